"""Deriving facial regions (:mod:`painting.regions`) from a head: landmarks, face-mesh contours, albedo.

Every region is first a hard outline on the face seen from the front: each covered texel of the atlas
(its baked 3D position) is put in the **face frame** — X along the midplane normal (subject's left +),
Y up (gnathion → forehead, made orthogonal), Z forward, in mm from the midplane point — and shapes are
tested in (X, Y). Only the front layer of the surface counts (texels facing forward and within
:data:`FRONT_DEPTH_MM` of the frontmost surface at their (X, Y)), so the inner mouth, the teeth and the
back of the head never join a region. The outline is then feathered (:func:`painting.regions.feather`).

Sources:

- **face-mesh heads** (468 or 478 vertices: MediaPipe's topology): lips, eyes, lids, crease, brow bone,
  under-eye and brows from the standard contour indices (:data:`CONTOURS`, as in MediaPipe's
  ``face_mesh`` annotations); the rest from the landmarks as below.
- **heads with landmarks** (the sidecar's ``left_eye_inner``… ``gnathion``): proportional shapes stated
  per region in :func:`_landmark_shapes`; for a head with an albedo in its own UVs the lips are the
  vermilion's colour edge (the red-to-green ratio, Otsu threshold) inside the landmarks' mouth box.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from painting.regions import (
    DEFAULT_FEATHER_MM,
    REGION_NAMES,
    REGION_RESOLUTION,
    Region,
    RegionError,
    RegionSet,
    decode_regions,
    feather,
    local_texel_mm,
    mesh_digest,
    reach_texels,
    regions_file,
    signed_distance,
    spread_to_padding,
    stored_mesh,
)

if TYPE_CHECKING:
    from pathlib import Path

    from painting.atlas import Atlas
    from painting.head import Head

#: Texels deeper than this behind the frontmost surface at their (X, Y) are not in any region (mm).
FRONT_DEPTH_MM = 4.0
#: The inner mouth of a head with landmarks: hidden texels within this depth behind the lip centre (mm).
INNER_MOUTH_DEPTH_MM = 20.0
#: Texels whose normal is further than this from the face frame's forward axis are not in front
#: regions (cosine); the jawline accepts side-facing texels.
FRONT_COS = 0.2

#: MediaPipe face-mesh contours (vertex indices of the 468-point topology; MediaPipe's annotations).
CONTOURS: dict[str, list[int]] = {
    "lipsUpperOuter": [61, 185, 40, 39, 37, 0, 267, 269, 270, 409, 291],
    "lipsLowerOuter": [61, 146, 91, 181, 84, 17, 314, 405, 321, 375, 291],
    "lipsUpperInner": [78, 191, 80, 81, 82, 13, 312, 311, 310, 415, 308],
    "lipsLowerInner": [78, 95, 88, 178, 87, 14, 317, 402, 318, 324, 308],
    "rightEyeUpper0": [33, 246, 161, 160, 159, 158, 157, 173, 133],
    "rightEyeLower0": [33, 7, 163, 144, 145, 153, 154, 155, 133],
    "rightEyeUpper2": [113, 225, 224, 223, 222, 221, 189],
    "rightEyeLower3": [143, 111, 117, 118, 119, 120, 121, 128, 245],
    "rightEyebrowUpper": [156, 70, 63, 105, 66, 107, 55, 193],
    "rightEyebrowLower": [35, 124, 46, 53, 52, 65],
    "leftEyeUpper0": [263, 466, 388, 387, 386, 385, 384, 398, 362],
    "leftEyeLower0": [263, 249, 390, 373, 374, 380, 381, 382, 362],
    "leftEyeUpper2": [342, 445, 444, 443, 442, 441, 413],
    "leftEyeLower3": [372, 340, 346, 347, 348, 349, 350, 357, 465],
    "leftEyebrowUpper": [383, 300, 293, 334, 296, 336, 285, 417],
    "leftEyebrowLower": [265, 353, 276, 283, 282, 295],
}
FACE_MESH_SIZES = (468, 478)
LANDMARKS_NEEDED = ("left_eye_inner", "left_eye_outer", "right_eye_inner", "right_eye_outer", "left_brow",
                    "right_brow", "left_cheek", "right_cheek", "nose_tip", "lip_centre", "upper_lip",
                    "lower_lip", "mouth_left", "mouth_right", "chin", "forehead", "nasion", "subnasale",
                    "gnathion")


class FaceFrame:
    """The face frame of a head (see the module docstring): mm coordinates of points and texels."""

    def __init__(self, head: Head) -> None:
        meta = head.metadata
        self.mpu = float(head.mm_per_unit)
        self.origin = np.asarray(meta.midplane_point, float)
        ex = np.asarray(meta.midplane_normal, float)
        ex /= np.linalg.norm(ex)
        lm = meta.landmarks
        up = (np.asarray(lm["forehead"], float) - np.asarray(lm["gnathion"], float)) if \
            "forehead" in lm and "gnathion" in lm else np.array([0.0, 1.0, 0.0])
        ey = up - np.dot(up, ex) * ex
        ey /= np.linalg.norm(ey)
        ez = np.cross(ex, ey)
        if "nose_tip" in lm and np.dot(np.asarray(lm["nose_tip"], float) - self.origin, ez) < 0:
            ex, ez = -ex, -ez  # keep a right-handed frame facing forward (subject's left then is -X)
        self.axes = np.stack([ex, ey, ez])

    def mm(self, points: np.ndarray) -> np.ndarray:
        """Points (…, 3) in mesh units → face-frame mm (…, 3)."""
        return (np.asarray(points, float) - self.origin) @ self.axes.T * self.mpu


def _inside(poly: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Points (x, y) inside the closed polygon ``poly`` (K, 2) (matplotlib's even–odd test)."""
    from matplotlib.path import Path as MplPath

    return np.asarray(MplPath(poly).contains_points(np.stack([x, y], axis=1)), bool)


def _parabola(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The parabola through three (X, Y) points evaluated at ``x`` (Lagrange form)."""
    (x0, y0), (x1, y1), (x2, y2) = p0, p1, p2
    return (y0 * (x - x1) * (x - x2) / ((x0 - x1) * (x0 - x2)) + y1 * (x - x0) * (x - x2) / ((x1 - x0) * (x1 - x2))
            + y2 * (x - x0) * (x - x1) / ((x2 - x0) * (x2 - x1)))


def _capsule(x: np.ndarray, y: np.ndarray, a: np.ndarray, b: np.ndarray, r: float) -> np.ndarray:
    """Points within ``r`` (mm) of the segment a–b (face-frame X, Y)."""
    ab = b - a
    t = np.clip(((x - a[0]) * ab[0] + (y - a[1]) * ab[1]) / float(ab @ ab), 0.0, 1.0)
    return (x - a[0] - t * ab[0]) ** 2 + (y - a[1] - t * ab[1]) ** 2 <= r * r


class _Texels:
    """The atlas's covered texels in the face frame: X, Y, Z (mm), facing (cos to forward), front layer."""

    def __init__(self, atlas: Atlas, frame: FaceFrame, allowed: np.ndarray) -> None:
        self.shape = atlas.coverage.shape
        self.allowed = allowed
        self.texel_mm = float(atlas.texel_mm)
        self.flat = np.flatnonzero(atlas.coverage.reshape(-1))
        p = frame.mm(atlas.position.reshape(-1, 3)[self.flat])
        self.x, self.y, self.z = p[:, 0], p[:, 1], p[:, 2]
        n = atlas.normal.reshape(-1, 3)[self.flat].astype(float)
        self.facing = n @ frame.axes[2]
        # The frontmost surface per 1 mm cell of (X, Y): a texel deeper than FRONT_DEPTH_MM behind it is
        # hidden (inner mouth, teeth, inside the nostrils, the back of the head).
        ix = np.floor(self.x).astype(np.int64)
        iy = np.floor(self.y).astype(np.int64)
        key = (ix - ix.min()) * (int(iy.max() - iy.min()) + 1) + (iy - iy.min())
        top = np.full(int(key.max()) + 1, -np.inf)
        np.maximum.at(top, key, self.z)
        self.front = (self.z >= top[key] - FRONT_DEPTH_MM) & (self.facing > FRONT_COS)

    def image(self, sel: np.ndarray, anywhere: bool = False) -> np.ndarray:
        """A bool (R, R) image of the selected covered texels, only where regions are allowed unless ``anywhere``.

        Allowed: the skin and what it surrounds (see :func:`derive_regions`).
        """
        out = np.zeros(self.shape[0] * self.shape[1], bool)
        out[self.flat[sel]] = True
        return out.reshape(self.shape) if anywhere else out.reshape(self.shape) & self.allowed


def _albedo_blob(head: Head, tex: _Texels, box: np.ndarray, dark: bool = False) -> np.ndarray | None:
    """The texels of ``box`` past the albedo's colour edge there (bool per covered texel), or None.

    The feature is redness ``(R − G) / (R + G + B)`` (the vermilion), or darkness ``−(R + G + B)``
    (brow hair) with ``dark``, of the albedo at each texel's centre (the head's own UVs), split by Otsu's
    threshold over the box; the connected blobs at least a fifth the size of the largest, closed and
    with their holes filled. None when the
    box is empty or the two classes' means differ by less than a visible edge (0.03 in redness, 30 in
    the 0–765 sum).
    """
    from scipy import ndimage

    if head.albedo is None or not box.any():
        return None
    h, w = head.albedo.shape[:2]
    res = tex.shape[0]
    flat = tex.flat[box]
    rows = np.minimum(((flat // res + 0.5) / res * h).astype(np.int64), h - 1)
    cols = np.minimum(((flat % res + 0.5) / res * w).astype(np.int64), w - 1)
    rgb = head.albedo[rows, cols].astype(np.float64)
    feature = -rgb.sum(axis=1) if dark else (rgb[:, 0] - rgb[:, 1]) / (rgb.sum(axis=1) + 1.0)
    # smoothed over ~0.6 mm (a normalised Gaussian inside the box), so the edge follows the colour, not
    # the scan's pore-level noise
    feature = _smoothed(feature, flat, res, 0.6 / max(tex.texel_mm, 1e-6))
    hist, edges = np.histogram(feature, bins=64)
    centres = 0.5 * (edges[1:] + edges[:-1])
    w0 = np.cumsum(hist)
    w1 = w0[-1] - w0
    m0 = np.cumsum(hist * centres) / np.maximum(w0, 1)
    m1 = (np.sum(hist * centres) - np.cumsum(hist * centres)) / np.maximum(w1, 1)
    best = int(np.argmax(w0 * w1 * (m0 - m1) ** 2))
    if m1[best] - m0[best] < (30.0 if dark else 0.03):  # no visible edge
        return None
    sel = np.zeros(len(tex.flat), bool)
    sel[np.flatnonzero(box)[feature > centres[best]]] = True
    img = tex.image(sel)
    labels, count = ndimage.label(img)
    if count == 0:
        return None
    sizes = np.asarray(ndimage.sum(img, labels, index=np.arange(1, count + 1)))
    keep = 1 + np.flatnonzero(sizes >= 0.2 * sizes.max())  # both lips (the mouth line may part them)
    blob = ndimage.binary_closing(np.isin(labels, keep), iterations=2)
    return np.asarray(ndimage.binary_fill_holes(blob), bool).reshape(-1)[tex.flat] & box


def _smoothed(values: np.ndarray, flat: np.ndarray, res: int, sigma: float) -> np.ndarray:
    """``values`` at the texels ``flat`` (of a ``res``² image), Gaussian-averaged over those texels alone.

    A normalised convolution (``sigma`` in texels), read back at the same texels.
    Filtered on the texels' box grown by the kernel's radius (``gaussian_filter``'s ``truncate`` 4): every
    sum these texels read lies inside it, and beyond it the image is 0, so the same numbers as the whole image.
    """
    from scipy import ndimage

    r, c = flat // res, flat % res
    reach = int(4.0 * sigma + 0.5) + 1
    r0, c0 = max(int(r.min()) - reach, 0), max(int(c.min()) - reach, 0)
    shape = (min(int(r.max()) + reach + 1, res) - r0, min(int(c.max()) + reach + 1, res) - c0)
    img = np.zeros(shape)
    wgt = np.zeros(shape)
    img[r - r0, c - c0] = values
    wgt[r - r0, c - c0] = 1.0
    num = ndimage.gaussian_filter(img, sigma)
    den = ndimage.gaussian_filter(wgt, sigma)
    return np.asarray((num / np.maximum(den, 1e-9))[r - r0, c - c0])


#: The lash line's band: from this far below the lids' slit (mm) …
LASH_BELOW_MM = 0.3
#: … to this far above it at the inner corner, widening linearly by LASH_WIDEN_MM to the outer corner (mm).
LASH_ABOVE_MM = 1.0
LASH_WIDEN_MM = 1.2
#: A column's upper lid must stand at least this far in front of the lid below it to mark the slit (mm).
SLIT_MIN_STEP_MM = 0.8


def front_depth(head: Head, frame: FaceFrame, box: tuple[float, float, float, float], step_mm: float = 0.1
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The mesh's frontmost face-frame Z (mm) on a grid over ``box`` = (x0, x1, y0, y1) (face-frame mm).

    An orthographic z-buffer of the triangles seen from the front, ``step_mm`` apart (−inf where no
    triangle covers a point). Hand-written rather than ray-cast (trimesh's rays without Embree take
    seconds for the ~10⁵ points of an eye box; the few hundred triangles there rasterise in ~0.2 s).

    Returns:
        (xs (W,), ys (H,), Z (H, W)) in mm.
    """
    x0, x1, y0, y1 = box
    xs = np.arange(x0, x1, step_mm) + 0.5 * step_mm
    ys = np.arange(y0, y1, step_mm) + 0.5 * step_mm
    depth = np.full((len(ys), len(xs)), -np.inf)
    tri = frame.mm(head.vertices)[np.asarray(head.faces)]
    keep = ((tri[:, :, 0].max(1) >= x0) & (tri[:, :, 0].min(1) <= x1) & (tri[:, :, 1].max(1) >= y0)
            & (tri[:, :, 1].min(1) <= y1))
    for (ax, ay, az), (bx, by, bz), (cx, cy, cz) in tri[keep]:
        det = (by - cy) * (ax - cx) + (cx - bx) * (ay - cy)
        if abs(det) < 1e-12:
            continue  # seen edge-on
        i0, i1 = np.searchsorted(xs, [min(ax, bx, cx), max(ax, bx, cx)])
        j0, j1 = np.searchsorted(ys, [min(ay, by, cy), max(ay, by, cy)])
        if i1 <= i0 or j1 <= j0:
            continue
        gx, gy = np.meshgrid(xs[i0:i1], ys[j0:j1])
        l1 = ((by - cy) * (gx - cx) + (cx - bx) * (gy - cy)) / det
        l2 = ((cy - ay) * (gx - cx) + (ax - cx) * (gy - cy)) / det
        l3 = 1.0 - l1 - l2
        z = np.where((l1 >= 0) & (l2 >= 0) & (l3 >= 0), l1 * az + l2 * bz + l3 * cz, -np.inf)
        np.maximum(depth[j0:j1, i0:i1], z, out=depth[j0:j1, i0:i1])
    return xs, ys, depth


def lid_slit(head: Head, frame: FaceFrame, inner: np.ndarray, outer: np.ndarray) -> np.polynomial.Polynomial | None:
    """The closed lids' slit of one eye: its face-frame Y (mm) as a cubic in s (0 at ``inner``, 1 at ``outer``).

    Along every 0.1 mm column between the eye corners, the front depth (:func:`front_depth`) is read
    from 5 mm below the corners' line to 3 mm above it: the upper lid's margin overhangs the lower lid,
    so the depth rises by a step there (the Z minimum just below the step is the crease between the
    lids). The slit is the middle of the largest step (at least :data:`SLIT_MIN_STEP_MM`); a cubic is
    fitted to the columns that have one. None when fewer than half the columns do (no slit in the
    geometry: an open eye, or a mesh without lids).
    """
    s_cols = np.linspace(0.0, 1.0, max(int(abs(outer[0] - inner[0]) / 0.1), 8))
    x_cols = inner[0] + s_cols * (outer[0] - inner[0])
    y_line = inner[1] + s_cols * (outer[1] - inner[1])
    xs, ys, depth = front_depth(head, frame, (float(x_cols.min()) - 0.2, float(x_cols.max()) + 0.2,
                                              float(y_line.min()) - 5.0, float(y_line.max()) + 3.0))
    found_s, found_y = [], []
    for s, x, yc in zip(s_cols, x_cols, y_line):
        col = depth[:, min(int(np.searchsorted(xs, x)), len(xs) - 1)]
        win = (ys >= yc - 5.0) & (ys <= yc + 3.0) & np.isfinite(col)
        if win.sum() < 10:
            continue
        z, y = col[win], ys[win]
        rise = np.diff(z)
        k = int(np.argmax(rise))
        if rise[k] >= SLIT_MIN_STEP_MM:
            found_s.append(s)
            found_y.append(0.5 * (y[k] + y[k + 1]))
    if len(found_s) < 0.5 * len(s_cols):
        return None
    return np.polynomial.Polynomial.fit(found_s, found_y, 3)


def _smooth_lower_lip(lips: np.ndarray, x: np.ndarray, y: np.ndarray, mouth_line: np.ndarray, x_lo: float,
                      x_hi: float) -> tuple[np.ndarray, bool]:
    """The lips with the lower lip's bottom edge made a smooth curve (bool per covered texel; and whether done).

    The albedo's colour edge follows reddish shadow under the lower lip's middle (a V dipping ~2 mm into
    the chin) and steps by a texel here and there. The lowest lip texel of every 0.5 mm column between
    the mouth corners (``x_lo``…``x_hi``, face-frame mm) is fitted with a quartic in X, refitted three
    times without the columns dipping more than 0.4 mm below it; lip texels more than 0.2 mm below the
    fit are dropped. Unchanged when fewer than 8 columns have lower-lip texels.
    """
    lower = lips & (y < mouth_line)
    inner = lower & (x > x_lo + 1.0) & (x < x_hi - 1.0)
    if not inner.any():
        return lips, False
    col = np.floor((x[inner] - x_lo) / 0.5).astype(np.int64)
    bottom = np.full(int(col.max()) + 1, np.inf)
    np.minimum.at(bottom, col, y[inner])
    cx = x_lo + 0.5 * (np.arange(len(bottom)) + 0.5)
    ok = np.isfinite(bottom)
    if ok.sum() < 8:
        return lips, False
    cx, bottom = cx[ok], bottom[ok]
    keep = np.ones(len(cx), bool)
    fit = np.polynomial.Polynomial.fit(cx, bottom, 4)
    for _ in range(3):
        keep = bottom - fit(cx) > -0.4
        fit = np.polynomial.Polynomial.fit(cx[keep], bottom[keep], 4)
    below = lower & (x > x_lo) & (x < x_hi) & (y < fit(np.clip(x, x_lo, x_hi)) - 0.2)
    return lips & ~below, True


def _landmark_shapes(head: Head, frame: FaceFrame, tex: _Texels) -> dict[str, tuple[np.ndarray, str]]:
    """Hard masks (bool (R, R)) and their sources from the sidecar's landmarks (face-frame mm)."""
    lm = {k: frame.mm(np.asarray(v, float)) for k, v in head.metadata.landmarks.items()}
    src = "landmarks (sidecar) and the bake's 3D positions, front view"
    out: dict[str, tuple[np.ndarray, str]] = {}
    for shapes in (_lip_shapes, _eye_shapes, _cheek_shapes, _centre_shapes):
        out.update(shapes(head, frame, tex, lm, src))
    return out


def _lip_shapes(head: Head, frame: FaceFrame, tex: _Texels, lm: dict[str, np.ndarray],
                src: str) -> dict[str, tuple[np.ndarray, str]]:
    """The lips, upper and lower: the albedo's vermilion edge in the landmarks' mouth box, else ellipses."""
    x, y, front = tex.x, tex.y, tex.front
    out: dict[str, tuple[np.ndarray, str]] = {}
    # Lips: the mouth box from the corners and lip points, refined by the albedo's vermilion edge.
    ml, mr, up_, lo_, lc = lm["mouth_left"], lm["mouth_right"], lm["upper_lip"], lm["lower_lip"], lm["lip_centre"]
    xl, xr = max(ml[0], mr[0]), min(ml[0], mr[0])
    cx = 0.5 * (xl + xr)
    half = 0.5 * (xl - xr) + 3.0
    top = up_[1] + 0.6 * (up_[1] - lc[1]) + 2.0
    bottom = lo_[1] - 0.6 * (lc[1] - lo_[1]) - 2.0
    box = front & (np.abs(x - cx) <= half) & (y <= top) & (y >= bottom)
    mouth_line = _parabola(mr[:2], lc[:2], ml[:2], x)
    lips = _albedo_blob(head, tex, box)
    if lips is not None:
        lip_src = "the albedo's vermilion colour edge (red/green ratio, Otsu) inside the landmarks' mouth box"
        lips, trimmed = _smooth_lower_lip(lips, x, y, mouth_line, xr, xl)
        if trimmed:
            lip_src += "; the lower lip's bottom edge a smooth quartic (shadow dips below it trimmed)"
    else:
        # No colour edge: an ellipse per lip through the corners and the upper/lower lip points.
        e_up = ((x - cx) / (0.5 * (xl - xr))) ** 2 + ((y - mouth_line) / max(up_[1] - lc[1], 1.0) / 1.3) ** 2
        e_lo = ((x - cx) / (0.5 * (xl - xr))) ** 2 + ((y - mouth_line) / max(lc[1] - lo_[1], 1.0) / 1.3) ** 2
        lips = front & (np.where(y >= mouth_line, e_up, e_lo) <= 1.0)
        lip_src = "ellipses through the landmarks' mouth corners and lip points (no albedo edge)"
    above = y >= mouth_line
    # the inner mouth: inside the mouth box, the texels hidden behind the lips (the lips' inner curl, the
    # mouth's inside), down to INNER_MOUTH_DEPTH_MM behind the lip centre
    inner = (np.abs(x - cx) <= half) & (y <= top) & (y >= bottom) & ~front & (tex.z >= lc[2] - INNER_MOUTH_DEPTH_MM)
    out["inner_mouth"] = (tex.image(inner, anywhere=True),
                          f"the texels hidden behind the lips in the landmarks' mouth box (more than {FRONT_DEPTH_MM:g} mm "
                          f"behind the frontmost surface, at most {INNER_MOUTH_DEPTH_MM:g} mm behind the lip centre)")
    out["lips"] = (tex.image(lips), lip_src)
    out["upper_lip"] = (tex.image(lips & above), lip_src + "; split at the mouth line (parabola through the corners "
                        "and lip_centre)")
    out["lower_lip"] = (tex.image(lips & ~above), out["upper_lip"][1])
    return out


def _eye_shapes(head: Head, frame: FaceFrame, tex: _Texels, lm: dict[str, np.ndarray],
                src: str) -> dict[str, tuple[np.ndarray, str]]:
    """Per eye: the lash line, the eye, its lid, crease, brow bone, under-eye and brow (see the comment)."""
    x, y, front = tex.x, tex.y, tex.front
    out: dict[str, tuple[np.ndarray, str]] = {}
    # Eyes, per side: the lash line joins the corners (bowed 1.5 mm up); the lid, crease and brow bone are
    # nested half-ellipses over it (semi-axes 0.55 × the eye's width and 10 / 14 mm); under-eye a 12 mm
    # half-ellipse below; brows a 10 mm band on the parabola through the inner corner, brow point and
    # 8 mm past the outer corner.
    parts: dict[str, np.ndarray] = {k: np.zeros(len(x), bool) for k in
                                    ("eyes", "upper_eyelid", "crease", "brow_bone", "under_eye", "brows")}
    brow_src = "a 10 mm band through the brow landmark"
    lash_line = np.zeros(len(x), bool)
    slits = 0
    for side in ("left", "right"):
        inner, outer, brow = lm[f"{side}_eye_inner"], lm[f"{side}_eye_outer"], lm[f"{side}_brow"]
        out_dir = np.sign(outer[0] - inner[0])
        width = abs(outer[0] - inner[0])
        s = (x - inner[0]) / (outer[0] - inner[0])
        lash = inner[1] + s * (outer[1] - inner[1]) + 6.0 * s * (1 - s)
        ecx = 0.5 * (inner[0] + outer[0])
        a = 0.55 * width
        h = y - lash
        ex2 = ((x - ecx) / a) ** 2
        e_lid = np.sqrt(ex2 + (h / 10.0) ** 2)
        e_cr = np.sqrt(ex2 + (h / 14.0) ** 2)
        end = np.array([outer[0] + 6.0 * out_dir, brow[1] - 5.0])
        brow_line = _parabola(np.array([inner[0] - 2.0 * out_dir, brow[1] - 2.0]), brow[:2], end, x)
        in_brow_x = ((x - inner[0]) * out_dir >= -4.0) & ((x - end[0]) * out_dir <= 0.0)
        brow_box = front & in_brow_x & (np.abs(y - brow_line) <= 8.0)
        hair = _albedo_blob(head, tex, brow_box, dark=True)
        parts["eyes"] |= front & (ex2 + ((h + 1.0) / 2.5) ** 2 <= 1.0)
        parts["upper_eyelid"] |= front & (h >= -2.5) & (e_lid <= 1.0)  # down to the closed lids' slit
        parts["crease"] |= front & (h >= 0.0) & (e_lid > 1.0) & (e_cr <= 1.0)
        parts["brows"] |= (front & in_brow_x & (np.abs(y - brow_line) <= 5.0)) if hair is None else hair
        brow_src = brow_src if hair is None else "the albedo's dark brow hair (luminance, Otsu) in a 16 mm band " \
            "through the brow landmark"
        parts["brow_bone"] |= front & (h >= 0.0) & (e_cr > 1.0) & (y < brow_line - 5.0) & \
            (np.sqrt(ex2 / 1.15 ** 2 + (h / 30.0) ** 2) <= 1.0)
        parts["under_eye"] |= front & (h < -2.5) & (np.sqrt(ex2 + (h / 12.0) ** 2) <= 1.0)
        slit = lid_slit(head, frame, inner, outer)
        if slit is not None:
            slits += 1
            sc = np.clip(s, 0.0, 1.0)
            above_slit = y - slit(sc)
            lash_line |= front & (s >= -0.02) & (s <= 1.04) & (above_slit >= -LASH_BELOW_MM) & \
                (above_slit <= LASH_ABOVE_MM + LASH_WIDEN_MM * sc)
    if slits == 2:
        out["lash_line"] = (tex.image(lash_line), src + f": the closed lids' slit (the step in the front depth "
                            f"where the upper lid overhangs the lower, a cubic between the eye corners), from "
                            f"{LASH_BELOW_MM:g} mm below it to {LASH_ABOVE_MM:g} mm above at the inner corner, "
                            f"{LASH_ABOVE_MM + LASH_WIDEN_MM:g} mm at the outer")
    else:
        out["lash_line"] = (tex.image(np.zeros(len(x), bool)), "no slit between closed lids in the geometry (no "
                            "step in the front depth between the eye corners)")
    eye_src = (src + ": lash line through the eye corners; lid/crease/brow bone nested half-ellipses "
               "10/14 mm high; under-eye 12 mm")
    for k, sel in parts.items():
        out[k] = (tex.image(sel), eye_src if k != "brows" else src + ": " + brow_src)
    return out


def _cheek_shapes(head: Head, frame: FaceFrame, tex: _Texels, lm: dict[str, np.ndarray],
                  src: str) -> dict[str, tuple[np.ndarray, str]]:
    """The cheeks' apples and cheekbones."""
    x, y, front = tex.x, tex.y, tex.front
    out: dict[str, tuple[np.ndarray, str]] = {}
    # Cheeks: the apple a 16 mm disc on the cheek landmark; the cheekbone a 10 mm capsule from just above
    # the apple up and out to the temple (22 mm past the outer eye corner, between eye and cheek).
    apple = np.zeros(len(x), bool)
    bone = np.zeros(len(x), bool)
    for side in ("left", "right"):
        ck, outer = lm[f"{side}_cheek"], lm[f"{side}_eye_outer"]
        out_dir = np.sign(outer[0] - lm[f"{side}_eye_inner"][0])
        apple |= front & ((x - ck[0]) ** 2 + (y - ck[1]) ** 2 <= 16.0 ** 2)
        temple = np.array([outer[0] + 22.0 * out_dir, 0.5 * (outer[1] + ck[1]) + 2.0])
        bone |= (tex.facing > 0.0) & _capsule(x, y, ck[:2] + np.array([6.0 * out_dir, 6.0]), temple, 10.0)
    out["cheek_apple"] = (tex.image(apple), src + ": a 16 mm disc on the cheek landmark")
    out["cheekbone"] = (tex.image(bone), src + ": a 10 mm capsule from the apple to the temple")
    return out


def _centre_shapes(head: Head, frame: FaceFrame, tex: _Texels, lm: dict[str, np.ndarray],
                   src: str) -> dict[str, tuple[np.ndarray, str]]:
    """The face's middle: nose bridge, forehead, T-zone and jawline."""
    x, y, front = tex.x, tex.y, tex.front
    out: dict[str, tuple[np.ndarray, str]] = {}
    lc = lm["lip_centre"]
    # Nose, forehead, T-zone, jaw.
    na, nt, sn, fh, gn, ch = lm["nasion"], lm["nose_tip"], lm["subnasale"], lm["forehead"], lm["gnathion"], lm["chin"]
    brow_top = max(lm["left_brow"][1], lm["right_brow"][1])
    eye_half = max(abs(lm["left_eye_outer"][0]), abs(lm["right_eye_outer"][0]))
    bridge = front & (np.abs(x - na[0]) <= 6.0) & (y <= na[1]) & (y >= nt[1] + 8.0)
    forehead = (tex.facing > 0.0) & (y >= brow_top + 10.0) & \
        ((x / (eye_half + 15.0)) ** 2 + ((y - brow_top - 10.0) / (fh[1] + 40.0 - brow_top)) ** 2 <= 1.0)
    nose = (tex.facing > 0.0) & (np.abs(x - na[0]) <= 14.0) & (y <= na[1]) & (y >= sn[1] - 2.0)
    chin = front & (((x - ch[0]) / 18.0) ** 2 + ((y - ch[1]) / 14.0) ** 2 <= 1.0)
    out["nose_bridge"] = (tex.image(bridge), src + ": 12 mm wide from the nasion to 8 mm above the nose tip")
    out["forehead"] = (tex.image(forehead), src + ": 10 mm above the brows to the hairline (skin "
                       "mask): a half-ellipse 15 mm wider than the outer eye corners")
    out["t_zone"] = (tex.image(forehead | nose | chin), src + ": forehead ∪ nose (28 mm wide, nasion to "
                     "subnasale) ∪ chin (36 × 28 mm ellipse)")
    mouth_y = lc[1]
    level = (np.abs(y - mouth_y) <= 3.0) & (tex.facing > -0.3)
    face_half = float(np.max(np.abs(x[level]))) if level.any() else eye_half + 20.0
    x_go, y_go = 0.92 * face_half, mouth_y - 0.25 * (mouth_y - gn[1])
    jaw_curve = gn[1] + (y_go - gn[1]) * np.minimum(np.abs(x) / x_go, 1.0) ** 2
    jaw = (tex.facing > -0.5) & (np.abs(x) <= x_go) & (np.abs(y - jaw_curve) <= 8.0) & (tex.z > lc[2] - 95.0)
    out["jawline"] = (tex.image(jaw), src + ": a 16 mm band on the parabola from the gnathion to the jaw "
                      "angles (0.92 × the face's half-width at the mouth, a quarter of the way down to the chin)")
    return out


def _contour_shapes(head: Head, frame: FaceFrame, tex: _Texels) -> dict[str, tuple[np.ndarray, str]]:
    """Hard masks of the contour regions of a face-mesh head (MediaPipe's 468-point contour indices)."""
    v = frame.mm(head.vertices)[:, :2]
    x, y, front = tex.x, tex.y, tex.front

    def poly(*chains: tuple[str, bool]) -> np.ndarray:
        pts = [v[CONTOURS[name][::-1] if rev else CONTOURS[name]] for name, rev in chains]
        return _inside(np.concatenate(pts), x, y) & front

    src = "face-mesh contours (MediaPipe 468-point indices: {})"
    upper = poly(("lipsUpperOuter", False), ("lipsUpperInner", True))
    lower = poly(("lipsLowerOuter", False), ("lipsLowerInner", True))
    out: dict[str, tuple[np.ndarray, str]] = {
        "inner_mouth": (mouth_opening_texels(head, tex.shape),
                        src.format("the triangles spanning lipsUpperInner + lipsLowerInner: the mouth's opening")),
        "upper_lip": (tex.image(upper), src.format("lipsUpperOuter − lipsUpperInner")),
        "lower_lip": (tex.image(lower), src.format("lipsLowerOuter − lipsLowerInner")),
        "lips": (tex.image(upper | lower), src.format("outer lip contour − inner lip contour")),
    }
    parts = {k: np.zeros(len(x), bool) for k in ("eyes", "lash_line", "upper_eyelid", "crease", "brow_bone",
                                                  "under_eye", "brows")}
    for side in ("left", "right"):
        s = side
        eye = poly((f"{s}EyeUpper0", False), (f"{s}EyeLower0", True))
        lid_top = poly((f"{s}EyeUpper0", False), (f"{s}EyeUpper2", True))
        brow = poly((f"{s}EyebrowUpper", False), (f"{s}EyebrowLower", True))
        above_lid = poly((f"{s}EyeUpper2", False), (f"{s}EyebrowLower", True))
        # the crease: the 4 mm band centred on EyeUpper2 (the socket's fold line)
        up2 = v[CONTOURS[f"{s}EyeUpper2"]]
        crease = np.zeros(len(x), bool)
        for a, b in zip(up2[:-1], up2[1:]):
            crease |= _capsule(x, y, a, b, 2.0)
        parts["eyes"] |= eye
        up0 = v[CONTOURS[f"{s}EyeUpper0"]]
        for a, b in zip(up0[:-1], up0[1:]):  # a 1.6 mm band centred on the upper lid's margin
            parts["lash_line"] |= _capsule(x, y, a, b, 0.8) & front
        parts["upper_eyelid"] |= lid_top & ~eye & ~crease
        parts["crease"] |= crease & front & ~eye
        parts["brows"] |= brow
        parts["brow_bone"] |= above_lid & ~crease & ~brow
        parts["under_eye"] |= poly((f"{s}EyeLower0", False), (f"{s}EyeLower3", True)) & ~eye
    sources = {"eyes": "EyeUpper0/EyeLower0", "lash_line": "a 1.6 mm band on EyeUpper0",
               "upper_eyelid": "EyeUpper0 to EyeUpper2, less the crease",
               "crease": "a 4 mm band on EyeUpper2", "brows": "EyebrowUpper/EyebrowLower",
               "brow_bone": "EyeUpper2 to EyebrowLower", "under_eye": "EyeLower0 to EyeLower3"}
    for k, sel in parts.items():
        out[k] = (tex.image(sel), src.format(sources[k]))
    return out


def mouth_opening_faces(head: Head) -> np.ndarray:
    """A face mesh's triangles across its mouth opening: those whose corners all lie on the inner lip contours.

    MediaPipe's topology closes the mouth with them (18 in the 468-point mesh); on a smiling face they
    span the teeth. Indices into ``head.faces`` (int64); empty for other heads.
    """
    if not is_face_mesh(head):
        return np.zeros(0, np.int64)
    inner = CONTOURS["lipsUpperInner"] + CONTOURS["lipsLowerInner"]
    return np.flatnonzero(np.all(np.isin(np.asarray(head.faces), inner), axis=1)).astype(np.int64)


def mouth_opening_texels(head: Head, shape: tuple[int, int]) -> np.ndarray:
    """Bool ``shape``: the texels of the head's own UVs in the mouth opening's triangles (:func:`mouth_opening_faces`).

    A texel belongs when its centre or a corner falls in one (conservative); top row first (row i covers
    v ∈ [i/H, (i+1)/H)).
    """
    from matplotlib.path import Path as MplPath

    h, w = shape
    out = np.zeros(shape, bool)
    uv = np.asarray(head.uv, float)
    jj, ii = np.meshgrid(np.arange(w), np.arange(h))
    for f in mouth_opening_faces(head):
        tri = uv[np.asarray(head.faces)[f]] * (w, h)  # texel units (x = u·W, y = v·H)
        lo = np.maximum(np.floor(tri.min(axis=0)).astype(int) - 1, 0)
        hi = np.minimum(np.ceil(tri.max(axis=0)).astype(int) + 2, (w, h))
        sub_j, sub_i = jj[lo[1]:hi[1], lo[0]:hi[0]], ii[lo[1]:hi[1], lo[0]:hi[0]]
        # a texel belongs if any of its centre and corners is inside (conservative, as the atlas's coverage)
        hit = np.zeros(sub_j.shape, bool)
        path = MplPath(tri)
        for dx, dy in ((0.5, 0.5), (0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)):
            pts = np.stack([sub_j.ravel() + dx, sub_i.ravel() + dy], axis=1)
            hit |= path.contains_points(pts).reshape(sub_j.shape)
        out[lo[1]:hi[1], lo[0]:hi[0]] |= hit
    return out


def is_face_mesh(head: Head) -> bool:
    """Whether ``head`` has MediaPipe's face-mesh topology (468 or 478 vertices in landmark order)."""
    return len(head.vertices) in FACE_MESH_SIZES


def derive_regions(head: Head, atlas: Atlas, head_uv: bool = True) -> RegionSet:
    """Every region of ``head`` on ``atlas`` (see the module docstring); the others in ``missing``.

    Args:
        head: the head (its landmarks, and for a face mesh its vertices).
        atlas: the bake of its paint layout at :data:`painting.regions.REGION_RESOLUTION` or a multiple
            of it (then the masks are averaged down to it: supersampled, smoother outlines).
        head_uv: the layout is the head's own UVs (the albedo and skin mask can be read per texel);
            False for an unwrapped layout (no albedo refinement, no skin mask).
    """
    out = RegionSet(head_name=head.name, mesh=mesh_digest(head.vertices, head.faces, head.uv))
    if not head_uv:
        from dataclasses import replace

        head = replace(head, albedo=None, skin_mask=None)
    missing_lm = [k for k in LANDMARKS_NEEDED if k not in head.metadata.landmarks]
    if missing_lm and not is_face_mesh(head):
        why = f"the head's sidecar lacks landmark(s) {', '.join(missing_lm)} and it is not a face mesh"
        out.missing = dict.fromkeys(REGION_NAMES, why)
        return out
    frame = FaceFrame(head)
    skin = atlas.coverage.copy() if head.skin_mask is None else _skin_mask(head, atlas)
    from scipy.ndimage import binary_fill_holes

    # regions stay on the skin and what it surrounds (the lips, brows and lids are holes in a skin mask)
    tex = _Texels(atlas, frame, np.asarray(binary_fill_holes(skin), bool) & atlas.coverage)
    shapes: dict[str, tuple[np.ndarray, str]] = {}
    if not missing_lm:
        shapes.update(_landmark_shapes(head, frame, tex))
    if is_face_mesh(head):
        shapes.update(_contour_shapes(head, frame, tex))
    texel_mm = local_texel_mm(atlas)
    excluded = [name for name in ("lips", "eyes", "brows", "inner_mouth") if name in shapes]
    shapes["skin"] = (skin, ("the head's skin mask" if head.skin_mask is not None else "every covered texel")
                      + " × (1 − each of the lips, eyes, brows and the inner mouth as soft masks)")
    if "lips" in shapes:
        shapes["lip_line"] = (_outline_band(shapes["lips"][0], 0.75, texel_mm), "a 1.5 mm band on the lips' outline")
    soft: dict[str, np.ndarray] = {}
    for name in REGION_NAMES:  # "skin" last: it needs the others' soft masks
        if name not in shapes or not shapes[name][0].any():
            out.missing[name] = f"no texels matched its shape on this head ({shapes[name][1]})" if name in shapes \
                else "needs the sidecar's landmarks"
            continue
        hard, source = shapes[name]
        f = DEFAULT_FEATHER_MM[name]
        mask = feather(hard, f, texel_mm)
        if name == "skin":  # the excluded regions cut out with their own (narrow) feathers
            for other in excluded:
                mask *= 1.0 - soft[other]
        soft[name] = mask
        mask = spread_to_padding(mask, atlas)
        k = atlas.resolution // REGION_RESOLUTION
        if k > 1:  # supersampled: the block means give the outline sub-texel (smooth) edges
            mask = block_mean(mask, k)
        mask.flags.writeable = False
        out.regions[name] = Region(name, mask, f, source)
    return out


def block_mean(mask: np.ndarray, k: int) -> np.ndarray:
    """The means of ``mask``'s ``k × k`` blocks, float32 (side / ``k``)²; ``mask``: float32 (n·k, n·k) in [0, 1].

    Summed in float64 one block offset at a time (each a strided view: numpy's ``mean`` over the two
    block axes of a reshaped array is about 5× slower), then divided by ``k²``: the same float32 values
    as ``mask.reshape(n, k, n, k).mean(axis=(1, 3), dtype=np.float64)``.
    """
    n = mask.shape[0] // k
    blocks = mask.reshape(n, k, n, k)
    total = blocks[:, 0, :, 0].astype(np.float64)
    for i in range(k):
        for j in range(k):
            if i or j:
                total += blocks[:, i, :, j]
    return (total / (k * k)).astype(np.float32)


def _outline_band(inside: np.ndarray, half_mm: float, texel_mm: np.ndarray) -> np.ndarray:
    """The texels within ``half_mm`` (surface distance through ``texel_mm``) of the outline of ``inside``."""
    if not inside.any():  # no outline: the distances of an all-outside array, as scipy gives them
        from scipy.ndimage import distance_transform_edt

        signed = np.where(inside, distance_transform_edt(inside) - 0.5, 0.5 - distance_transform_edt(~inside))
        return np.asarray(np.abs(signed * texel_mm) <= half_mm)
    win, signed_texels = signed_distance(inside, reach_texels(half_mm, texel_mm))
    band = np.zeros(inside.shape, bool)
    band[win] = np.abs(signed_texels * texel_mm[win]) <= half_mm
    return band


def _skin_mask(head: Head, atlas: Atlas) -> np.ndarray:
    """The head's skin mask (its own UVs) sampled at the atlas's texel centres, and the coverage."""
    assert head.skin_mask is not None
    h, w = head.skin_mask.shape
    res = atlas.resolution
    rows = np.minimum(((np.arange(res) + 0.5) / res * h).astype(np.int64), h - 1)
    cols = np.minimum(((np.arange(res) + 0.5) / res * w).astype(np.int64), w - 1)
    return head.skin_mask[rows][:, cols] & atlas.coverage


def shipped_regions_file(digest: str) -> Path | None:
    """The region file in ``resources/heads`` recording the mesh ``digest`` (:func:`mesh_digest`), or None."""
    from core.assets import resource_path

    for path in sorted(resource_path("heads").glob("*.regions.png")):
        if stored_mesh(path) == digest:
            return path
    return None


def regions_for(head: Head, atlas: Atlas | None = None, head_uv: bool = True) -> RegionSet:
    """The regions of ``head`` (see the module docstring for where they come from).

    Args:
        head: the head.
        atlas: the bake of the head's paint layout at :data:`REGION_RESOLUTION`; needed to derive regions
            (not to read stored ones).
        head_uv: the layout is the head's own UVs (see :func:`painting.region_shapes.derive_regions`).

    Returns:
        The regions; those that could not be derived are named in ``missing``.
    """
    from core.files import read_bounded
    from painting.head import MAX_HEAD_FILE_BYTES, find_sidecar

    if head.path.parent.name != "<embedded>":
        sidecar = find_sidecar(head.path)
        stored = None if sidecar is None else regions_file(sidecar)
    else:  # embedded in a project: the shipped region file of this very mesh, if there is one
        stored = shipped_regions_file(mesh_digest(head.vertices, head.faces, head.uv))
    if stored is not None and stored.is_file():
        blob = read_bounded(stored, MAX_HEAD_FILE_BYTES, "region masks", RegionError)
        return decode_regions(blob, str(stored), head.name)
    if atlas is None:
        return RegionSet(head_name=head.name, missing=dict.fromkeys(REGION_NAMES, "no atlas to derive them on"))
    return derive_regions(head, atlas, head_uv=head_uv)
