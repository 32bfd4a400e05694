"""A small z-buffered triangle rasteriser on the CPU (numpy), for the capture numerics.

Why hand-written: capture must run without a GL context (batch fitting, tests of the numerics, machines
with no EGL), and what it needs is only a G-buffer — which triangle covers each pixel and the
barycentric coordinates there — for a ~20k-triangle head at photo resolution or in UV space. trimesh's
ray casting without embree is orders of magnitude slower, and VTK/pyvista rendering needs GL. The
rasteriser below is fully vectorised: triangles are grouped by bounding-box size, every candidate pixel
of a group is tested at once, and the nearest candidate per pixel wins.

Conventions: pixel (row i, column j) has its centre at x = j + 0.5, y = i + 0.5 in the 2D coordinates
given to :func:`rasterize` (x right, y down, image top row first).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class GBuffer:
    """What covers each pixel.

    Attributes:
        tri: int32 (H, W), the triangle index, -1 where nothing is drawn.
        bary: float32 (H, W, 3), perspective-correct barycentric coordinates (0 where ``tri`` is -1).
        depth: float32 (H, W), the depth value that won the z-test (``inf`` where empty).
    """

    tri: np.ndarray
    bary: np.ndarray
    depth: np.ndarray

    @property
    def covered(self) -> np.ndarray:
        """bool (H, W): pixels covered by a triangle."""
        return self.tri >= 0

    def interpolate(self, faces: np.ndarray, attribute: np.ndarray) -> np.ndarray:
        """Interpolate a per-vertex attribute (N, C) to the covered pixels: (H, W, C), zero elsewhere."""
        h, w = self.tri.shape
        out = np.zeros((h, w, attribute.shape[1]), dtype=np.float64)
        m = self.covered
        corners = faces[self.tri[m]]  # (P, 3)
        b = self.bary[m].astype(np.float64)
        out[m] = np.einsum("pk,pkc->pc", b, attribute[corners])
        return out


def rasterize(xy: np.ndarray, depth: np.ndarray, faces: np.ndarray, width: int, height: int,
              w: np.ndarray | None = None, cull_back: bool = False, max_candidates: int = 4_000_000) -> GBuffer:
    """Rasterise triangles given by 2D vertex positions.

    Args:
        xy: float (N, 2) vertex positions in pixels (x right, y down; pixel centres at +0.5).
        depth: float (N,) per-vertex depth, smaller = nearer (linearly interpolated in screen space,
            which is exact for NDC depth after the perspective divide).
        faces: int (F, 3) vertex indices.
        width, height: the image size in pixels.
        w: optional float (N,) clip-space w (the camera-space depth) for perspective-correct barycentrics;
            None for affine (orthographic, UV space).
        cull_back: drop triangles with a negative signed area in these (x right, y down) coordinates.
        max_candidates: candidate pixels processed per batch (memory bound).

    Returns:
        A :class:`GBuffer`.
    """
    xy = np.asarray(xy, dtype=np.float64)
    depth = np.asarray(depth, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    p0, p1, p2 = xy[faces[:, 0]], xy[faces[:, 1]], xy[faces[:, 2]]
    area = (p1[:, 0] - p0[:, 0]) * (p2[:, 1] - p0[:, 1]) - (p1[:, 1] - p0[:, 1]) * (p2[:, 0] - p0[:, 0])
    keep = np.isfinite(area) & (np.abs(area) > 1e-12)
    if cull_back:
        keep &= area < 0
    tri_xy = np.stack([p0, p1, p2], axis=1)  # (F, 3, 2)
    lo = np.floor(tri_xy.min(axis=1) - 0.5).astype(np.int64) + 1  # first pixel whose centre may be inside
    hi = np.floor(tri_xy.max(axis=1) - 0.5).astype(np.int64)
    lo = np.maximum(lo, 0)
    hi[:, 0] = np.minimum(hi[:, 0], width - 1)
    hi[:, 1] = np.minimum(hi[:, 1], height - 1)
    keep &= np.all(hi >= lo, axis=1)
    if w is not None:
        keep &= np.all(np.asarray(w)[faces] > 1e-9, axis=1)
    idx = np.nonzero(keep)[0]
    size = hi[idx] - lo[idx] + 1  # (K, 2) bbox width, height
    # Group by the bounding box rounded up to a power of two, so each group is one dense batch.
    bw = 1 << np.ceil(np.log2(size[:, 0])).astype(np.int64)
    bh = 1 << np.ceil(np.log2(size[:, 1])).astype(np.int64)
    npix = width * height
    best_depth = np.full(npix, np.inf)
    best_tri = np.full(npix, -1, dtype=np.int64)
    best_bary = np.zeros((npix, 3))
    groups: dict[tuple[int, int], list[int]] = {}
    for key_w, key_h in set(zip(bw.tolist(), bh.tolist())):
        groups[(key_w, key_h)] = []
    keys = np.stack([bw, bh], axis=1)
    for (gw, gh) in groups:
        sel = idx[(keys[:, 0] == gw) & (keys[:, 1] == gh)]
        per = gw * gh
        step = max(1, max_candidates // per)
        oy, ox = np.mgrid[0:gh, 0:gw]
        ox = ox.ravel()
        oy = oy.ravel()
        for start in range(0, len(sel), step):
            t = sel[start:start + step]
            px = lo[t, 0][:, None] + ox[None, :]
            py = lo[t, 1][:, None] + oy[None, :]
            valid = (px <= hi[t, 0][:, None]) & (py <= hi[t, 1][:, None])
            cx = px + 0.5
            cy = py + 0.5
            a, b, c = tri_xy[t, 0], tri_xy[t, 1], tri_xy[t, 2]
            ar = area[t][:, None]
            # Edge functions (barycentric weights times the signed area).
            l0 = ((b[:, 0:1] - cx) * (c[:, 1:2] - cy) - (b[:, 1:2] - cy) * (c[:, 0:1] - cx)) / ar
            l1 = ((c[:, 0:1] - cx) * (a[:, 1:2] - cy) - (c[:, 1:2] - cy) * (a[:, 0:1] - cx)) / ar
            l2 = 1.0 - l0 - l1
            eps = -1e-7
            valid &= (l0 >= eps) & (l1 >= eps) & (l2 >= eps)
            if not valid.any():
                continue
            ti, pi = np.nonzero(valid)
            tt = t[ti]
            f = faces[tt]
            b0, b1, b2 = l0[ti, pi], l1[ti, pi], l2[ti, pi]
            z = b0 * depth[f[:, 0]] + b1 * depth[f[:, 1]] + b2 * depth[f[:, 2]]
            pix = py[ti, pi] * width + px[ti, pi]
            bary = np.stack([b0, b1, b2], axis=1)
            if w is not None:
                ww = np.asarray(w, dtype=np.float64)[f]
                bary = bary / ww
                bary /= bary.sum(axis=1, keepdims=True)
            # Nearest candidate per pixel within this batch, then merge with the running z-buffer.
            order = np.lexsort((z, pix))
            pix_s = pix[order]
            first = np.ones(len(order), dtype=bool)
            first[1:] = pix_s[1:] != pix_s[:-1]
            o = order[first]
            pp = pix[o]
            better = z[o] < best_depth[pp]
            pp = pp[better]
            o = o[better]
            best_depth[pp] = z[o]
            best_tri[pp] = tt[o]
            best_bary[pp] = bary[o]
    return GBuffer(
        tri=best_tri.reshape(height, width).astype(np.int32),
        bary=best_bary.reshape(height, width, 3).astype(np.float32),
        depth=best_depth.reshape(height, width).astype(np.float32),
    )


def rasterize_uv(uv: np.ndarray, faces: np.ndarray, size: tuple[int, int]) -> GBuffer:
    """Rasterise the mesh in UV space (texture-space conventions of :mod:`painting.head`: texel row ``i``
    covers ``v ∈ [i/H, (i+1)/H)``, top row first). ``size`` is (height, width) in texels."""
    h, w = size
    xy = np.stack([uv[:, 0] * w, uv[:, 1] * h], axis=1)
    return rasterize(xy, np.zeros(len(uv)), faces, w, h)
