#!/usr/bin/env python3
"""Build ``resources/materials/default.json``, Sheer's default (modelled) cosmetic material library.

No measured cosmetic spectra are openly available, so every material is modelled, and says so in its
provenance. For each shade:

1. a target colour (sRGB hex, the colour of the opaque product under D65) → CIE XYZ;
2. → a smooth reflectance spectrum R∞(λ) on 380–780 nm in 5 nm steps by colour-science's spectral
   recovery (Jakob & Hanika 2019: a sigmoid of a quadratic, so smooth and strictly inside (0, 1));
3. → K/S(λ) from R∞ = 1 + K/S − √((K/S)² + 2K/S) inverted, i.e. K/S = (1 − R∞)² / (2 R∞);
4. → S(λ) = S0 · (560 nm / λ) (scattering by sub-micron pigment falls with wavelength), K = S · K/S, with
   S0 chosen by bisection so that a layer of the material's default thickness hides as its stated
   coverage says: its contrast ratio (Y over black / Y over white, CIE 1931 2°, D65: :mod:`km.coverage`)
   is the stated one — a cream lipstick is full coverage, 0.95 at 15 µm, a blush sheer, 0.3 at 10 µm, and
   so on (:data:`COVERAGE`, :data:`SHADE_COVERAGE`);
5. → the synthetic measurement of Huang et al. 2013 (Sect. 4): R∞, R of a layer of thickness D over a
   matte black card of reflectance Rg (D = 0.15 mm, or thinner when 0.15 mm would be opaque to within
   0.1 % so that R carries information), rounded to 9 significant digits as an instrument would report;
6. → S and K re-derived from that triplet with :func:`km.invert_sk` (Eq. 6–7) and stored, so the
   inversion path is exercised on every material.

The output is deterministic (shortest round-trip float repr of rounded values): running this script
reproduces the file byte for byte. Usage::

    python scripts/build_default_library.py            # rewrite resources/materials/default.json
    python scripts/build_default_library.py --check    # exit 1 if the file is not what this builds
    python scripts/build_default_library.py --out X.json
    python scripts/build_default_library.py --check --out A.json --out B.json   # one build, both files
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from km.coverage import Coverage, contrast_ratio  # noqa: E402
from km.library import Library  # noqa: E402
from km.material import Material, Measurement  # noqa: E402
from km.measurements import CATEGORY_DEFAULTS  # noqa: E402
from km.spectra import DEFAULT_GRID  # noqa: E402

DEFAULT_OUT = ROOT / "resources" / "materials" / "default.json"
#: 380–780 nm in 5 nm steps (the paper's measurement grid)
WAVELENGTHS = np.array(DEFAULT_GRID.wavelengths)
#: Measurement thicknesses tried, largest first (mm).
MEASUREMENT_D_MM = (0.15, 0.1, 0.05, 0.03, 0.02, 0.01, 0.005, 0.003, 0.002, 0.001, 0.0005, 0.0003, 0.0002, 0.0001)
#: S(λ) = S0 · (REFERENCE_NM / λ) ** SCATTER_EXPONENT.
REFERENCE_NM = 560.0
SCATTER_EXPONENT = 1.0
SIGNIFICANT_DIGITS_MEASUREMENT = 9
SIGNIFICANT_DIGITS_SK = 10


@dataclass(frozen=True)
class Stated:
    """A shade's stated coverage: its class and contrast ratio at its default thickness, and why."""

    level: str
    contrast_ratio: float
    why: str


#: Each category's usual coverage (the contrast ratio at the category's default thickness,
#: km.measurements.CATEGORY_DEFAULTS), as products of the kind are sold and worn.
COVERAGE: dict[str, Stated] = {
    "foundation": Stated("sheer", 0.35, "a light-coverage liquid foundation evens the skin and lets it show "
                         "through; dark shades hide as much as light ones"),
    "concealer": Stated("full", 0.92, "a concealer covers: full coverage"),
    "blush": Stated("sheer", 0.3, "a blush is sheer: a wash of colour the skin shows through"),
    "bronzer": Stated("sheer", 0.35, "a bronzer is sheer: a warm wash the skin shows through"),
    "highlighter": Stated("sheer", 0.3, "a highlighter is a sheer veil"),
    "lipstick": Stated("full", 0.95, "a cream lipstick is full coverage: as applied it is its bullet's colour"),
    "eyeshadow": Stated("medium", 0.7, "a pressed eye shadow is buildable, medium coverage: its own colour with "
                        "the lid a little beneath"),
    "eyeliner": Stated("full", 0.95, "a liner is dense: full coverage"),
}

#: (name, category, target colour of the opaque product as sRGB hex, note)
SHADES: tuple[tuple[str, str, str, str], ...] = (
    ("Foundation Porcelain", "foundation", "#F0D5C2", "very light, neutral-pink undertone"),
    ("Foundation Ivory", "foundation", "#E8C4A6", "light, warm undertone"),
    ("Foundation Beige", "foundation", "#D6A683", "light-medium, neutral undertone"),
    ("Foundation Honey", "foundation", "#BF8A62", "medium, golden undertone"),
    ("Foundation Caramel", "foundation", "#9C6A46", "tan, warm undertone"),
    ("Foundation Espresso", "foundation", "#5F3E2B", "deep, neutral undertone"),
    ("Concealer Light", "concealer", "#EDCDB0", "light, peach-corrected"),
    ("Concealer Medium", "concealer", "#C99570", "medium"),
    ("Blush Rose", "blush", "#D9707E", "cool pink"),
    ("Blush Peach", "blush", "#EE9274", "warm peach"),
    ("Blush Berry", "blush", "#B3506A", "deep berry"),
    ("Bronzer Sun", "bronzer", "#A86D4A", "warm matte bronze"),
    ("Highlighter Champagne", "highlighter", "#F3DCC0",
     "the pearl/metallic sparkle of real highlighters is not modelled (KM layers are diffuse)"),
    ("Lipstick Classic Red", "lipstick", "#B3192A", "blue-red"),
    ("Lipstick Nude", "lipstick", "#B67A68", "pink-beige nude"),
    ("Lipstick Pink", "lipstick", "#D65A88", "bright pink"),
    ("Lipstick Coral", "lipstick", "#E0564A", "orange-red coral"),
    ("Lipstick Berry", "lipstick", "#7A1F40", "deep berry"),
    ("Lipstick Mauve", "lipstick", "#9C5A6B", "muted mauve"),
    ("Lipstick Brick", "lipstick", "#8A3325", "brown-red"),
    ("Eyeshadow Taupe", "eyeshadow", "#8C7466", "matte grey-brown"),
    ("Eyeshadow Bronze", "eyeshadow", "#8A5A33", "matte warm bronze (no metallic effect modelled)"),
    ("Eyeshadow Plum", "eyeshadow", "#5E3650", "matte plum"),
    ("Eyeshadow Navy", "eyeshadow", "#2E3A5C", "matte navy"),
    ("Eyeliner Black", "eyeliner", "#1C1B1D", "carbon black"),
    ("Eyeliner Brown", "eyeliner", "#3E2A20", "dark brown"),
    ("Lipstick Red Matte", "lipstick", "#B3192A", "the classic blue-red in a matte formula"),
    ("Lipstick Red Satin", "lipstick", "#B3192A", "the classic blue-red in a satin formula"),
    ("Lipstick Red Gloss", "lipstick", "#B3192A", "the classic blue-red in a glossy formula"),
    ("Lipstick Sheer Red", "lipstick", "#B3192A", "a sheer red tint (a tinted balm): the lip shows through"),
)


@dataclass(frozen=True)
class Finish:
    """A surface finish: the layer's specular lobe (Kelemen, Beckmann roughness ``roughness``) and its IOR."""

    roughness: float
    ior: float
    why: str


#: The finishes a material states. A material's finish is the one its roughness falls in
#: (:func:`finish_of`): matte ≥ 0.4, gloss < 0.12, satin between.
FINISHES: dict[str, Finish] = {
    "matte": Finish(0.45, 1.50, "a broad, dim sheen and no sharp highlight"),
    "satin": Finish(0.20, 1.50, "a soft highlight"),
    "gloss": Finish(0.07, 1.55, "a sharp, bright highlight (the oily base's index of refraction 1.55)"),
}
#: Shades whose finish is not their category's usual one (name -> finish).
SHADE_FINISHES: dict[str, str] = {
    "Lipstick Red Matte": "matte", "Lipstick Red Satin": "satin", "Lipstick Red Gloss": "gloss",
    "Lipstick Sheer Red": "satin",
}
#: Shades whose coverage is not their category's (name -> statement).
SHADE_COVERAGE: dict[str, Stated] = {
    "Lipstick Red Matte": Stated("full", 0.98, "a matte lipstick is the most pigmented: full coverage"),
    "Lipstick Red Satin": Stated("full", 0.92, "a satin lipstick is full coverage, a little less pigmented than "
                                 "the matte"),
    "Lipstick Red Gloss": Stated("medium", 0.7, "a glossy lipstick carries less pigment in its oils: medium "
                                 "coverage"),
    "Lipstick Sheer Red": Stated("sheer", 0.03, "a sheer tint (a tinted balm): the lip shows through"),
}


def finish_of(roughness: float) -> str:
    """The finish a Beckmann roughness reads as: "matte" (≥ 0.4), "gloss" (< 0.12) or "satin"."""
    return "matte" if roughness >= 0.4 else "gloss" if roughness < 0.12 else "satin"


def coverage_for(name: str, category: str) -> Stated:
    """The stated coverage of shade ``name`` (its own, else its category's)."""
    return SHADE_COVERAGE.get(name, COVERAGE[category])


def black_card() -> np.ndarray:
    """Reflectance of the matte black card the synthetic R is 'measured' over (≈ 0.040–0.048)."""
    return 0.040 + 0.008 * (WAVELENGTHS - 380.0) / 400.0


def round_sig(values: np.ndarray, digits: int) -> np.ndarray:
    """Round to ``digits`` significant digits through decimal text (deterministic, platform-independent)."""
    return np.array([float(f"{float(v):.{digits}g}") for v in np.ravel(values)]).reshape(np.shape(values))


def reflectance_from_hex(hex_colour: str) -> np.ndarray:
    """A smooth reflectance R∞(λ) on :data:`WAVELENGTHS` whose colour under D65 is ``hex_colour`` (sRGB)."""
    import colour

    shape = colour.SpectralShape(float(WAVELENGTHS[0]), float(WAVELENGTHS[-1]), 5.0)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    illuminant = colour.SDS_ILLUMINANTS["D65"].copy().align(shape)
    encoded = colour.notation.HEX_to_RGB(hex_colour)
    xyz = colour.RGB_to_XYZ(colour.cctf_decoding(encoded, function="sRGB"), "sRGB")
    sd = colour.XYZ_to_sd(xyz, method="Jakob 2019", cmfs=cmfs, illuminant=illuminant)
    return np.asarray(sd.values, dtype=np.float64)


def scattering_for_coverage(ks: np.ndarray, stated: Stated, at_um: float) -> np.ndarray:
    """S(λ) (per mm) of the spectral shape (560/λ)^p whose layer of ``at_um`` µm has the stated contrast ratio.

    Bisection on log S0: the contrast ratio grows with S0 (at a fixed K/S, the layer's optical depth).
    """
    shape = (REFERENCE_NM / WAVELENGTHS) ** SCATTER_EXPONENT
    lo, hi = np.log(1e-3), np.log(1e7)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        s = np.exp(mid) * shape
        if contrast_ratio(WAVELENGTHS, s, ks * s, at_um) < stated.contrast_ratio:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-12:
            break
    return np.exp(0.5 * (lo + hi)) * shape


def build_material(name: str, category: str, hex_colour: str, note: str) -> Material:
    """One modelled material (see the module docstring for the route)."""
    from km.optics import invert_sk, ks_from_r_inf, layer_rt, over

    stated = coverage_for(name, category)
    thickness, max_thickness, roughness, ior = CATEGORY_DEFAULTS[category]
    r_inf = round_sig(reflectance_from_hex(hex_colour), SIGNIFICANT_DIGITS_MEASUREMENT)
    ks = ks_from_r_inf(r_inf)
    s_model = scattering_for_coverage(ks, stated, thickness)
    k_model = ks * s_model
    rg = round_sig(black_card(), SIGNIFICANT_DIGITS_MEASUREMENT)
    for d_mm in MEASUREMENT_D_MM:
        r0, t = layer_rt(s_model, k_model, d_mm)
        r = round_sig(over(r0, t, rg), SIGNIFICANT_DIGITS_MEASUREMENT)
        gap = (r_inf - r) / (r_inf - rg)
        if np.all(gap > 1e-3):
            break
    else:  # pragma: no cover - every shade in SHADES has a usable thickness
        raise RuntimeError(f"{name}: no measurement thickness leaves R distinguishable from R∞")
    s, k = invert_sk(r_inf, r, rg, d_mm, wavelengths=WAVELENGTHS)
    s = round_sig(s, SIGNIFICANT_DIGITS_SK)
    k = round_sig(k, SIGNIFICANT_DIGITS_SK)
    if name in SHADE_FINISHES:
        roughness, ior = FINISHES[SHADE_FINISHES[name]].roughness, FINISHES[SHADE_FINISHES[name]].ior
    finish = finish_of(roughness)
    finish_text = (f"Finish: {finish} (Beckmann roughness {roughness:g}, index of refraction {ior:g}: "
                   f"{FINISHES[finish].why})")
    thinner = "" if d_mm == MEASUREMENT_D_MM[0] else (
        f" (D = {d_mm:g} mm rather than 0.15 mm, because a 0.15 mm layer of this shade would be opaque to "
        "within 0.1 % and R would carry no information)")
    provenance = (
        f"Modelled, not measured: no measured cosmetic spectra are openly available. {note[0].upper()}{note[1:]}. "
        f"Target colour {hex_colour} (sRGB, the opaque product under D65) -> smooth reflectance R_inf by "
        "colour-science's Jakob 2019 spectral recovery (CIE 1931 2 deg, D65) -> K/S from R_inf -> "
        f"S(lambda) = S0 * (560 nm / lambda), S0 set so that a layer of its default {thickness:g} um hides as its "
        f"stated coverage says ({stated.level}: {stated.why}): contrast ratio {stated.contrast_ratio:g} (Y over "
        "black / Y over white, CIE 1931 2 deg, D65) -> "
        f"synthetic measurement: R_inf, R over a matte black card (Rg 0.040-0.048) at D = {d_mm:g} mm{thinner}, "
        f"rounded to {SIGNIFICANT_DIGITS_MEASUREMENT} significant digits -> S, K re-derived from that triplet "
        f"with km.invert_sk (Huang et al. 2013, Eq. 6-7). {finish_text}; the roughness and index of refraction "
        "are typical values for the finish, not measured. Built by scripts/build_default_library.py."
    )
    measurement = Measurement(WAVELENGTHS, r_inf, r, rg, d_mm, instrument="none (synthetic, modelled)",
                              illuminant="D65")
    coverage = Coverage(stated.level, stated.contrast_ratio,
                        f"Modelled, stated for the kind of product ({stated.why}); S and K are set to give it "
                        "(scripts/build_default_library.py)")
    return Material(name=name, category=category, wavelengths=WAVELENGTHS, S=s, K=k, thickness_um=thickness,
                    max_thickness_um=max_thickness, roughness=roughness, ior=ior, source="modelled",
                    provenance=provenance, measurement=measurement, coverage=coverage)


def build_library(shades: tuple[tuple[str, str, str, str], ...] = SHADES) -> Library:
    """The default library (or one of ``shades``)."""
    lib = Library(name="Sheer default materials (modelled)")
    for name, category, hex_colour, note in shades:
        lib.add(build_material(name, category, hex_colour, note))
    return lib


def build_text(shades: tuple[tuple[str, str, str, str], ...] = SHADES) -> str:
    """The file content :func:`build_library` saves."""
    return build_library(shades).dumps()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, action="append",
                        help=f"output file (default {DEFAULT_OUT}); given again, each of them (one build)")
    parser.add_argument("--check", action="store_true",
                        help="compare with the file(s) instead of writing: exit 1 if any is out of date")
    args = parser.parse_args(argv)
    outs: list[Path] = args.out or [DEFAULT_OUT]
    text = build_text()
    if args.check:
        stale = 0
        for out in outs:
            current = out.read_text(encoding="utf-8") if out.exists() else ""
            if current != text:
                print(f"{out} is out of date: run scripts/build_default_library.py", file=sys.stderr)
                stale += 1
            else:
                print(f"{out} is up to date")
        return 1 if stale else 0
    from core.atomicio import atomic_write_text

    for out in outs:
        atomic_write_text(out, text)
        print(f"wrote {out} ({text.count(chr(10))} lines)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
