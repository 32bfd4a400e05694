"""The skin region of the photograph: a mask painted by the user, or computed.

Computed: the polygon of the projected face landmarks (convex hull, grown by 30 % about its centroid),
minus ellipses over the eyes, the brows and the mouth, intersected with the head's front-facing pixels,
then refined by a skin-colour model on the hue (see :func:`refine_by_skin_colour`). Without landmarks the polygon step is skipped (the head's
front-facing pixels are the candidates).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.path import Path as MplPath
from scipy.spatial import ConvexHull

from core.errors import SheerError

if TYPE_CHECKING:
    from pathlib import Path

    from capture.camera import Camera


class MaskError(SheerError, ValueError):
    """A skin mask that cannot be used (wrong size, empty, unreadable)."""


FACE_LANDMARKS = ("forehead", "left_cheek", "right_cheek", "chin", "left_eye", "right_eye", "lip_centre",
                  "nose_tip", "left_eye_outer", "right_eye_outer", "mouth_left", "mouth_right")


def _ellipse(shape: tuple[int, int], centre: np.ndarray, axis_x: np.ndarray, ry: float) -> np.ndarray:
    """Pixels inside an ellipse with centre, a major-axis vector (its half length) and a minor half length."""
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w]
    p = np.stack([xx + 0.5 - centre[0], yy + 0.5 - centre[1]], axis=-1)
    rx = float(np.linalg.norm(axis_x))
    ux = axis_x / max(rx, 1e-9)
    uy = np.array([-ux[1], ux[0]])
    a = p @ ux
    b = p @ uy
    return (a / max(rx, 1e-9)) ** 2 + (b / max(ry, 1e-9)) ** 2 <= 1.0


def landmark_region(camera: Camera, landmarks: dict[str, tuple[float, float, float]],
                    shape: tuple[int, int]) -> np.ndarray | None:
    """The landmark polygon minus eyes, brows and mouth (bool (H, W)), or None without enough landmarks."""
    pts = {k: np.asarray(v, float) for k, v in landmarks.items() if k in FACE_LANDMARKS}
    if not {"left_eye", "right_eye"} <= set(pts) or len(pts) < 5:
        return None
    names = list(pts)
    px, _ = camera.project(np.stack([pts[n] for n in names]))
    p2 = dict(zip(names, px))
    hull_pts = np.stack(list(p2.values()))
    c = hull_pts.mean(axis=0)
    grown = c + 1.3 * (hull_pts - c)
    hull = ConvexHull(grown)
    poly = MplPath(grown[hull.vertices])
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w]
    inside = poly.contains_points(np.stack([xx.ravel() + 0.5, yy.ravel() + 0.5], axis=1)).reshape(h, w)
    le, re = p2["left_eye"], p2["right_eye"]
    across = le - re
    ed = float(np.linalg.norm(across))
    up = np.array([across[1], -across[0]]) / max(ed, 1e-9)
    if up[1] > 0:  # "up" must point to smaller y (the image's top)
        up = -up
    for eye in (le, re):
        inside &= ~_ellipse(shape, eye, across * 0.28, 0.16 * ed)
        inside &= ~_ellipse(shape, eye + up * 0.30 * ed, across * 0.32, 0.12 * ed)
    if "lip_centre" in p2:
        inside &= ~_ellipse(shape, p2["lip_centre"], across * 0.42, 0.20 * ed)
    return inside


def refine_by_skin_colour(photo_lin: np.ndarray, candidates: np.ndarray, max_sigmas: float = 3.0) -> np.ndarray:
    """Keep the candidate pixels whose hue fits a robust skin-hue model.

    The hue is the angle of the chromaticity (r, g) = (R, G)/(R+G+B) about the white point (1/3, 1/3);
    unlike the chromaticity itself it is unchanged by a white specular highlight, which must stay in
    the mask (the exponent is measured on it). Pixels more than ``max_sigmas`` robust deviations
    (1.4826 × MAD, at least 4°) from the median hue, or darker than a quarter of the median luminance,
    are dropped.
    """
    rgb = photo_lin[candidates]
    s = rgb.sum(axis=1)
    ok = s > 1e-4
    chrom = rgb[ok, :2] / s[ok, None] - 1.0 / 3.0
    hue = np.degrees(np.arctan2(chrom[:, 1], chrom[:, 0]))
    med = np.median(hue)
    dev = np.abs((hue - med + 180.0) % 360.0 - 180.0)
    sigma = max(1.4826 * float(np.median(dev)), 4.0)
    lum = rgb[ok] @ np.array([0.2126, 0.7152, 0.0722])
    good = np.zeros(len(rgb), dtype=bool)
    good[np.nonzero(ok)[0]] = (dev <= max_sigmas * sigma) & (lum >= 0.25 * np.median(lum))
    out = np.zeros_like(candidates)
    out[candidates] = good
    return out


def load_mask(path: str | Path, shape: tuple[int, int]) -> np.ndarray:
    """A painted mask: an image of the photograph's size, white (≥ 128) = skin."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            m = np.asarray(im.convert("L")) >= 128
    except FileNotFoundError:
        raise MaskError(f"{path}: mask file not found") from None
    except (UnidentifiedImageError, OSError, Image.DecompressionBombError) as exc:
        raise MaskError(f"{path}: cannot read the mask: {exc}") from None
    if m.shape != shape:
        raise MaskError(f"{path}: the mask is {m.shape[1]}×{m.shape[0]} but the photo is {shape[1]}×{shape[0]}")
    if not m.any():
        raise MaskError(f"{path}: the mask is empty (no white pixel)")
    return m
