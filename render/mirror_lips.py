"""Her lips in her photograph, for the mirror view's lip layers (:class:`render.mirror.MirrorView`).

The lip layers (lipstick, gloss, liner: :data:`LIP_CATEGORIES`) are painted in the head's UV atlas from a
region rasterised on the mesh; seen through the photograph's camera that edge is the mesh's polygon,
feathered, and it need not lie on her vermilion border. Where the face knows her own landmarks (the
automatic capture: face.json ``landmarks``, MediaPipe's 478 points in the photograph's pixels), the mirror
clips those layers in image space to her lips' outer contour instead:

- :func:`lip_outline`: a smooth closed curve through the outer-lip landmarks — the upper and the lower
  lip each a cubic B-spline from one mouth corner to the other (the corners kept sharp: the commissures);
  a B-spline lies within its control polygon on a convex stretch, so the clip never reaches past the
  atlas's own fill there;
- :func:`lip_coverage`: that curve rasterised at the photograph's resolution, antialiased: per pixel
  ``clip(0.5 − d / w)`` for its signed distance d to the curve (positive outside) over a ramp of
  w = :data:`LIP_EDGE_FEATHER_MM` (at least one pixel), centred on the curve;
- :func:`micro_shading`: her lips' own high-frequency shading, the photograph's luminance over its
  low-pass within the lips (Gaussian, σ = :data:`DETAIL_SIGMA_MM`, normalised by the coverage so the
  skin around does not bleed in). The lips' micro-geometry (lines, the curl's shading) shades the layer
  on them as it shades the bare lip: the composite multiplies the made-up colour by it, and divides it
  out of the albedo the layers go over (``mirror_face.frag.glsl``).

Millimetres in the photograph: the fitted head is in mm (``head.mm_per_unit``); the camera projects a
millimetre at the lips' depth to :func:`px_per_mm` pixels.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from core.camera import Pinhole
    from painting.head import Head
    from render.km_pass import LayerInput

#: MediaPipe face-mesh outer-lip contours, mouth corner (61, her right) to mouth corner (291, her left).
UPPER_OUTER = (61, 185, 40, 39, 37, 0, 267, 269, 270, 409, 291)
LOWER_OUTER = (61, 146, 91, 181, 84, 17, 314, 405, 321, 375, 291)
#: Material categories whose layers are clipped to her lips.
LIP_CATEGORIES = frozenset({"lipstick", "lip gloss", "lip liner"})
#: The clip's edge ramp, full width in mm, centred on the contour (a pixel at least: antialiasing).
LIP_EDGE_FEATHER_MM = 0.3
#: σ of the low-pass that separates her lips' micro-shading from their smooth shading, mm.
DETAIL_SIGMA_MM = 1.0
#: The share of her lips' high-frequency log-luminance that is shading by their micro-geometry (the rest:
#: their colour's own variation, which the layers' transmittance hides as it hides the rest of her albedo).
GEOMETRY_SHARE = 0.5
#: The micro-shading ratio is kept within [1 / MAX_SHADING, MAX_SHADING].
MAX_SHADING = 3.0
#: Samples per landmark span of the outline's splines.
SPLINE_SAMPLES = 24


def is_lip_layer(layer: LayerInput) -> bool:
    """Whether ``layer``'s material is a lip product (:data:`LIP_CATEGORIES`)."""
    return str(getattr(layer.material, "category", "")).strip().casefold() in LIP_CATEGORIES


def _bspline(points: np.ndarray, samples: int = SPLINE_SAMPLES) -> np.ndarray:
    """A uniform cubic B-spline through the ends of ``points`` (N, 2), ends clamped (tripled); (M, 2)."""
    p = np.concatenate([points[:1], points[:1], points, points[-1:], points[-1:]])
    t = np.linspace(0.0, 1.0, samples, endpoint=False)
    b = np.stack([(1 - t) ** 3, 3 * t ** 3 - 6 * t ** 2 + 4, -3 * t ** 3 + 3 * t ** 2 + 3 * t + 1, t ** 3]) / 6
    out = [b.T @ p[i:i + 4] for i in range(len(p) - 3)]
    return np.concatenate([*out, points[-1:]])


def lip_outline(points: np.ndarray, samples: int = SPLINE_SAMPLES) -> np.ndarray:
    """Her lips' outer contour from the face-mesh landmarks ``points`` (≥ 468, 2+) in pixels: closed (M, 2).

    The upper lip from corner 61 to corner 291, then the lower lip back (each :func:`_bspline`).
    """
    pts = np.asarray(points, dtype=np.float64)[:, :2]
    upper = _bspline(pts[list(UPPER_OUTER)], samples)
    lower = _bspline(pts[list(LOWER_OUTER)], samples)
    return np.concatenate([upper[:-1], lower[::-1][:-1]])


def signed_distance(outline: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Signed distance (pixels, positive outside) of points (x, y) to the closed polyline ``outline``."""
    a = outline
    b = np.roll(outline, -1, axis=0)
    px = np.stack([x.ravel(), y.ravel()], axis=1)
    best = np.full(len(px), np.inf)
    inside = np.zeros(len(px), bool)
    for s in range(0, len(a), 64):
        a0, b0 = a[s:s + 64], b[s:s + 64]
        ab = b0 - a0
        ap = px[:, None, :] - a0[None]
        t = np.clip(np.einsum("pkc,kc->pk", ap, ab) / np.maximum((ab * ab).sum(1), 1e-12), 0.0, 1.0)
        d = np.linalg.norm(ap - t[..., None] * ab[None], axis=2)
        best = np.minimum(best, d.min(axis=1))
        # even-odd rule: crossings of a ray towards +x
        ya, yb = a0[:, 1][None], b0[:, 1][None]
        cross = (ya > px[:, 1:2]) != (yb > px[:, 1:2])
        xc = a0[:, 0][None] + (px[:, 1:2] - ya) / np.where(yb == ya, 1.0, yb - ya) * ab[:, 0][None]
        inside ^= (cross & (px[:, 0:1] < xc)).sum(axis=1) % 2 == 1
    return np.where(inside, -best, best).reshape(x.shape)


def px_per_mm(camera: Pinhole, head: Head, point: np.ndarray) -> float:
    """Pixels per millimetre at ``point`` (mesh units) across the photograph's view (its camera's x axis)."""
    p = np.asarray(point, dtype=np.float64)
    step = np.asarray(camera.R, dtype=np.float64)[0] / float(head.mm_per_unit)  # 1 mm along the image's x
    px, _ = camera.project(np.stack([p, p + step]))
    return float(np.linalg.norm(px[1] - px[0]))


def lip_coverage(outline: np.ndarray, box: tuple[int, int, int, int], ppmm: float,
                 feather_mm: float = LIP_EDGE_FEATHER_MM) -> np.ndarray:
    """The lips' antialiased coverage over ``box`` (x0, y0, x1, y1: pixels, top row first): float32 (h, w).

    Pixel (i, j) of the box has its centre at (x0 + j + 0.5, y0 + i + 0.5) (the capture's pixel
    convention); its coverage ramps from 1 to 0 over ``feather_mm`` (≥ 1 pixel) centred on ``outline``.
    """
    x0, y0, x1, y1 = box
    yy, xx = np.mgrid[y0:y1, x0:x1] + 0.5
    sd = signed_distance(outline, xx, yy)
    w = max(feather_mm * ppmm, 1.0)
    return np.clip(0.5 - sd / w, 0.0, 1.0).astype(np.float32)


def micro_shading(luminance: np.ndarray, coverage: np.ndarray, sigma_px: float,
                  share: float = GEOMETRY_SHARE) -> np.ndarray:
    """Her lips' micro-shading: luminance / its coverage-weighted Gaussian low-pass (σ pixels); 1 off the lips.

    ``luminance``: linear (h, w) of the photograph over the same box as ``coverage``. float32 (h, w),
    within [1 / :data:`MAX_SHADING`, :data:`MAX_SHADING`].
    """
    from scipy.ndimage import gaussian_filter

    m = (coverage > 0.5).astype(np.float64)
    low = gaussian_filter(luminance * m, sigma_px, mode="nearest")
    weight = gaussian_filter(m, sigma_px, mode="nearest")
    ratio = np.where(m > 0, luminance / np.maximum(low / np.maximum(weight, 1e-6), 1e-6), 1.0)
    return (np.clip(ratio, 1.0 / MAX_SHADING, MAX_SHADING) ** share).astype(np.float32)


@dataclass(frozen=True)
class LipImage:
    """Her lips in the photograph over a box.

    ``origin`` (x0, y0: its top-left pixel, top row first), ``coverage`` and ``shading`` float32 (h, w)
    (:func:`lip_coverage`, :func:`micro_shading`), ``outline`` (M, 2) pixels, ``px_per_mm``.
    """

    origin: tuple[int, int]
    coverage: np.ndarray
    shading: np.ndarray
    outline: np.ndarray
    px_per_mm: float


def face_landmarks_px(face: object, width: int, height: int) -> np.ndarray | None:
    """The face's detected face-mesh landmarks in pixels of a ``width`` × ``height`` photograph, or None.

    Read from ``face.landmarks()`` (``capture.face.Face``: face.json ``landmarks``, pixels of the image
    they were detected on, scaled here to this size); None for a face without them (a capture from points).
    """
    get = getattr(face, "landmarks", None)
    lm = get() if callable(get) else None
    if lm is None:
        return None
    pts = np.asarray(lm.points, dtype=np.float64)
    if pts.ndim != 2 or len(pts) < 468 or not np.all(np.isfinite(pts[:468, :2])):
        return None
    return pts[:, :2] * np.array([width / float(lm.width), height / float(lm.height)])


def lip_image(face: object, head: Head, camera: Pinhole, photo8: np.ndarray) -> LipImage | None:
    """Her lips in ``photo8`` (uint8 sRGB (H, W, 3)) seen by ``camera``, or None without her landmarks."""
    from km.srgb import srgb_decode

    h, w = photo8.shape[:2]
    pts = face_landmarks_px(face, w, h)
    if pts is None:
        return None
    outline = lip_outline(pts)
    lm = head.metadata.landmarks
    centre = lm.get("lip_centre") if isinstance(lm, dict) else None
    if centre is None:
        centre = np.asarray(head.vertices, dtype=np.float64).mean(axis=0)
    ppmm = px_per_mm(camera, head, np.asarray(centre, dtype=np.float64))
    pad = int(np.ceil(4.0 * DETAIL_SIGMA_MM * ppmm)) + 2
    x0, y0 = (max(int(np.floor(v)) - pad, 0) for v in outline.min(axis=0))
    x1, y1 = min(int(np.ceil(outline[:, 0].max())) + pad, w), min(int(np.ceil(outline[:, 1].max())) + pad, h)
    if x1 <= x0 or y1 <= y0:
        return None
    coverage = lip_coverage(outline, (x0, y0, x1, y1), ppmm)
    lin = srgb_decode(np.asarray(photo8[y0:y1, x0:x1, :3], dtype=np.float64) / 255.0)
    lum = lin @ np.array([0.2126, 0.7152, 0.0722])
    shading = micro_shading(lum, coverage, DETAIL_SIGMA_MM * ppmm)
    return LipImage((x0, y0), coverage, shading, outline, ppmm)
