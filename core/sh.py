"""Real spherical harmonics of degree ≤ 2, for diffuse lighting (Ramamoorthi & Hanrahan 2001).

Shared by the renderer's environment lighting (:mod:`render.lights`) and the capture's ambient light from a
mirror-ball probe (:mod:`capture.ambient`), which may not import each other.
"""

from __future__ import annotations

import math

import numpy as np


def sh9_basis(d: np.ndarray) -> np.ndarray:
    """Real SH basis Y_lm (l ≤ 2) at unit directions ``d`` (..., 3) → (..., 9).

    Order: Y00; Y1,-1 (y), Y10 (z), Y11 (x); Y2,-2 (xy), Y2,-1 (yz), Y20, Y21 (xz), Y22 (x² − y²).
    """
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([
        0.282095 * np.ones_like(x),
        0.488603 * y, 0.488603 * z, 0.488603 * x,
        1.092548 * x * y, 1.092548 * y * z, 0.315392 * (3 * z * z - 1), 1.092548 * x * z,
        0.546274 * (x * x - y * y),
    ], axis=-1)


#: Convolution with the clamped cosine, per coefficient (bands l = 0, 1, 2): radiance → irradiance.
SH_COSINE = np.array([math.pi, *[2 * math.pi / 3] * 3, *[math.pi / 4] * 5])
