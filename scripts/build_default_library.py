#!/usr/bin/env python3
"""Build ``resources/materials/default.json``, Sheer's default (modelled) cosmetic material library.

No measured cosmetic spectra are openly available, so every material is modelled, and says so in its
provenance. For each shade:

1. a target colour (sRGB hex, the colour of the opaque product under D65) → CIE XYZ;
2. → a smooth reflectance spectrum R∞(λ) on 380–780 nm in 5 nm steps by colour-science's spectral
   recovery (Jakob & Hanika 2019: a sigmoid of a quadratic, so smooth and strictly inside (0, 1));
3. → K/S(λ) from R∞ = 1 + K/S − √((K/S)² + 2K/S) inverted, i.e. K/S = (1 − R∞)² / (2 R∞);
4. → S(λ) = S0 · (560 nm / λ) (scattering by sub-micron pigment falls with wavelength), K = S · K/S, with
   S0 chosen by bisection so that a layer of the category's reference thickness hides the category's
   fraction of the contrast between two skin-like backgrounds (reflectances 0.25 and 0.45), weighted by
   luminance (CIE ȳ · D65): foundation hides 50 % at 20 µm, and so on (:data:`HIDING`);
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

from km.library import Library  # noqa: E402
from km.material import Material, Measurement  # noqa: E402
from km.measurements import CATEGORY_DEFAULTS  # noqa: E402
from km.spectra import DEFAULT_GRID  # noqa: E402

DEFAULT_OUT = ROOT / "resources" / "materials" / "default.json"
#: 380–780 nm in 5 nm steps (the paper's measurement grid)
WAVELENGTHS = np.array(DEFAULT_GRID.wavelengths)
#: Skin-like background reflectances between which the hiding power is measured.
CONTRAST_BACKGROUNDS = (0.25, 0.45)
#: Measurement thicknesses tried, largest first (mm).
MEASUREMENT_D_MM = (0.15, 0.1, 0.05, 0.03, 0.02, 0.01, 0.005)
#: S(λ) = S0 · (REFERENCE_NM / λ) ** SCATTER_EXPONENT.
REFERENCE_NM = 560.0
SCATTER_EXPONENT = 1.0
SIGNIFICANT_DIGITS_MEASUREMENT = 9
SIGNIFICANT_DIGITS_SK = 10


@dataclass(frozen=True)
class Hiding:
    """A category's hiding criterion: a layer of ``at_um`` µm hides ``fraction`` of the background contrast."""

    fraction: float
    at_um: float
    why: str


HIDING: dict[str, Hiding] = {
    "foundation": Hiding(0.50, 20.0, "foundation evens skin: hides half the skin contrast at 20 µm"),
    "concealer": Hiding(0.75, 25.0, "concealer covers spots: hides 75 % of the skin contrast at 25 µm"),
    "blush": Hiding(0.15, 10.0, "blush is sheer: hides only 15 % of the skin contrast at 10 µm"),
    "bronzer": Hiding(0.25, 10.0, "bronzer is sheer: hides 25 % of the skin contrast at 10 µm"),
    "highlighter": Hiding(0.30, 8.0, "highlighter is a thin veil: hides 30 % of the skin contrast at 8 µm"),
    "lipstick": Hiding(0.85, 15.0, "lipstick is strongly coloured: hides 85 % of the lip contrast at 15 µm"),
    "eyeshadow": Hiding(0.60, 10.0, "eye shadow is buildable: hides 60 % of the skin contrast at 10 µm"),
    "eyeliner": Hiding(0.90, 10.0, "eyeliner is dense: hides 90 % of the skin contrast at 10 µm"),
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
#: Shades whose hiding power is not their category's (name -> criterion).
SHADE_HIDING: dict[str, Hiding] = {
    "Lipstick Red Matte": Hiding(0.92, 15.0, "a matte lipstick is the most pigmented: hides 92 % of the lip "
                                 "contrast at 15 µm"),
    "Lipstick Sheer Red": Hiding(0.25, 15.0, "a sheer tint lets the lip show: hides only 25 % of the lip "
                                 "contrast at 15 µm"),
}


def finish_of(roughness: float) -> str:
    """The finish a Beckmann roughness reads as: "matte" (≥ 0.4), "gloss" (< 0.12) or "satin"."""
    return "matte" if roughness >= 0.4 else "gloss" if roughness < 0.12 else "satin"


def hiding_for(name: str, category: str) -> Hiding:
    """The hiding criterion of shade ``name`` (its own, else its category's)."""
    return SHADE_HIDING.get(name, HIDING[category])


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


def luminance_weights() -> np.ndarray:
    """CIE 1931 ȳ(λ) · D65(λ), normalised to sum 1, on :data:`WAVELENGTHS`."""
    import colour

    shape = colour.SpectralShape(float(WAVELENGTHS[0]), float(WAVELENGTHS[-1]), 5.0)
    ybar = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape).values[:, 1]
    d65 = colour.SDS_ILLUMINANTS["D65"].copy().align(shape).values
    w = ybar * d65
    return w / w.sum()


def contrast_passed(s: np.ndarray, k: np.ndarray, x_mm: float, weights: np.ndarray) -> float:
    """Luminance-weighted fraction of the background contrast a layer lets through (1 = clear, 0 = opaque)."""
    from km.optics import layer_rt, over

    r0, t = layer_rt(s, k, x_mm)
    a, b = CONTRAST_BACKGROUNDS
    passed = (over(r0, t, np.full_like(s, b)) - over(r0, t, np.full_like(s, a))) / (b - a)
    return float(np.sum(weights * passed))


def scattering_for_hiding(ks: np.ndarray, hiding: Hiding, weights: np.ndarray) -> np.ndarray:
    """S(λ) (per mm) of the spectral shape (560/λ)^p whose layer meets ``hiding``, by bisection on log S0."""
    shape = (REFERENCE_NM / WAVELENGTHS) ** SCATTER_EXPONENT
    target = 1.0 - hiding.fraction
    lo, hi = np.log(1e-3), np.log(1e6)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        s = np.exp(mid) * shape
        if contrast_passed(s, ks * s, hiding.at_um / 1000.0, weights) > target:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-12:
            break
    return np.exp(0.5 * (lo + hi)) * shape


def build_material(name: str, category: str, hex_colour: str, note: str, weights: np.ndarray) -> Material:
    """One modelled material (see the module docstring for the route)."""
    from km.optics import invert_sk, ks_from_r_inf, layer_rt, over

    hiding = hiding_for(name, category)
    r_inf = round_sig(reflectance_from_hex(hex_colour), SIGNIFICANT_DIGITS_MEASUREMENT)
    ks = ks_from_r_inf(r_inf)
    s_model = scattering_for_hiding(ks, hiding, weights)
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
    thickness, max_thickness, roughness, ior = CATEGORY_DEFAULTS[category]
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
        f"S(lambda) = S0 * (560 nm / lambda), S0 set so that {hiding.why} (luminance-weighted contrast "
        f"between backgrounds of reflectance {CONTRAST_BACKGROUNDS[0]:g} and {CONTRAST_BACKGROUNDS[1]:g}) -> "
        f"synthetic measurement: R_inf, R over a matte black card (Rg 0.040-0.048) at D = {d_mm:g} mm{thinner}, "
        f"rounded to {SIGNIFICANT_DIGITS_MEASUREMENT} significant digits -> S, K re-derived from that triplet "
        f"with km.invert_sk (Huang et al. 2013, Eq. 6-7). {finish_text}; the roughness and index of refraction "
        "are typical values for the finish, not measured. Built by scripts/build_default_library.py."
    )
    measurement = Measurement(WAVELENGTHS, r_inf, r, rg, d_mm, instrument="none (synthetic, modelled)",
                              illuminant="D65")
    return Material(name=name, category=category, wavelengths=WAVELENGTHS, S=s, K=k, thickness_um=thickness,
                    max_thickness_um=max_thickness, roughness=roughness, ior=ior, source="modelled",
                    provenance=provenance, measurement=measurement)


def build_library(shades: tuple[tuple[str, str, str, str], ...] = SHADES) -> Library:
    """The default library (or one of ``shades``)."""
    weights = luminance_weights()
    lib = Library(name="Sheer default materials (modelled)")
    for name, category, hex_colour, note in shades:
        lib.add(build_material(name, category, hex_colour, note, weights))
    return lib


def build_text(shades: tuple[tuple[str, str, str, str], ...] = SHADES) -> str:
    """The file content :func:`build_library` saves."""
    return build_library(shades).dumps()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"output file (default {DEFAULT_OUT})")
    parser.add_argument("--check", action="store_true", help="compare with the file instead of writing it")
    args = parser.parse_args(argv)
    text = build_text()
    if args.check:
        current = args.out.read_text(encoding="utf-8") if args.out.exists() else ""
        if current != text:
            print(f"{args.out} is out of date: run scripts/build_default_library.py", file=sys.stderr)
            return 1
        print(f"{args.out} is up to date")
        return 0
    from core.atomicio import atomic_write_text

    atomic_write_text(args.out, text)
    print(f"wrote {args.out} ({text.count(chr(10))} lines)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
