"""Wavelength grids and resampling of spectral data (wavelengths in nm, on the last axis).

The default grid is the paper's measurement grid: 380–780 nm in 5 nm steps (81 samples).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from km.optics import KMDomainError

__all__ = ["WavelengthGrid", "DEFAULT_GRID"]

FloatArray = NDArray[np.float64]

#: relative tolerance for "this grid is uniform" and for stop = start + n·step
_UNIFORM_RTOL = 1e-9


class WavelengthGrid:
    """An immutable, hashable, strictly increasing set of wavelengths in nm.

    ``WavelengthGrid(start=380, stop=780, step=5)`` builds a uniform grid (``stop`` included; it must
    be ``start + n·step``); :meth:`from_wavelengths` takes an explicit array (uniform or not). Two
    grids are equal when their wavelengths are equal; grids can be dictionary keys (the colour
    matrices are cached per grid).

    ========== ===== ==============================================
    attribute  unit  meaning
    ========== ===== ==============================================
    wavelengths nm   read-only float64 array, strictly increasing
    start      nm    first wavelength
    stop       nm    last wavelength
    step       nm    spacing of a uniform grid, None if not uniform
    ========== ===== ==============================================
    """

    __slots__ = ("_wl", "_step", "_hash")

    _wl: FloatArray
    _step: float | None
    _hash: int

    def __init__(self, start: float = 380.0, stop: float = 780.0, step: float = 5.0) -> None:
        try:
            start_f, stop_f, step_f = float(start), float(stop), float(step)
        except (TypeError, ValueError) as exc:
            raise KMDomainError(f"WavelengthGrid: start, stop and step must be numbers, got "
                                f"{start!r}, {stop!r}, {step!r}") from exc
        if not (np.isfinite([start_f, stop_f, step_f]).all() and step_f > 0.0 and start_f > 0.0):
            raise KMDomainError(f"WavelengthGrid: need finite start > 0 nm and step > 0 nm, got start={start_f:g}, "
                                f"stop={stop_f:g}, step={step_f:g}")
        if stop_f < start_f:
            raise KMDomainError(f"WavelengthGrid: stop ({stop_f:g} nm) is below start ({start_f:g} nm)")
        n_steps = round((stop_f - start_f) / step_f)
        if abs(start_f + n_steps * step_f - stop_f) > _UNIFORM_RTOL * max(step_f, abs(stop_f)):
            raise KMDomainError(f"WavelengthGrid: {stop_f:g} nm is not start + n·step "
                                f"(start={start_f:g} nm, step={step_f:g} nm)")
        wl = start_f + step_f * np.arange(n_steps + 1, dtype=np.float64)
        wl[-1] = stop_f
        self._init(wl, step_f if n_steps > 0 else None)

    @classmethod
    def from_wavelengths(cls, wavelengths: ArrayLike | WavelengthGrid) -> WavelengthGrid:
        """A grid with exactly these wavelengths (nm): 1-D, finite, positive, strictly increasing."""
        if isinstance(wavelengths, WavelengthGrid):
            return wavelengths
        try:
            wl = np.array(wavelengths, dtype=np.float64).reshape(-1) if np.ndim(wavelengths) <= 1 else None
        except (TypeError, ValueError) as exc:
            raise KMDomainError("WavelengthGrid: wavelengths must be a 1-D sequence of numbers (nm)") from exc
        if wl is None:
            raise KMDomainError(f"WavelengthGrid: wavelengths must be 1-D, got shape {np.shape(wavelengths)}")
        if wl.size == 0:
            raise KMDomainError("WavelengthGrid: no wavelengths")
        if not np.isfinite(wl).all() or (wl <= 0.0).any():
            bad = np.nonzero(~(np.isfinite(wl) & (wl > 0.0)))[0]
            raise KMDomainError(f"WavelengthGrid: wavelengths must be finite and positive (nm); bad at index "
                                f"{', '.join(map(str, bad[:12]))}")
        steps = np.diff(wl)
        if (steps <= 0.0).any():
            i = int(np.nonzero(steps <= 0.0)[0][0])
            raise KMDomainError(f"WavelengthGrid: wavelengths must be strictly increasing; index {i + 1} "
                                f"({wl[i + 1]:g} nm) does not exceed index {i} ({wl[i]:g} nm)")
        step: float | None = None
        if steps.size and np.allclose(steps, steps[0], rtol=_UNIFORM_RTOL, atol=0.0):
            step = float(steps[0])
        obj = cls.__new__(cls)
        obj._init(wl, step)
        return obj

    def _init(self, wl: FloatArray, step: float | None) -> None:
        wl.setflags(write=False)
        object.__setattr__(self, "_wl", wl)
        object.__setattr__(self, "_step", step)
        object.__setattr__(self, "_hash", hash(wl.tobytes()))

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("WavelengthGrid is immutable")

    def __delattr__(self, name: str) -> None:
        raise AttributeError("WavelengthGrid is immutable")

    # --- read-only views ---------------------------------------------------------------------------------
    @property
    def wavelengths(self) -> FloatArray:
        """The wavelengths in nm (a read-only float64 array)."""
        return self._wl

    @property
    def start(self) -> float:
        """The first wavelength (nm)."""
        return float(self._wl[0])

    @property
    def stop(self) -> float:
        """The last wavelength (nm, included)."""
        return float(self._wl[-1])

    @property
    def step(self) -> float | None:
        """Spacing in nm of a uniform grid (None when irregular or a single wavelength)."""
        return self._step

    @property
    def is_uniform(self) -> bool:
        """Whether the wavelengths are evenly spaced."""
        return self._step is not None

    def __len__(self) -> int:
        return int(self._wl.size)

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> np.ndarray:
        if copy:
            return np.array(self._wl, dtype=dtype)
        return self._wl if dtype is None else self._wl.astype(dtype)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, WavelengthGrid):
            return NotImplemented
        return self._hash == other._hash and np.array_equal(self._wl, other._wl)

    def __hash__(self) -> int:
        return self._hash

    def __repr__(self) -> str:
        if self._step is not None:
            return f"WavelengthGrid(start={self.start:g}, stop={self.stop:g}, step={self._step:g})"
        return f"WavelengthGrid.from_wavelengths([{', '.join(f'{w:g}' for w in self._wl)}])"

    def __reduce__(self) -> tuple[Any, ...]:
        return (WavelengthGrid.from_wavelengths, (self._wl.copy(),))

    # --- resampling --------------------------------------------------------------------------------------
    def resample(self, values: ArrayLike, from_wavelengths: ArrayLike | WavelengthGrid, *,
                 extrapolate: bool = False) -> FloatArray:
        """Resample spectral ``values`` given at ``from_wavelengths`` onto this grid.

        =============== ===== ====================================================================
        argument        unit  domain
        =============== ===== ====================================================================
        values          any   array (..., n_from); the last axis is wavelength
        from_wavelengths nm   1-D strictly increasing, length n_from (or a WavelengthGrid)
        extrapolate     -     False: this grid must lie within [min, max] of from_wavelengths,
                              else :class:`~km.optics.KMDomainError`; True: hold the end values
        =============== ===== ====================================================================

        Returns ``(..., len(self))`` float64 in the unit of ``values``.

        Linear interpolation, on purpose: unlike the Sprague or cubic interpolators colour-science
        uses for colorimetry, it never overshoots, so reflectances stay in [0, 1] and S, K stay
        non-negative, which the KM formulas require. A NaN sample makes NaN only in the two
        intervals that touch it (an exact wavelength match takes the sample alone).
        """
        src = WavelengthGrid.from_wavelengths(from_wavelengths)
        v = np.asarray(values, dtype=np.float64)
        if v.ndim == 0 or v.shape[-1] != len(src):
            raise KMDomainError(f"resample: values have {v.shape[-1] if v.ndim else 0} samples on the last "
                                f"axis but {len(src)} source wavelengths were given")
        if src == self:
            return v.copy()
        s = src.wavelengths
        x = self._wl
        if not extrapolate and (x[0] < s[0] or x[-1] > s[-1]):
            raise KMDomainError(f"resample: the grid {self.start:g}–{self.stop:g} nm is not covered by the data "
                                f"({s[0]:g}–{s[-1]:g} nm); pass extrapolate=True to hold the end values")
        if s.size == 1:
            return np.repeat(v, x.size, axis=-1)
        i = np.clip(np.searchsorted(s, x, side="right") - 1, 0, s.size - 2)
        t = np.clip((x - s[i]) / (s[i + 1] - s[i]), 0.0, 1.0)
        v0 = v[..., i]
        v1 = v[..., i + 1]
        with np.errstate(all="ignore"):
            out = v0 + t * (v1 - v0)
        out = np.where(t == 0.0, v0, out)
        out = np.where(t == 1.0, v1, out)
        return out


#: the paper's measurement grid: 380–780 nm, 5 nm steps, 81 samples
DEFAULT_GRID = WavelengthGrid(380.0, 780.0, 5.0)
