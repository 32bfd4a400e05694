"""The sRGB transfer functions (IEC 61966-2-1), the one home of the encode/decode pair in Sheer.

Both work on any array shape, elementwise, on values in [0, 1] (values outside are extended by the same
formulas; negative values are the caller's to clip). The constants are the standard's: a linear segment
below 0.0031308 (linear) / 0.04045 (encoded), a 2.4 power with offset 0.055 above.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def srgb_encode(linear: ArrayLike) -> np.ndarray:
    """Linear light [0, 1] → sRGB-encoded [0, 1] (float64, or the input's float dtype)."""
    c = np.asarray(linear)
    if not np.issubdtype(c.dtype, np.floating):
        c = c.astype(np.float64)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(np.maximum(c, 0.0031308), 1.0 / 2.4) - 0.055)


def srgb_decode(encoded: ArrayLike) -> np.ndarray:
    """sRGB-encoded [0, 1] → linear light [0, 1] (float64, or the input's float dtype)."""
    v = np.asarray(encoded)
    if not np.issubdtype(v.dtype, np.floating):
        v = v.astype(np.float64)
    return np.where(v <= 0.04045, v / 12.92, np.power((np.maximum(v, 0.04045) + 0.055) / 1.055, 2.4))


def srgb_encode_scalar(linear: float) -> float:
    """:func:`srgb_encode` of one Python float (no numpy round trip, for uniforms and colours)."""
    return 12.92 * linear if linear <= 0.0031308 else 1.055 * linear ** (1.0 / 2.4) - 0.055
