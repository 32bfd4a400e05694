"""A biophysical two-layer skin reflectance model, evaluated with the project's Kubelka–Munk optics.

The skin is an **epidermis** (melanin — a blend of eumelanin and pheomelanin — no blood) of fixed thickness over a semi-infinite **dermis**
(blood, partly oxygenated), the structure of the two-layer models of the skin-optics literature
(Donner & Jensen 2006, "A spectral BSSRDF for shading human skin", EGSR). Each layer's absorption and
reduced scattering coefficients come from the published spectra below; they are turned into KM
coefficients (K = 2 μa, S = ¾ μs′), the layers are combined with :func:`km.optics.layer_rt` and
:func:`km.optics.over`, and the air–skin surface is added with the Saunderson correction
(:func:`km.optics.saunderson`). The result is a diffuse reflectance in [0, 1] on any wavelength grid.

Parameters (:class:`SkinParams`; ranges in :data:`PARAM_RANGES`):

============ ===== ================================================================================
parameter    unit  meaning
============ ===== ================================================================================
melanin      1     volume fraction of melanosomes in the epidermis (Jacques 1998: light skin
                   1.3–6.3 %, moderately pigmented 11–16 %, darkly pigmented 18–43 %)
blood        1     volume fraction of whole blood in the dermis
oxygenation  1     fraction of the haemoglobin that is oxygenated (held in fits, default 0.75)
scattering   1     scale of the reduced scattering coefficient of both layers (1 = Jacques 1998)
pheomelanin  1     fraction of the melanin that is pheomelanin (the rest eumelanin; default 0.3)
============ ===== ================================================================================

:func:`fit_skin` fits melanin, blood, scattering and the pheomelanin fraction to a measured colour
(three numbers for four unknowns: weak priors towards scattering 1 and pheomelanin 0.3 pick one
solution) and says how far the closest model colour is (ΔE2000) and whether the colour lies outside
what the model can produce. Units: wavelengths in nm, μa and μs′ per mm (the published cm⁻¹ values
divided by 10), thicknesses in mm.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from core.errors import SheerError
from km.colour import delta_e2000, linear_rgb_to_lab, spectral_xyz_matrix, spectrum_to_xyz, xyz_to_lab
from km.optics import layer_rt, over, saunderson
from km.spectra import DEFAULT_GRID, WavelengthGrid

if TYPE_CHECKING:
    from pathlib import Path

__all__ = [
    "SkinError", "SkinParams", "SkinFit", "PARAM_RANGES", "skin_reflectance", "skin_coefficients",
    "fit_skin", "lab_of", "ita_degrees", "hue_degrees", "haemoglobin_absorption",
]

FloatArray = NDArray[np.float64]

# --------------------------------------------------------------------------------------------------
# Constants, each with its source and unit
# --------------------------------------------------------------------------------------------------

#: μa of the inside of a melanosome (eumelanin), per cm, is MELANIN_A · λ[nm] ^ −MELANIN_EXPONENT
#: (S. L. Jacques, "Skin optics", Oregon Medical Laser Center News, 1998: μa.mel = 6.6·10¹¹ λ⁻³·³³ cm⁻¹;
#: Donner & Jensen 2006 use the same for eumelanin, 6.6·10¹⁰ λ⁻³·³³ per mm).
MELANIN_A_PER_CM = 6.6e11
MELANIN_EXPONENT = 3.33
#: Pheomelanin, per cm: 2.9·10¹⁵ λ[nm]⁻⁴·⁷⁵ (Donner & Jensen 2006: 2.9·10¹⁴ λ⁻⁴·⁷⁵ per mm). Steeper than
#: eumelanin: it absorbs the blue as strongly but the red less, so the skin it colours is yellower.
PHEOMELANIN_A_PER_CM = 2.9e15
PHEOMELANIN_EXPONENT = 4.75
#: μa of bloodless, melanin-free tissue, per cm: 0.244 + 85.3 exp(−(λ − 154 nm)/66.2 nm) (Jacques 1998, ibid.).
BASELINE_A_PER_CM, BASELINE_B_PER_CM, BASELINE_L0_NM, BASELINE_W_NM = 0.244, 85.3, 154.0, 66.2
#: Reduced scattering of the dermis, per cm: Mie 2·10⁵ λ⁻¹·⁵ + Rayleigh 2·10¹² λ⁻⁴ (λ in nm; Jacques 1998,
#: ibid.); the epidermis is given the same (its scattering is similar; Donner & Jensen 2006 do likewise).
MIE_PER_CM, MIE_EXPONENT = 2.0e5, 1.5
RAYLEIGH_PER_CM, RAYLEIGH_EXPONENT = 2.0e12, 4.0
#: Haemoglobin: μa[cm⁻¹] = ln(10) · ε[cm⁻¹/M] · C[g/L] / M[g/mol] (S. Prahl, OMLC "Optical absorption of
#: hemoglobin", 1999), with C = 150 g/L in whole blood and M = 64 500 g/mol (Prahl, ibid.). ε is read from
#: the sample asset below (Prahl's compilation of Gratzer's and Kollias' data).
HAEMOGLOBIN_G_PER_L = 150.0
HAEMOGLOBIN_G_PER_MOL = 64_500.0
HAEMOGLOBIN_ASSET = "spectra/hemoglobin_molar_extinction.csv"
#: Epidermis thickness, mm. A model choice: facial epidermis is thin; 60 µm sits in the 50–100 µm usually
#: quoted for it (Donner & Jensen 2006 used 0.25 mm for their renders, which makes every skin darker).
EPIDERMIS_MM = 0.06
#: Refractive index of skin (Donner & Jensen 2006 use η = 1.4; the stratum corneum measures 1.4–1.55).
SKIN_IOR = 1.4
#: Default blood oxygenation, fraction (a mix of arterial ≈ 0.97 and venous ≈ 0.6 blood; Jacques 1998 uses 0.75).
DEFAULT_OXYGENATION = 0.75
#: Default (and the fits' prior) pheomelanin fraction of the melanin: a model choice between the
#: eumelanin-dominated dark skins and the pheomelanin-rich light ones (Donner & Jensen 2006 fit 0–1).
DEFAULT_PHEOMELANIN = 0.3
#: Diffusion → Kubelka–Munk: K = 2 μa, S = ¾ μs′ (van Gemert & Star 1987, "Relations between the Kubelka-Munk
#: and the transport equation models for anisotropic scattering", Lasers Life Sci. 1: 287–298), with their
#: −¼ μa term in S dropped: it assumes μs′ ≫ μa, and it would make S negative in the blue for dark epidermis.
KM_K_PER_MUA = 2.0
KM_S_PER_MUSP = 0.75
#: mm per cm (the published coefficients are per cm; km's are per mm)
_CM_TO_MM = 0.1

#: Each parameter's (lowest, highest) value the model accepts and the fits search (fractions; scale).
PARAM_RANGES: dict[str, tuple[float, float]] = {
    "melanin": (0.002, 0.45),     # below Jacques' lightest 1.3 % to above his darkest 43 %
    "blood": (0.001, 0.08),       # 0.1–8 % (Donner & Jensen 2006 fit 0.2–7 %)
    "oxygenation": (0.0, 1.0),
    "scattering": (0.4, 2.5),     # the spread of μs′ between people and body sites (Jacques 2013 review)
    "pheomelanin": (0.0, 1.0),
}
#: A fit whose closest model colour is further than this (ΔE2000) is reported as out of the model's gamut.
GAMUT_DE2000 = 1.0


class SkinError(SheerError, ValueError):
    """A skin model input that cannot be used (a parameter out of range, an unreadable spectrum…)."""


def _surface_k2(n: float) -> float:
    """Internal diffuse reflectance at a smooth dielectric boundary of index ``n`` (fraction).

    Judd (1942): ``r_i = 1 − (1 − r_e)/n²``, with the external diffuse reflectance ``r_e`` the
    cosine-weighted hemispherical mean of Fresnel's reflectance (unpolarised), integrated numerically.
    """
    steps = 2000
    h = (math.pi / 2) / steps
    theta = (np.arange(steps) + 0.5) * h  # midpoints
    cos_i = np.cos(theta)
    sin_t = np.sin(theta) / n
    cos_t = np.sqrt(1.0 - sin_t**2)
    rs = ((cos_i - n * cos_t) / (cos_i + n * cos_t)) ** 2
    rp = ((n * cos_i - cos_t) / (n * cos_i + cos_t)) ** 2
    r_e = float(np.sum(0.5 * (rs + rp) * 2.0 * np.sin(theta) * cos_i) * h)
    return 1.0 - (1.0 - r_e) / n**2


#: The Saunderson k2 of the air–skin surface (≈ 0.53 for n = 1.4); k1 = 0: the colours we fit and compare
#: are diffuse (specular excluded, like a 45°/0° measurement or the capture's fitted diffuse colour).
SURFACE_K2 = _surface_k2(SKIN_IOR)


# --------------------------------------------------------------------------------------------------
# Chromophores
# --------------------------------------------------------------------------------------------------


def _read_haemoglobin(path: Path) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(wavelengths nm, ε HbO2, ε Hb in cm⁻¹/M) from Prahl's table as shipped with the sample assets.

    The file: ``#`` comment lines, a header line ``wavelength_nm,HbO2,Hb``, then one row per wavelength.
    """
    from core.files import read_bounded

    raw = read_bounded(path, 1 << 20, "haemoglobin spectra", SkinError)
    rows = [line.split(",") for line in raw.decode("utf-8", "replace").splitlines()
            if line.strip() and not line.lstrip().startswith("#")]
    try:
        table = np.array(rows[1:], dtype=np.float64)
    except ValueError:
        table = np.zeros((0, 0))
    if table.ndim != 2 or table.shape[0] < 2 or table.shape[1] != 3 or not np.isfinite(table).all() \
            or (table[:, 1:] < 0).any():
        raise SkinError(f"{path}: expected a header and rows wavelength_nm,HbO2,Hb of finite, non-negative "
                        "numbers")
    return table[:, 0], table[:, 1], table[:, 2]


@functools.lru_cache(maxsize=8)
def haemoglobin_absorption(grid: WavelengthGrid = DEFAULT_GRID) -> tuple[FloatArray, FloatArray]:
    """μa per mm of whole blood (150 g/L haemoglobin), fully oxygenated and fully deoxygenated, on ``grid``.

    Returns two read-only arrays of ``len(grid)`` values (per mm). Raises :class:`SkinError` (or
    :class:`core.errors.AssetNotFoundError`) when the sample asset is missing or malformed.
    """
    from core.assets import find_asset

    wl, e_oxy, e_deoxy = _read_haemoglobin(find_asset(HAEMOGLOBIN_ASSET))
    scale = math.log(10.0) * HAEMOGLOBIN_G_PER_L / HAEMOGLOBIN_G_PER_MOL * _CM_TO_MM
    oxy = grid.resample(e_oxy, wl) * scale
    deoxy = grid.resample(e_deoxy, wl) * scale
    for a in (oxy, deoxy):
        a.setflags(write=False)
    return oxy, deoxy


@functools.lru_cache(maxsize=8)
def _tissue(grid: WavelengthGrid) -> dict[str, FloatArray]:
    """The wavelength-only spectra (per mm) on ``grid``: melanins, baseline, μs′, oxy- and deoxy-blood."""
    wl = grid.wavelengths
    out = {
        "eumelanin": MELANIN_A_PER_CM * wl ** -MELANIN_EXPONENT * _CM_TO_MM,
        "pheomelanin": PHEOMELANIN_A_PER_CM * wl ** -PHEOMELANIN_EXPONENT * _CM_TO_MM,
        "baseline": (BASELINE_A_PER_CM + BASELINE_B_PER_CM * np.exp(-(wl - BASELINE_L0_NM) / BASELINE_W_NM))
        * _CM_TO_MM,
        "musp": (MIE_PER_CM * wl ** -MIE_EXPONENT + RAYLEIGH_PER_CM * wl ** -RAYLEIGH_EXPONENT) * _CM_TO_MM,
    }
    out["oxy"], out["deoxy"] = haemoglobin_absorption(grid)
    return out


# --------------------------------------------------------------------------------------------------
# The model
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SkinParams:
    """One skin's parameters: fractions and a scale, all unit 1.

    See the module docstring and :data:`PARAM_RANGES`; constructing one outside the ranges raises
    :class:`SkinError`.
    """

    melanin: float
    blood: float
    oxygenation: float = DEFAULT_OXYGENATION
    scattering: float = 1.0
    pheomelanin: float = DEFAULT_PHEOMELANIN

    def __post_init__(self) -> None:
        for name, (lo, hi) in PARAM_RANGES.items():
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and lo <= value <= hi):
                raise SkinError(f"skin {name} must be a number in [{lo:g}, {hi:g}], got {value!r}")

    def to_json(self) -> dict[str, float]:
        """The parameters by name (JSON-ready)."""
        return {"melanin": self.melanin, "blood": self.blood, "oxygenation": self.oxygenation,
                "scattering": self.scattering, "pheomelanin": self.pheomelanin}

    def reflectance(self, grid: WavelengthGrid = DEFAULT_GRID) -> FloatArray:
        """Diffuse reflectance of this skin on ``grid`` (fractions in [0, 1], ``len(grid)`` values)."""
        return skin_reflectance(self.melanin, self.blood, self.oxygenation, self.scattering, grid,
                                self.pheomelanin)


def skin_coefficients(melanin: ArrayLike, blood: ArrayLike, oxygenation: ArrayLike = DEFAULT_OXYGENATION,
                      scattering: ArrayLike = 1.0, grid: WavelengthGrid = DEFAULT_GRID,
                      pheomelanin: ArrayLike = DEFAULT_PHEOMELANIN) -> dict[str, FloatArray]:
    """μa and μs′ (per mm) of the epidermis and the dermis, broadcast over the parameters.

    ============ ===== ===============================================================
    argument     unit  domain
    ============ ===== ===============================================================
    melanin      1     [0, 1] epidermal melanosome volume fraction (any shape)
    blood        1     [0, 1] dermal blood volume fraction
    oxygenation  1     [0, 1] haemoglobin oxygen saturation
    scattering   1     > 0, scale of μs′
    pheomelanin  1     [0, 1] pheomelanin fraction of the melanin
    ============ ===== ===============================================================

    Returns ``{"mua_epidermis", "mua_dermis", "musp"}``, each ``(*broadcast shape, len(grid))`` per mm.
    Like :mod:`km.optics`'s forward functions it never raises on values: a parameter outside its domain
    (or NaN, or infinite) gives NaN at that position, and no numpy warning escapes.
    """
    t = _tissue(grid)
    m, b, o, s, p = (np.asarray(v, dtype=np.float64)[..., None]
                     for v in (melanin, blood, oxygenation, scattering, pheomelanin))
    with np.errstate(all="ignore"):
        bad = ~((m >= 0) & (m <= 1) & (b >= 0) & (b <= 1) & (o >= 0) & (o <= 1) & (p >= 0) & (p <= 1)
                & (s > 0) & (s < np.inf))
        mua_e = m * ((1.0 - p) * t["eumelanin"] + p * t["pheomelanin"]) + (1.0 - m) * t["baseline"]
        mua_d = b * (o * t["oxy"] + (1.0 - o) * t["deoxy"]) + (1.0 - b) * t["baseline"]
        musp = s * t["musp"]
        if bad.any():
            mua_e, mua_d, musp = (np.where(bad, np.nan, a) for a in np.broadcast_arrays(mua_e, mua_d, musp))
    return {"mua_epidermis": mua_e, "mua_dermis": mua_d, "musp": musp}


def skin_reflectance(melanin: ArrayLike, blood: ArrayLike, oxygenation: ArrayLike = DEFAULT_OXYGENATION,
                     scattering: ArrayLike = 1.0, grid: WavelengthGrid = DEFAULT_GRID,
                     pheomelanin: ArrayLike = DEFAULT_PHEOMELANIN) -> FloatArray:
    """Diffuse reflectance of the two-layer skin (fractions in [0, 1]), broadcast over the parameters.

    Arguments as :func:`skin_coefficients`; returns ``(*broadcast shape, len(grid))``. Epidermis of
    :data:`EPIDERMIS_MM` over an opaque dermis, KM (Eq. 1–4 of Huang et al. 2013 via :mod:`km.optics`),
    then the air–skin surface (Saunderson, k1 = 0, k2 = :data:`SURFACE_K2`).
    """
    c = skin_coefficients(melanin, blood, oxygenation, scattering, grid, pheomelanin)
    S = KM_S_PER_MUSP * c["musp"]
    R_e, T_e = layer_rt(S, KM_K_PER_MUA * c["mua_epidermis"], EPIDERMIS_MM)
    R_d, _ = layer_rt(S, KM_K_PER_MUA * c["mua_dermis"], np.inf)
    return saunderson(over(R_e, T_e, R_d), 0.0, SURFACE_K2)


# --------------------------------------------------------------------------------------------------
# Colour helpers
# --------------------------------------------------------------------------------------------------


def lab_of(reflectance: ArrayLike, illuminant: str = "D65", grid: WavelengthGrid = DEFAULT_GRID) -> FloatArray:
    """CIELAB (..., 3) of reflectance spectra lit by ``illuminant``, relative to that light's white."""
    return xyz_to_lab(spectrum_to_xyz(reflectance, grid, illuminant), illuminant)


def ita_degrees(lab: ArrayLike) -> FloatArray:
    """Individual typology angle ITA° = atan((L* − 50)/b*) in degrees (Chardon et al. 1991), (...,).

    > 55° very light, 41–55 light, 28–41 intermediate, 10–28 tan, −30–10 brown, < −30 dark.
    """
    lab_ = np.asarray(lab, dtype=np.float64)
    return np.degrees(np.arctan2(lab_[..., 0] - 50.0, lab_[..., 2]))


def hue_degrees(lab: ArrayLike) -> FloatArray:
    """CIELAB hue angle h_ab in degrees [0, 360), (...,)."""
    lab_ = np.asarray(lab, dtype=np.float64)
    return np.degrees(np.arctan2(lab_[..., 2], lab_[..., 1])) % 360.0


# --------------------------------------------------------------------------------------------------
# Fitting
# --------------------------------------------------------------------------------------------------

#: the fitted parameters (oxygenation is held); the first three are searched on a log scale
_FIT_NAMES = ("melanin", "blood", "scattering", "pheomelanin")


@dataclass(frozen=True)
class SkinFit:
    """The result of :func:`fit_skin`.

    Attributes:
        params: the fitted :class:`SkinParams`.
        reflectance: its spectrum on ``grid`` (fractions).
        lab: the model colour (CIELAB, D65).
        target_lab: the colour fitted (CIELAB, D65).
        residual_de2000: ΔE2000 between the two (≥ 0).
        out_of_gamut: True when the residual exceeds :data:`GAMUT_DE2000`: no skin of the model has
            this colour, the closest one is reported.
        grid: the wavelength grid (nm).
    """

    params: SkinParams
    reflectance: FloatArray
    lab: FloatArray
    target_lab: FloatArray
    residual_de2000: float
    out_of_gamut: bool
    grid: WavelengthGrid = field(default=DEFAULT_GRID)

    def to_json(self) -> dict[str, Any]:
        """JSON-ready summary: parameters, spectrum (nm, fractions), colours, residual, gamut flag."""
        return {"params": self.params.to_json(), "lab": [round(float(v), 3) for v in self.lab],
                "target_lab": [round(float(v), 3) for v in self.target_lab],
                "ita_deg": round(float(ita_degrees(self.lab)), 2),
                "residual_de2000": round(self.residual_de2000, 4), "out_of_gamut": self.out_of_gamut,
                "wavelengths_nm": [float(w) for w in self.grid.wavelengths],
                "reflectance": [round(float(r), 6) for r in self.reflectance]}


#: Weights of the priors (Lab units per unit of ln scattering, and per unit of pheomelanin fraction). Lab
#: cannot separate four parameters (and not always melanin from scattering): many colours are made by
#: several parameter sets (metamers of the model, with different spectra). The priors pick the one
#: nearest to scattering 1 and pheomelanin :data:`DEFAULT_PHEOMELANIN`; they cost a fitted colour ~0.01 ΔE.
SCATTERING_PRIOR = 0.05
PHEOMELANIN_PRIOR = 0.05


def _x_to_params(x: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """(melanin, blood, scattering, pheomelanin) from the search variables (..., 4)."""
    return np.exp(x[..., 0]), np.exp(x[..., 1]), np.exp(x[..., 2]), x[..., 3]


@functools.lru_cache(maxsize=8)
def _fit_table(grid: WavelengthGrid, oxygenation: float) -> tuple[FloatArray, FloatArray]:
    """A coarse table of (search variables (n, 4), Lab under D65 (n, 3)) to start the fits from.

    The scattering and pheomelanin axes hold the priors' centres exactly, so starts on them are offered.
    """
    lo_s, hi_s = (math.log(v) for v in PARAM_RANGES["scattering"])
    axes = [np.linspace(math.log(PARAM_RANGES["melanin"][0]), math.log(PARAM_RANGES["melanin"][1]), 24),
            np.linspace(math.log(PARAM_RANGES["blood"][0]), math.log(PARAM_RANGES["blood"][1]), 10),
            np.concatenate([np.linspace(lo_s, 0.0, 3), np.linspace(0.0, hi_s, 4)[1:]]),
            np.array([0.0, DEFAULT_PHEOMELANIN, 0.65, 1.0])]
    x = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 4)
    m, b, s, p = _x_to_params(x)
    return x, lab_of(skin_reflectance(m, b, oxygenation, s, grid, p), "D65", grid)


def _check_lab(target_lab: ArrayLike) -> FloatArray:
    lab = np.asarray(target_lab, dtype=np.float64)
    if lab.shape != (3,) or not np.isfinite(lab).all() or not 0.0 <= lab[0] <= 100.0:
        raise SkinError(f"a skin colour must be a finite CIELAB triple with L* in [0, 100], got {lab.tolist()}")
    return lab


def fit_skin(target_lab: ArrayLike | None = None, *, linear_rgb: ArrayLike | None = None,
             oxygenation: float = DEFAULT_OXYGENATION, grid: WavelengthGrid = DEFAULT_GRID) -> SkinFit:
    """Fit melanin, blood, scattering and pheomelanin so that the model's colour under D65 is the given one.

    ============ ===== ===============================================================
    argument     unit  domain
    ============ ===== ===============================================================
    target_lab   1     CIELAB (L* in [0, 100]) relative to D65, or
    linear_rgb   1     linear sRGB (D65 white = (1, 1, 1)), finite (< 0: outside sRGB)
    oxygenation  1     [0, 1], held fixed
    ============ ===== ===============================================================

    Least squares (scipy's trust-region reflective, melanin, blood and scattering on a log scale,
    all within :data:`PARAM_RANGES`) on the Lab difference plus the weak priors
    (:data:`SCATTERING_PRIOR`, :data:`PHEOMELANIN_PRIOR`), started from the nearest entries of a
    coarse table (two overall, two on the priors' centres); the lowest cost wins. A colour the model
    can produce is fitted to ΔE2000 ≈ 0; one it cannot is reported with ``out_of_gamut`` and the
    closest colour. Raises :class:`SkinError` for malformed input.
    """
    from scipy.optimize import least_squares

    if (target_lab is None) == (linear_rgb is None):
        raise SkinError("fit_skin: give exactly one of a Lab colour or a linear RGB colour")
    if linear_rgb is not None:
        rgb = np.asarray(linear_rgb, dtype=np.float64)
        if rgb.shape != (3,) or not np.isfinite(rgb).all():
            raise SkinError(f"a linear RGB colour must be three finite numbers, got {rgb.tolist()}")
        target = _check_lab(linear_rgb_to_lab(rgb))
    else:
        assert target_lab is not None
        target = _check_lab(target_lab)
    SkinParams(0.01, 0.01, oxygenation)  # validates the oxygenation
    x_table, lab_table = _fit_table(grid, float(oxygenation))
    lo = np.array([*np.log([PARAM_RANGES[k][0] for k in _FIT_NAMES[:3]]), PARAM_RANGES["pheomelanin"][0]])
    hi = np.array([*np.log([PARAM_RANGES[k][1] for k in _FIT_NAMES[:3]]), PARAM_RANGES["pheomelanin"][1]])

    to_xyz = spectral_xyz_matrix(grid, "D65")  # the matrix lab_of uses, looked up once (called ~400 times)

    prior = np.diag([0.0, 0.0, SCATTERING_PRIOR, PHEOMELANIN_PRIOR])[2:]

    def colour(x: FloatArray) -> FloatArray:  # x (..., 4) → Lab (..., 3)
        m, b, s, p = _x_to_params(x)
        return xyz_to_lab(skin_reflectance(m, b, oxygenation, s, grid, p) @ to_xyz, "D65")

    def residual(x: FloatArray) -> FloatArray:
        return np.concatenate([colour(x) - target, prior @ (x - [0.0, 0.0, 0.0, DEFAULT_PHEOMELANIN])])

    def jacobian(x: FloatArray) -> FloatArray:
        # forward differences, the four steps evaluated in one vectorised call (the model broadcasts)
        step = 1e-6 * np.where(x + 1e-6 <= hi, 1.0, -1.0)
        lab = colour(np.vstack([x, x + np.diag(step)]))
        return np.vstack([((lab[1:] - lab[0]) / step[:, None]).T, prior])

    dist = np.sum((lab_table - target) ** 2, axis=1)
    on_prior = np.flatnonzero((x_table[:, 2] == 0.0) & (x_table[:, 3] == DEFAULT_PHEOMELANIN))
    starts = [*np.argsort(dist)[:2], *on_prior[np.argsort(dist[on_prior])[:2]]]
    best = None
    for i in dict.fromkeys(int(j) for j in starts):
        sol = least_squares(residual, x_table[i], jac=jacobian, bounds=(lo, hi), method="trf", xtol=1e-9,
                            ftol=1e-9, gtol=1e-9, max_nfev=300)
        if best is None or sol.cost < best.cost:
            best = sol
    assert best is not None
    m, b, s, p = (float(v) for v in _x_to_params(np.clip(best.x, lo, hi)))
    params = SkinParams(melanin=m, blood=b, oxygenation=float(oxygenation), scattering=s, pheomelanin=p)
    refl = params.reflectance(grid)
    lab = lab_of(refl, "D65", grid)
    de = float(delta_e2000(lab, target))
    return SkinFit(params=params, reflectance=refl, lab=lab, target_lab=target, residual_de2000=de,
                   out_of_gamut=de > GAMUT_DE2000, grid=grid)
