"""Summaries of timed series for the benchmarks' JSON: a median never stands alone (it hides hitches)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Sequence


def spread(key: str, values: Sequence[float], digits: int = 2) -> dict[str, float]:
    """The median of ``values`` under ``key``, its 90th percentile and its maximum beside it.

    Args:
        key: the median's name (e.g. ``save_ms``); the others are ``key + "_p90"`` (linear
            interpolation between order statistics) and ``key + "_max"``.
        values: at least one sample, in the unit ``key`` names.
        digits: decimals kept (a figure these would round to 0 keeps three significant digits instead:
            a short time is small, not nothing).

    Returns:
        The three figures by name, in the unit of ``values``.
    """
    arr = np.asarray(values, dtype=np.float64)
    return {key: _rounded(float(np.median(arr)), digits),
            f"{key}_p90": _rounded(float(np.percentile(arr, 90)), digits),
            f"{key}_max": _rounded(float(arr.max()), digits)}


def _rounded(value: float, digits: int) -> float:
    """``value`` to ``digits`` decimals, or to three significant digits where those decimals give 0 (not 0)."""
    out = round(value, digits)
    return float(f"{value:.3g}") if out == 0 and value != 0 else out


def de2000_srgb8(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """ΔE2000 between two uint8 sRGB images (H, W, 3) at the pixels of ``mask`` (bool (H, W)), km's maths."""
    from km.colour import delta_e2000, linear_rgb_to_lab
    from km.srgb import srgb_decode

    la = linear_rgb_to_lab(srgb_decode(a[mask].astype(np.float64) / 255.0))
    lb = linear_rgb_to_lab(srgb_decode(b[mask].astype(np.float64) / 255.0))
    return np.asarray(delta_e2000(la, lb), np.float64)
