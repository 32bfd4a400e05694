"""Spectra to CIE XYZ, linear sRGB and CIE Lab, through colour-science (CIE 1931 2° observer).

A spectrum-to-colour conversion is linear in the spectrum, so for each (wavelength grid, illuminant)
this module builds, once, an (n_wavelengths × 3) matrix and converting any number of spectra is one
matrix product (``values @ M``). The matrices are made by colour-science itself: the tristimulus
values of the n unit spectra (the identity) with ``colour.msds_to_XYZ`` (ASTM E308, colour-science's
default), so the result equals ``colour.sd_to_XYZ`` on the same data; grids colour-science's ASTM
E308 path does not accept (irregular, or steps other than 1/5/10/20 nm) go through a linear
resampling onto the 1 nm grid first.

``spectrum_to_rgb`` adapts the illuminant's white to the sRGB white (D65) with a von Kries type
transform (CAT02 by default, colour-science's default), so a perfect white reflector is exactly
(1, 1, 1) under every illuminant, as the eye adapted to that light would see it.

NaN or ±inf in a spectrum makes that spectrum's colour NaN or ±inf (no exception, no warning).
"""

from __future__ import annotations

import functools
import warnings

import colour
import numpy as np
from numpy.typing import ArrayLike, NDArray

from km.optics import KMDomainError
from km.spectra import DEFAULT_GRID, WavelengthGrid

__all__ = [
    "spectrum_to_xyz",
    "spectrum_to_rgb",
    "spectral_xyz_matrix",
    "spectral_rgb_matrix",
    "supported_illuminants",
    "xyz_to_lab",
    "linear_rgb_to_lab",
    "delta_e2000",
]

FloatArray = NDArray[np.float64]

_OBSERVER = "CIE 1931 2 Degree Standard Observer"
#: the usual short names of the CIE fluorescent illuminants, which colour-science spells "FL…"
_ALIASES = {f"F{i}": f"FL{i}" for i in range(1, 13)}
_ASTM_INTERVALS = (1.0, 5.0, 10.0, 20.0)


def supported_illuminants() -> tuple[str, ...]:
    """Names accepted as ``illuminant``: colour-science's CIE illuminants (plus F1–F12 for FL1–FL12)."""
    return tuple(sorted(set(colour.SDS_ILLUMINANTS) | set(_ALIASES)))


def _illuminant_sd(name: str) -> colour.SpectralDistribution:
    key = _ALIASES.get(name, name)
    try:
        return colour.SDS_ILLUMINANTS[key]
    except KeyError:
        raise KMDomainError(
            f"unknown illuminant {name!r}; use one of D65, D55, D50, A, F2, … (km.colour.supported_illuminants())"
        ) from None


def _grid(wavelengths: ArrayLike | WavelengthGrid) -> WavelengthGrid:
    return WavelengthGrid.from_wavelengths(wavelengths)


def _linear_resampling_matrix(src: FloatArray, dst: FloatArray) -> FloatArray:
    """(len(dst) × len(src)) matrix of linear interpolation from ``src`` to ``dst`` (within range)."""
    i = np.clip(np.searchsorted(src, dst, side="right") - 1, 0, src.size - 2)
    t = np.clip((dst - src[i]) / (src[i + 1] - src[i]), 0.0, 1.0)
    L = np.zeros((dst.size, src.size))
    rows = np.arange(dst.size)
    L[rows, i] += 1.0 - t
    L[rows, i + 1] += t
    return L


def _astm_matrix(wl: FloatArray, illuminant: colour.SpectralDistribution) -> FloatArray:
    """colour-science's ASTM E308 tristimulus values of the unit spectra on ``wl`` (n × 3, Y of 1s = 100)."""
    n = wl.size
    msds = colour.MultiSpectralDistributions(np.eye(n), wl, labels=[str(i) for i in range(n)])
    cmfs = colour.MSDS_CMFS[_OBSERVER]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # colour-science's notes about trimming/extrapolating its tables
        return np.asarray(colour.msds_to_XYZ(msds, cmfs, illuminant, method="ASTM E308"), dtype=np.float64)


def _weights_1nm(fine: FloatArray, illuminant: colour.SpectralDistribution) -> FloatArray:
    """Tristimulus weights on a 1 nm grid: CMF × illuminant, the 1 nm case of ASTM E308.

    As in ASTM E308, the weights beyond the grid's ends (down to 360 and up to 830 nm, the CMF
    range) are added to the first and last wavelength. Written out (with colour-science's tables and
    its interpolation of the illuminant) because ``msds_to_XYZ`` on ~400 unit spectra takes over a
    second; this takes milliseconds.
    """
    cmfs = colour.MSDS_CMFS[_OBSERVER]
    full = colour.SpectralShape(min(cmfs.shape.start, fine[0]), max(cmfs.shape.end, fine[-1]), 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # colour-science notes its extrapolation of the tables
        cmfs_full = cmfs.copy().align(full)
        ill = illuminant.copy().align(full)
    W = np.asarray(cmfs_full.values, dtype=np.float64) * np.asarray(ill.values, dtype=np.float64)[:, None]
    wl_full = np.asarray(cmfs_full.wavelengths, dtype=np.float64)
    lo = int(np.searchsorted(wl_full, fine[0]))
    hi = int(np.searchsorted(wl_full, fine[-1]))
    out = W[lo:hi + 1].copy()
    out[0] += W[:lo].sum(axis=0)
    out[-1] += W[hi + 1:].sum(axis=0)
    return out


@functools.lru_cache(maxsize=64)
def _xyz_matrix_cached(grid: WavelengthGrid, illuminant: str) -> FloatArray:
    sd = _illuminant_sd(illuminant)
    wl = grid.wavelengths
    if len(grid) < 2:
        raise KMDomainError("spectrum_to_xyz: need at least two wavelengths")
    if grid.step is not None and any(abs(grid.step - s) < 1e-9 for s in _ASTM_INTERVALS) \
            and float(grid.start).is_integer():
        M = _astm_matrix(wl, sd)
    else:
        # colour-science's ASTM E308 path takes 1, 5, 10 or 20 nm steps only: go through 1 nm
        fine = np.arange(np.ceil(wl[0]), np.floor(wl[-1]) + 1.0)
        if fine.size < 2:
            raise KMDomainError(f"spectrum_to_xyz: the grid {grid!r} is too narrow")
        M = _linear_resampling_matrix(wl, fine).T @ _weights_1nm(fine, sd)
    M = M / M[:, 1].sum()  # a perfect white reflector has Y = 1
    M.setflags(write=False)
    return M


@functools.lru_cache(maxsize=64)
def _rgb_matrix_cached(grid: WavelengthGrid, illuminant: str, cat: str) -> FloatArray:
    M_xyz = _xyz_matrix_cached(grid, illuminant)
    srgb = colour.RGB_COLOURSPACES["sRGB"]
    xyz_white = M_xyz.sum(axis=0)  # the illuminant's white, Y = 1
    xyz_target = colour.xy_to_XYZ(srgb.whitepoint)
    if cat not in colour.CHROMATIC_ADAPTATION_TRANSFORMS:
        raise KMDomainError(f"unknown chromatic adaptation transform {cat!r}; use one of "
                            f"{', '.join(sorted(colour.CHROMATIC_ADAPTATION_TRANSFORMS))}")
    cat_matrix = colour.adaptation.matrix_chromatic_adaptation_VonKries(xyz_white, xyz_target, transform=cat)
    M = M_xyz @ cat_matrix.T @ np.asarray(srgb.matrix_XYZ_to_RGB).T
    # the adaptation maps the white exactly up to rounding (and to the 4-digit sRGB matrix): make it exact
    M = M / M.sum(axis=0)
    M.setflags(write=False)
    return M


def spectral_xyz_matrix(wavelengths: ArrayLike | WavelengthGrid = DEFAULT_GRID,
                        illuminant: str = "D65") -> FloatArray:
    """The read-only (n_wavelengths × 3) matrix ``M`` with ``XYZ = values @ M`` (white: Y = 1). Cached."""
    return _xyz_matrix_cached(_grid(wavelengths), illuminant)


def spectral_rgb_matrix(wavelengths: ArrayLike | WavelengthGrid = DEFAULT_GRID, illuminant: str = "D65",
                        cat: str = "CAT02") -> FloatArray:
    """The read-only (n_wavelengths × 3) matrix ``M`` with ``linear sRGB = values @ M``; ones → (1, 1, 1).

    The renderer uploads this to the GPU to do the same conversion. Cached per (grid, illuminant, cat).
    """
    return _rgb_matrix_cached(_grid(wavelengths), illuminant, cat)


def _apply(values: ArrayLike, M: FloatArray, n: int, where: str) -> FloatArray:
    v = np.asarray(values, dtype=np.float64)
    if v.ndim == 0 or v.shape[-1] != n:
        raise KMDomainError(f"{where}: values have {v.shape[-1] if v.ndim else 0} samples on the last axis "
                            f"but {n} wavelengths were given")
    with np.errstate(all="ignore"):
        return np.asarray(v @ M, dtype=np.float64)


def spectrum_to_xyz(values: ArrayLike, wavelengths: ArrayLike | WavelengthGrid = DEFAULT_GRID,
                    illuminant: str = "D65") -> FloatArray:
    """CIE 1931 XYZ of reflectance (or transmittance) spectra lit by ``illuminant``.

    ============ ===== ===============================================================
    argument     unit  domain
    ============ ===== ===============================================================
    values       1     (..., n) spectral reflectance, normally [0, 1]; any real works
    wavelengths  nm    n wavelengths (array or :class:`~km.spectra.WavelengthGrid`)
    illuminant   -     a name from :func:`supported_illuminants` ("D65", "D55", "A", "F2"…)
    ============ ===== ===============================================================

    ============ ===== ===============================================================
    returns      unit  range
    ============ ===== ===============================================================
    XYZ          1     (..., 3); a perfect white reflector has Y = 1 (not adapted: its
                       X, Z are the illuminant's white point)
    ============ ===== ===============================================================

    Equal to ``colour.sd_to_XYZ(...) / 100`` for grids colour-science's ASTM E308 path accepts.
    """
    grid = _grid(wavelengths)
    return _apply(values, _xyz_matrix_cached(grid, illuminant), len(grid), "spectrum_to_xyz")


def spectrum_to_rgb(values: ArrayLike, wavelengths: ArrayLike | WavelengthGrid = DEFAULT_GRID,
                    illuminant: str = "D65", cat: str = "CAT02") -> FloatArray:
    """Linear sRGB of reflectance spectra lit by ``illuminant``, adapted to the sRGB white (D65).

    ============ ===== ===============================================================
    argument     unit  domain
    ============ ===== ===============================================================
    values       1     (..., n) spectral reflectance, normally [0, 1]
    wavelengths  nm    n wavelengths (array or :class:`~km.spectra.WavelengthGrid`)
    illuminant   -     a name from :func:`supported_illuminants`
    cat          -     colour-science chromatic adaptation transform ("CAT02", "Bradford"…)
    ============ ===== ===============================================================

    ============ ===== ===============================================================
    returns      unit  range
    ============ ===== ===============================================================
    RGB          1     (..., 3) linear (not gamma-encoded) sRGB; all-ones → (1, 1, 1)
                       exactly; saturated colours may fall outside [0, 1] (not clipped)
    ============ ===== ===============================================================

    One matrix product with a cached (n × 3) matrix (:func:`spectral_rgb_matrix`).
    """
    grid = _grid(wavelengths)
    return _apply(values, _rgb_matrix_cached(grid, illuminant, cat), len(grid), "spectrum_to_rgb")


@functools.lru_cache(maxsize=64)
def _white_xy(illuminant: str) -> tuple[float, float]:
    X, Y, Z = _xyz_matrix_cached(DEFAULT_GRID, illuminant).sum(axis=0)
    return float(X / (X + Y + Z)), float(Y / (X + Y + Z))


def xyz_to_lab(xyz: ArrayLike, illuminant: str | ArrayLike = "D65") -> FloatArray:
    """CIE 1976 L*a*b* of XYZ (Y of white = 1) relative to the white of ``illuminant``.

    ============ ===== ===============================================================
    argument     unit  domain
    ============ ===== ===============================================================
    xyz          1     (..., 3), Y of the reference white = 1
    illuminant   -     a name (its white is integrated on the default grid, so
                       ``spectrum_to_xyz(ones, illuminant=name)`` gives L* = 100,
                       a* = b* = 0), or an xy chromaticity pair
    ============ ===== ===============================================================

    Returns Lab (..., 3): L* in [0, 100], a*, b* roughly [−128, 127]. NaN in → NaN out.
    A thin wrapper over ``colour.XYZ_to_Lab`` (evaluated in colour-science's "reference" scale).
    """
    xy = np.asarray(_white_xy(illuminant) if isinstance(illuminant, str) else illuminant, dtype=np.float64)
    with colour.domain_range_scale("reference"), np.errstate(all="ignore"):
        return np.asarray(colour.XYZ_to_Lab(np.asarray(xyz, dtype=np.float64), xy), dtype=np.float64)


def linear_rgb_to_lab(rgb: ArrayLike) -> FloatArray:
    """CIE L*a*b* (white: sRGB's D65 white) of linear sRGB values (..., 3); (1, 1, 1) → (100, 0, 0).

    Range: L* in [0, 100] for RGB in [0, 1]. A thin wrapper over ``colour.RGB_to_XYZ`` and
    ``colour.XYZ_to_Lab``. NaN in → NaN out.
    """
    srgb = colour.RGB_COLOURSPACES["sRGB"]
    with colour.domain_range_scale("reference"), np.errstate(all="ignore"):
        xyz = colour.RGB_to_XYZ(np.asarray(rgb, dtype=np.float64), srgb, apply_cctf_decoding=False)
        # the white is the XYZ of RGB (1, 1, 1): colour-science's sRGB matrix is the 4-digit published one,
        # whose white is a hair off the nominal D65 xy, and white must give a* = b* = 0
        white = colour.XYZ_to_xy(colour.RGB_to_XYZ(np.ones(3), srgb, apply_cctf_decoding=False))
        return np.asarray(colour.XYZ_to_Lab(xyz, white), dtype=np.float64)


def delta_e2000(lab1: ArrayLike, lab2: ArrayLike) -> FloatArray:
    """CIEDE2000 colour difference of two Lab arrays (..., 3), broadcast; ≥ 0, unit ΔE00 (≈1 = just noticeable).

    A thin wrapper over ``colour.delta_E(..., method="CIE 2000")``. NaN in → NaN out.
    """
    with colour.domain_range_scale("reference"), np.errstate(all="ignore"):
        return np.asarray(colour.delta_E(np.asarray(lab1, dtype=np.float64), np.asarray(lab2, dtype=np.float64),
                                         method="CIE 2000"), dtype=np.float64)
