"""G-buffers for the capture numerics, on :mod:`painting.raster`'s CPU triangle rasteriser.

Capture must run without a GL context (batch fitting, tests of the numerics, machines with no EGL), and
what it needs is only a G-buffer — which triangle covers each pixel and the barycentric coordinates
there — for a ~20k-triangle head at photo resolution or in UV space. The rasterisation itself (edge
functions, z-buffer, batching) is :func:`painting.raster.rasterize`; this module adapts it:

- **perspective-correct barycentrics** for a camera view: painting's are affine in screen space (right
  in texture space); here they are divided by each corner's clip-space w (the camera-space depth) and
  renormalised;
- triangles behind the camera (a corner with w ≤ 0) or with a non-finite corner are left out, and the
  triangle indices mapped back to the mesh's;
- the depth that won the z-test is returned per pixel.

Conventions (painting's): pixel (row i, column j) has its centre at x = j + 0.5, y = i + 0.5 (x right,
y down, top row first); texture space x = u·W, y = v·H.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from painting.raster import rasterize as _rasterize


@dataclass
class GBuffer:
    """What covers each pixel.

    Attributes:
        tri: int32 (H, W), the triangle index, -1 where nothing is drawn.
        bary: float32 (H, W, 3), barycentric coordinates (perspective-correct for a camera view; 0 where
            ``tri`` is -1).
        depth: float32 (H, W), the depth value that won the z-test (``inf`` where empty).
    """

    tri: np.ndarray
    bary: np.ndarray
    depth: np.ndarray

    @property
    def covered(self) -> np.ndarray:
        """Bool (H, W): pixels covered by a triangle."""
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
              w: np.ndarray | None = None) -> GBuffer:
    """Rasterise triangles given by 2D vertex positions (through :func:`painting.raster.rasterize`).

    Args:
        xy: float (N, 2) vertex positions in pixels (x right, y down; pixel centres at +0.5).
        depth: float (N,) per-vertex depth, smaller = nearer (linearly interpolated in screen space,
            which is exact for NDC-like depth after the perspective divide, e.g. −1/z).
        faces: int (F, 3) vertex indices.
        width: the image's width in pixels.
        height: the image's height in pixels.
        w: optional float (N,) clip-space w (the camera-space depth, > 0 in front of the camera) for
            perspective-correct barycentrics; None for affine ones (orthographic, UV space).

    Returns:
        A :class:`GBuffer` whose triangle indices refer to ``faces``.
    """
    xy = np.asarray(xy, dtype=np.float64)
    depth = np.asarray(depth, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    keep = np.all(np.isfinite(xy[faces]), axis=(1, 2)) & np.all(np.isfinite(depth[faces]), axis=1)
    if w is not None:
        w = np.asarray(w, dtype=np.float64)
        keep &= np.all(w[faces] > 1e-9, axis=1)
    idx = np.nonzero(keep)[0]
    f = faces[idx]
    tri_local, bary = _rasterize(xy[f], width, height, depth=depth[f])
    cov = tri_local >= 0
    tri = np.full((height, width), -1, dtype=np.int32)
    tri[cov] = idx[tri_local[cov]]
    corners = f[tri_local[cov]]  # (P, 3)
    b = bary[cov]
    zbuf = np.full((height, width), np.inf, dtype=np.float32)
    zbuf[cov] = np.einsum("pk,pk->p", b, depth[corners])
    if w is not None:
        b = b / w[corners]
        b /= b.sum(axis=1, keepdims=True)
    bary_out = np.zeros((height, width, 3), dtype=np.float32)
    bary_out[cov] = b
    return GBuffer(tri=tri, bary=bary_out, depth=zbuf)


def rasterize_uv(uv: np.ndarray, faces: np.ndarray, size: tuple[int, int]) -> GBuffer:
    """Rasterise the mesh in UV space; ``size`` is (height, width) in texels.

    Texture-space conventions of :mod:`painting.head`: texel row ``i`` covers ``v ∈ [i/H, (i+1)/H)``, top
    row first. Where UV islands overlap, painting's rule decides (the last triangle drawn wins).
    """
    h, w = size
    xy = np.stack([uv[:, 0] * w, uv[:, 1] * h], axis=1)
    f = np.asarray(faces, dtype=np.int64)
    tri_local, bary = _rasterize(xy[f], w, h)
    return GBuffer(tri=tri_local.astype(np.int32), bary=bary.astype(np.float32),
                   depth=np.where(tri_local >= 0, 0.0, np.inf).astype(np.float32))
