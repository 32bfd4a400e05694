"""Synthetic photographs for the shade finder's tests: a ColorChecker and a skin patch under a known light.

Rendered spectrally: each surface's reflectance (the checker's from colour-science's Ohta spectra, the
skin's from the skin model) under the light, seen by a camera whose sensitivities are the sRGB
colour-matching functions (no white balance), so the light's tint stays in the picture; exposed so
that the white patch is 0.85, 8-bit sRGB.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import colour
import numpy as np
from PIL import Image

from km.colour import spectral_xyz_matrix
from km.skin import skin_reflectance
from km.spectra import DEFAULT_GRID
from km.srgb import srgb_encode

if TYPE_CHECKING:
    from pathlib import Path

#: layout: 4 × 6 patches of PATCH px with GAP px between, from (X0, Y0); the skin patch below them
PATCH, GAP, X0, Y0 = 80, 12, 60, 40
SKIN_BOX = (60, 440, 200, 100)


def checker_reflectances() -> np.ndarray:
    """(24, n) the checker's reflectances on km's default grid."""
    sds = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    return np.stack([DEFAULT_GRID.resample(np.asarray(sd.values), np.asarray(sd.wavelengths), extrapolate=True)
                     for sd in sds.values()])


def camera_rgb(reflectance: np.ndarray, light: str) -> np.ndarray:
    """Linear camera RGB (..., 3) of reflectances under ``light``, not white balanced (XYZ → sRGB primaries)."""
    xyz = reflectance @ spectral_xyz_matrix(DEFAULT_GRID, light)
    return xyz @ np.asarray(colour.RGB_COLOURSPACES["sRGB"].matrix_XYZ_to_RGB).T


def write_photo(path: Path, light: str, skin: tuple[float, float], *, checker: bool = True) -> np.ndarray:
    """Write the photograph; returns the skin's reflectance spectrum (melanin, blood as given)."""
    skin_r = skin_reflectance(*skin)
    patches = camera_rgb(checker_reflectances(), light)
    scale = 0.85 / patches[18].max()
    img = np.full((560, 640, 3), 0.02)
    if checker:
        for i, rgb in enumerate(patches * scale):
            r, c = divmod(i, 6)
            y, x = Y0 + r * (PATCH + GAP), X0 + c * (PATCH + GAP)
            img[y:y + PATCH, x:x + PATCH] = rgb
    x, y, w, h = SKIN_BOX
    img[y:y + h, x:x + w] = camera_rgb(skin_r, light) * scale
    Image.fromarray(np.round(srgb_encode(np.clip(img, 0.0, 1.0)) * 255).astype(np.uint8)).save(path)
    return skin_r
