"""Shade finder: which foundation of a library, at which thickness, looks right on this skin, under these lights.

For every foundation (a material whose category is ``foundation``) the made-up skin is predicted
spectrally with the project's Kubelka–Munk optics — the foundation layer (:func:`km.optics.layer_rt`)
over the skin's reflectance (:func:`km.optics.over`) — and scored by ΔE2000 against a target spectrum
(by default the skin itself: a foundation that "disappears") under a chosen illuminant. The thickness
is searched within the material's range; the **metamerism check** then scores the same made-up skin
under daylight (D65), a store light and warm indoor light (A): a shade whose ΔE2000 changes by more
than :data:`METAMERISM_DE2000` between them "matches in the store, not outside".

Thickness range: from :data:`MIN_THICKNESS_FRACTION` of the material's default thickness (a foundation
is worn to cover; without a floor, "no foundation" would always match one's own skin best) to its
``max_thickness_um``. Search: a grid of :data:`GRID_POINTS` thicknesses (denser where thin layers change
the colour fastest), then a golden-section search in the bracket around the grid's best, vectorised
over skins and foundations (the whole library at once).

Units: thickness in µm, wavelengths in nm, reflectances in [0, 1], ΔE2000 unit 1.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from core.errors import SheerError
from km.colour import delta_e2000, spectrum_to_rgb, supported_illuminants
from km.optics import KMDomainError, layer_rt, over
from km.skin import SkinFit, fit_skin, lab_of
from km.spectra import DEFAULT_GRID, WavelengthGrid
from km.srgb import srgb_encode

if TYPE_CHECKING:
    from pathlib import Path

    from km.library import Library
    from km.material import Material

__all__ = [
    "ShadeError", "ShadeBank", "ShadeMatch", "Target", "foundations", "best_thickness", "match_shades",
    "make_target", "resolve_light", "METAMERISM_DE2000", "DEFAULT_STORE_LIGHT", "TARGET_SHIFTS",
    "Confidence", "confidence", "FAIR_FIT_DE2000",
]

FloatArray = NDArray[np.float64]

#: A shade is flagged metameric when its ΔE2000 differs by more than this between the check lights.
METAMERISM_DE2000 = 1.5
#: The store's light by default: CIE F11, a narrow tri-band fluorescent (the TL84 of retail lighting and
#: colour-assessment booths), the usual store light that is least like daylight.
DEFAULT_STORE_LIGHT = "F11"
#: The thinnest layer searched, as a fraction of the material's default ``thickness_um``.
MIN_THICKNESS_FRACTION = 0.5
#: Thicknesses of the coarse search, and golden-section steps after it (the bracket shrinks by 0.618 each).
GRID_POINTS = 24
GOLDEN_STEPS = 22
#: Named targets: a CIELAB shift (ΔL*, Δa*, Δb*) from the skin's own colour, about one step of a
#: foundation range (ranges step by 3–5 L*); the target spectrum is the skin model fitted to the shifted colour.
TARGET_SHIFTS: dict[str, tuple[float, float, float]] = {
    "own": (0.0, 0.0, 0.0), "lighter": (3.0, 0.0, 0.0), "darker": (-3.0, 0.0, 0.0),
    "warmer": (0.0, 1.0, 3.0), "cooler": (0.0, -0.5, -3.0),
}
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
#: The skin fit's residual (ΔE2000) up to which a match is of "medium" confidence: the model's known limit
#: (no carotene: light, very yellow skins fit with a residual of 1–3; :mod:`km.skin`). Up to
#: :data:`km.skin.GAMUT_DE2000` it is "high"; above this, "low".
FAIR_FIT_DE2000 = 3.0


class ShadeError(SheerError, ValueError):
    """Shade finder input that cannot be used (no foundation in the library, a bad target or light…)."""


def foundations(library: Library) -> list[Material]:
    """The library's foundations (category ``foundation``), in library order.

    Raises:
        ShadeError: the library holds none (the message names the library).
    """
    found = library.by_category("foundation")
    if not found:
        where = str(library.path) if library.path else (library.name or "the library")
        raise ShadeError(f"{where}: no foundation in the library (no material has category 'foundation'; "
                         f"categories present: {', '.join(library.categories()) or 'none'})")
    return found


# --------------------------------------------------------------------------------------------------
# Lights
# --------------------------------------------------------------------------------------------------


def resolve_light(spec: str) -> str:
    """An illuminant name km.colour accepts, from a name (D65, A, F11, LED-B3…) or a spectrum file.

    A file (CSV: ``wavelength_nm,power`` rows, ``#`` comments and a header allowed, ≥ 2 rows within
    300–830 nm, power ≥ 0 and not all 0) is registered in colour-science's illuminant table under
    ``file:<name>:<hash>`` so that :mod:`km.colour` converts with it like any CIE illuminant (the hash
    of the content keeps km.colour's per-name caches right when a file changes).

    Raises:
        ShadeError: an unknown name, or an unreadable or malformed file.
    """
    from pathlib import Path

    names = set(supported_illuminants())
    if spec in names:
        return spec
    path = Path(spec)
    if not path.suffix and not path.exists():
        raise ShadeError(f"unknown light {spec!r}: use a CIE name (D65, A, F2, F11, LED-B3…) or a spectrum "
                         "file wavelength_nm,power")
    return _register_light_file(path)


def _register_light_file(path: Path) -> str:
    import colour

    from core.files import read_bounded

    raw = read_bounded(path, 4 << 20, "light spectrum", ShadeError)
    rows = []
    for n, line in enumerate(raw.decode("utf-8", "replace").splitlines(), 1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        parts = [p.strip() for p in text.replace(";", ",").split(",")]
        try:
            rows.append((float(parts[0]), float(parts[1])))
        except (ValueError, IndexError):
            if rows:  # a header is allowed before the data only
                raise ShadeError(f"{path}: line {n}: expected 'wavelength_nm,power', got {text!r}") from None
    data = np.array(rows, dtype=np.float64).reshape(-1, 2)
    if data.shape[0] < 2 or not np.isfinite(data).all() or (np.diff(data[:, 0]) <= 0).any() \
            or (data[:, 1] < 0).any() or not (data[:, 1] > 0).any() or data[0, 0] < 300 or data[-1, 0] > 830:
        raise ShadeError(f"{path}: a light spectrum needs ≥ 2 rows wavelength_nm,power with increasing "
                         "wavelengths within 300–830 nm and non-negative powers, not all zero")
    name = f"file:{path.name}:{hashlib.sha1(data.tobytes()).hexdigest()[:10]}"
    if name not in colour.SDS_ILLUMINANTS:
        sd = colour.SpectralDistribution(dict(zip(data[:, 0], data[:, 1])), name=name)
        colour.SDS_ILLUMINANTS[name] = sd  # registered once: km.colour looks illuminants up by name
    return name


# --------------------------------------------------------------------------------------------------
# The foundations, ready for vectorised evaluation
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ShadeBank:
    """Foundations on one wavelength grid: S and K (M, n) per mm, thickness bounds (M,) in µm, names.

    Build with :meth:`from_materials`; a bank may also be made directly (the gap suggestion builds
    one from a mixture).
    """

    names: tuple[str, ...]
    S: FloatArray
    K: FloatArray
    t_lo_um: FloatArray
    t_hi_um: FloatArray
    grid: WavelengthGrid = DEFAULT_GRID

    @classmethod
    def from_materials(cls, materials: list[Material], grid: WavelengthGrid = DEFAULT_GRID,
                       min_fraction: float = MIN_THICKNESS_FRACTION) -> ShadeBank:
        """The bank of ``materials`` resampled onto ``grid``; thickness from ``min_fraction`` × default."""
        if not materials:
            raise ShadeError("no foundation to match")
        if not 0.0 < min_fraction <= 1.0:
            raise ShadeError(f"the thinnest layer must be a fraction in (0, 1] of the default, got {min_fraction}")
        on = [m.on_wavelengths(grid.wavelengths) for m in materials]
        return cls(names=tuple(m.name for m in on), S=np.stack([m.S for m in on]), K=np.stack([m.K for m in on]),
                   t_lo_um=np.array([m.thickness_um * min_fraction for m in on]),
                   t_hi_um=np.array([m.max_thickness_um for m in on]), grid=grid)

    def made_up(self, skin: FloatArray, thickness_um: FloatArray) -> FloatArray:
        """Reflectance of each foundation over ``skin``: skin (N, n), thickness (N, M) µm → (N, M, n)."""
        R0, T = layer_rt(self.S, self.K, np.asarray(thickness_um, dtype=np.float64)[..., None] * 1e-3)
        return over(R0, T, np.asarray(skin, dtype=np.float64)[:, None, :])


def _de(bank: ShadeBank, skin: FloatArray, target_lab: FloatArray, t_um: FloatArray, illuminant: str) -> FloatArray:
    """ΔE2000 (N, M) of the made-up skins at ``t_um`` (N, M) against ``target_lab`` (N, 3)."""
    return delta_e2000(lab_of(bank.made_up(skin, t_um), illuminant, bank.grid), target_lab[:, None, :])


def best_thickness(bank: ShadeBank, skin: FloatArray, target: FloatArray, illuminant: str = "D65",
                   chunk: int = 64, golden_steps: int = GOLDEN_STEPS) -> tuple[FloatArray, FloatArray]:
    """The thickness (µm) of each foundation that brings each skin closest to its target, and that ΔE2000.

    ============ ====== ===============================================================
    argument     unit   meaning
    ============ ====== ===============================================================
    skin         1      (N, n) skin reflectances on ``bank.grid``
    target       1      (N, n) target reflectances (the colour to reach, as a spectrum)
    illuminant   -      the light the colours are compared under (relative to its white)
    chunk        skins  evaluated together (bounds the memory: chunk × M × GRID_POINTS × n)
    golden_steps -      golden-section steps after the grid (0: the grid's best only)
    ============ ====== ===============================================================

    Returns ``(thickness_um, de2000)``, each (N, M). Grid search then golden section (module docstring).
    """
    skin = np.atleast_2d(np.asarray(skin, dtype=np.float64))
    target = np.atleast_2d(np.asarray(target, dtype=np.float64))
    n_skins, n_mat = skin.shape[0], len(bank.names)
    u = (np.arange(GRID_POINTS) / (GRID_POINTS - 1)) ** 2
    t_grid = bank.t_lo_um[:, None] + (bank.t_hi_um - bank.t_lo_um)[:, None] * u  # (M, G)
    R0g, Tg = layer_rt(bank.S[:, None, :], bank.K[:, None, :], t_grid[..., None] * 1e-3)  # (M, G, n)
    t_out = np.empty((n_skins, n_mat))
    de_out = np.empty((n_skins, n_mat))
    idx = np.arange(n_mat)
    for lo in range(0, n_skins, chunk):
        sk, tg = skin[lo:lo + chunk], target[lo:lo + chunk]
        target_lab = lab_of(tg, illuminant, bank.grid)
        made = over(R0g, Tg, sk[:, None, None, :])  # (c, M, G, n)
        de_grid = delta_e2000(lab_of(made, illuminant, bank.grid), target_lab[:, None, None, :])
        k = np.argmin(de_grid, axis=2)  # (c, M)
        if golden_steps == 0:
            t_out[lo:lo + chunk] = t_grid[idx, k]
            de_out[lo:lo + chunk] = np.min(de_grid, axis=2)
            continue
        a = t_grid[idx, np.maximum(k - 1, 0)]
        b = t_grid[idx, np.minimum(k + 1, GRID_POINTS - 1)]
        # golden section on [a, b]
        x1 = b - _GOLDEN * (b - a)
        x2 = a + _GOLDEN * (b - a)
        f1 = _de(bank, sk, target_lab, x1, illuminant)
        f2 = _de(bank, sk, target_lab, x2, illuminant)
        for _ in range(golden_steps):
            left = f1 <= f2
            b = np.where(left, x2, b)
            a = np.where(left, a, x1)
            x_new = np.where(left, b - _GOLDEN * (b - a), a + _GOLDEN * (b - a))
            f_new = _de(bank, sk, target_lab, x_new, illuminant)
            x2, f2, x1, f1 = (np.where(left, x1, x_new), np.where(left, f1, f_new),
                              np.where(left, x_new, x2), np.where(left, f_new, f2))
        cand_t = np.stack([x1, x2, t_grid[idx, k]], axis=-1)
        cand_f = np.stack([f1, f2, de_grid[np.arange(len(sk))[:, None], idx, k]], axis=-1)
        j = np.argmin(cand_f, axis=-1)[..., None]
        t_out[lo:lo + chunk] = np.take_along_axis(cand_t, j, -1)[..., 0]
        de_out[lo:lo + chunk] = np.take_along_axis(cand_f, j, -1)[..., 0]
    return t_out, de_out


# --------------------------------------------------------------------------------------------------
# Targets
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Target:
    """What the made-up skin should look like: a spectrum, how it was made and the fit behind it.

    Attributes:
        name: ``own``, ``lighter``, …, or ``lab:L,a,b`` / ``rgb:R,G,B`` as given.
        reflectance: the target spectrum on the skin's grid (fractions).
        lab: its CIELAB under D65.
        fit: the skin-model fit that made the spectrum (None for ``own``: the skin itself).
    """

    name: str
    reflectance: FloatArray
    lab: FloatArray
    fit: SkinFit | None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready: name, Lab, and the residual of the fit that made it (if any)."""
        out: dict[str, Any] = {"name": self.name, "lab": [round(float(v), 3) for v in self.lab]}
        if self.fit is not None:
            out["fit_residual_de2000"] = round(self.fit.residual_de2000, 4)
            out["out_of_gamut"] = self.fit.out_of_gamut
        return out


def _three_numbers(text: str, what: str) -> tuple[float, float, float]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise ShadeError(f"target {what}: expected three numbers separated by commas, got {text!r}")
    return values


def make_target(spec: str, skin: SkinFit) -> Target:
    """The target spectrum for ``spec``, given the person's fitted skin.

    ``spec``: one of :data:`TARGET_SHIFTS` (``own`` is the skin's own spectrum; the others shift its
    colour and fit the skin model to the result), ``lab:L,a,b`` (CIELAB, D65) or ``rgb:R,G,B`` (8-bit
    sRGB). Raises :class:`ShadeError` for anything else.
    """
    from km.skin import SkinError

    key = spec.strip().lower()
    if key == "own":
        return Target("own", skin.reflectance, skin.lab, None)
    if key in TARGET_SHIFTS:
        lab = skin.lab + np.asarray(TARGET_SHIFTS[key])
    elif key.startswith("lab:"):
        lab = np.asarray(_three_numbers(key[4:], "lab"))
    elif key.startswith("rgb:"):
        rgb = np.asarray(_three_numbers(key[4:], "rgb"))
        if (rgb < 0).any() or (rgb > 255).any():
            raise ShadeError(f"target rgb: each value must be in 0..255, got {key[4:]}")
        from km.colour import linear_rgb_to_lab
        from km.srgb import srgb_decode

        lab = linear_rgb_to_lab(srgb_decode(rgb / 255.0))
    else:
        raise ShadeError(f"unknown target {spec!r}: use {', '.join(TARGET_SHIFTS)}, lab:L,a,b or rgb:R,G,B")
    try:
        fit = fit_skin(lab, oxygenation=skin.params.oxygenation, grid=skin.grid)
    except SkinError as exc:
        raise ShadeError(f"target {spec!r}: {exc}") from None
    return Target(key, fit.reflectance, fit.lab, fit)


# --------------------------------------------------------------------------------------------------
# The match
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Confidence:
    """How far a match can be trusted: how close the skin model came to the colour it was given.

    The shades are ranked on the skin the model fitted, so a colour the model cannot make (a photograph's
    light, white balance, make-up or shadow, or a colour that is not skin) is matched through the closest
    skin it can, and the match is only as good as that fit.

    Attributes:
        level: ``high`` (the fit's residual within :data:`km.skin.GAMUT_DE2000`: a skin of the model),
            ``medium`` (within :data:`FAIR_FIT_DE2000`) or ``low`` (hard to read: confirm the shade in person).
        residual_de2000: the fit's residual.
        words: one sentence that says so.
    """

    level: str
    residual_de2000: float
    words: str

    @property
    def hard_to_read(self) -> bool:
        """Whether the skin was hard to read (``low``): the shade wants confirming in person."""
        return self.level == "low"

    def to_json(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {"level": self.level, "residual_de2000": round(self.residual_de2000, 3), "words": self.words}


def confidence(fit: SkinFit) -> Confidence:
    """The confidence of a match made on ``fit`` (see :class:`Confidence`): the command line's and the kiosk's."""
    from km.skin import GAMUT_DE2000

    de = float(fit.residual_de2000)
    if de <= GAMUT_DE2000:
        return Confidence("high", de, f"the skin model reproduces this colour (ΔE2000 {de:.1f})")
    if de <= FAIR_FIT_DE2000:
        return Confidence("medium", de, f"the closest skin the model can make is ΔE2000 {de:.1f} away (light, very "
                                        "yellow skins are its known limit): a close guide")
    lab = ", ".join(f"{v:.1f}" for v in fit.target_lab)
    return Confidence("low", de, f"hard to read: the colour (Lab {lab}) is ΔE2000 {de:.1f} from every skin the model "
                                 "can make (the light, the camera's white balance, make-up or shadow may have changed "
                                 "it); the closest skin is matched: confirm the shade in person")


@dataclass(frozen=True)
class ShadeMatch:
    """One foundation's best result on this skin.

    Attributes:
        name: the material's name.
        thickness_um: the best thickness (µm) under the main illuminant.
        de2000: ΔE2000 against the target under the main illuminant.
        de2000_by_illuminant: ΔE2000 at that thickness under each check light (by name).
        metameric: True when those differ by more than :data:`METAMERISM_DE2000`.
        reflectance: the made-up skin's spectrum (fractions, the skin's grid).
        swatch_hex: the made-up skin in sRGB under D65, ``#rrggbb``.
    """

    name: str
    thickness_um: float
    de2000: float
    de2000_by_illuminant: dict[str, float]
    metameric: bool
    reflectance: FloatArray
    swatch_hex: str

    def metamerism_words(self) -> str:
        """The metamerism warning in plain words ("" when the shade holds under every check light)."""
        if not self.metameric:
            return ""
        by = self.de2000_by_illuminant
        best = min(by, key=lambda k: by[k])
        worst = max(by, key=lambda k: by[k])
        names = {"D65": "daylight", "A": "warm indoor light"}
        return (f"matches best in {names.get(best, best)} but looks different in {names.get(worst, worst)} "
                f"(ΔE {by[best]:.1f} → {by[worst]:.1f})")

    def to_json(self) -> dict[str, Any]:
        """The issue's per-shade JSON: name, thickness_um, de2000, de2000_by_illuminant, metameric, swatch."""
        return {"name": self.name, "thickness_um": round(self.thickness_um, 3), "de2000": round(self.de2000, 4),
                "de2000_by_illuminant": {k: round(v, 4) for k, v in self.de2000_by_illuminant.items()},
                "metameric": self.metameric, "swatch_hex": self.swatch_hex}


def _hex(reflectance: FloatArray, grid: WavelengthGrid) -> list[str]:
    rgb = srgb_encode(np.clip(spectrum_to_rgb(reflectance, grid, "D65"), 0.0, 1.0))
    return ["#" + "".join(f"{round(float(c) * 255):02x}" for c in row) for row in np.atleast_2d(rgb)]


def match_shades(skin: FloatArray, target: FloatArray, bank: ShadeBank, *, illuminant: str = "D65",
                 lights: tuple[str, ...] = ("D65", DEFAULT_STORE_LIGHT, "A")) -> list[ShadeMatch]:
    """Every foundation of ``bank`` on one skin, best first (by ΔE2000 under ``illuminant``).

    ``skin`` and ``target`` are reflectances (n,) on ``bank.grid``; ``lights`` are the metamerism
    check's illuminants (names as :func:`resolve_light` returns). Raises :class:`ShadeError` for an
    unknown illuminant.
    """
    skin2 = np.asarray(skin, dtype=np.float64).reshape(1, -1)
    target2 = np.asarray(target, dtype=np.float64).reshape(1, -1)
    try:
        t, de = best_thickness(bank, skin2, target2, illuminant)
        made = bank.made_up(skin2, t)[0]  # (M, n)
        by_light = {name: delta_e2000(lab_of(made, name, bank.grid), lab_of(target2[0], name, bank.grid))
                    for name in dict.fromkeys(lights)}
    except KMDomainError as exc:
        raise ShadeError(str(exc)) from None
    spread = np.ptp(np.stack(list(by_light.values())), axis=0)
    swatches = _hex(made, bank.grid)
    out = [ShadeMatch(name=bank.names[m], thickness_um=float(t[0, m]), de2000=float(de[0, m]),
                      de2000_by_illuminant={k: float(v[m]) for k, v in by_light.items()},
                      metameric=bool(spread[m] > METAMERISM_DE2000), reflectance=made[m], swatch_hex=swatches[m])
           for m in range(len(bank.names))]
    return sorted(out, key=lambda s: (s.de2000, s.name))
