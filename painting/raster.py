"""Vectorised triangle rasterisation in numpy (used by the atlas bake and by headless previews).

Hand-written because neither trimesh, xatlas nor scipy rasterise triangles into a texel grid with
per-texel triangle ids and barycentrics (xatlas only packs charts). The work is done per bucket of
triangles with bounding boxes of equal size, so every step is one numpy operation over many triangles.

Pixel convention: pixel ``(row i, column j)`` has its centre at ``(x, y) = (j + 0.5, i + 0.5)`` in
pixel units; for texture space ``x = u·W`` and ``y = v·H`` (rows top first, see :mod:`painting.head`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Iterator

#: Candidate texels handled per numpy batch (bounds the peak memory of a bake to a few hundred MB).
_BATCH = 1_000_000


def _edge_coeffs(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Edge functions ``e_k(x, y) = a_k·x + b_k·y + c_k`` (positive inside) for (n, 3, 2) triangles.

    Returns (a, b, c, signed doubled area); edge ``k`` is opposite vertex ``k``.
    """
    p0, p1, p2 = tri[:, 0], tri[:, 1], tri[:, 2]
    area2 = (p1[:, 0] - p0[:, 0]) * (p2[:, 1] - p0[:, 1]) - (p2[:, 0] - p0[:, 0]) * (p1[:, 1] - p0[:, 1])
    sign = np.where(area2 < 0, -1.0, 1.0)
    starts = np.stack([p1, p2, p0], axis=1)  # edge k runs from vertex k+1 to k+2
    ends = np.stack([p2, p0, p1], axis=1)
    a = (starts[..., 1] - ends[..., 1]) * sign[:, None]
    b = (ends[..., 0] - starts[..., 0]) * sign[:, None]
    c = (starts[..., 0] * ends[..., 1] - starts[..., 1] * ends[..., 0]) * sign[:, None]
    return a, b, c, area2


def iter_candidates(tri: np.ndarray, width: int, height: int, pad: float = 0.0
                    ) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Yield (triangle index, row, column) arrays of the pixels near each triangle, batched to bound memory.

    A pixel is a candidate when its centre lies in the triangle's bounding box grown by ``pad`` pixels,
    clipped to the image.
    """
    lo = np.ceil(tri.min(axis=1) - pad - 0.5).astype(np.int64)  # first centre >= min - pad
    hi = np.floor(tri.max(axis=1) + pad - 0.5).astype(np.int64)  # last centre <= max + pad
    lo = np.maximum(lo, 0)
    hi[:, 0] = np.minimum(hi[:, 0], width - 1)
    hi[:, 1] = np.minimum(hi[:, 1], height - 1)
    nx = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0)
    ny = np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
    count = nx * ny
    order = np.nonzero(count)[0]
    if len(order) == 0:
        return
    cum = np.cumsum(count[order])
    start = 0
    while start < len(order):
        base = cum[start - 1] if start else 0
        stop = int(np.searchsorted(cum, base + _BATCH, side="right"))
        stop = max(stop, start + 1)
        ids = order[start:stop]
        cnt = count[ids]
        tri_idx = np.repeat(ids, cnt)
        offsets = np.arange(int(cnt.sum()), dtype=np.int64) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        nxr = np.repeat(nx[ids], cnt)
        cols = lo[tri_idx, 0] + offsets % nxr
        rows = lo[tri_idx, 1] + offsets // nxr
        yield tri_idx, rows, cols
        start = stop


def barycentric(tri: np.ndarray, tri_idx: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (n, 3) of points (x, y) in triangles ``tri[tri_idx]``.

    NaN for degenerate triangles.
    """
    t = tri[tri_idx]
    p0, p1, p2 = t[:, 0], t[:, 1], t[:, 2]
    d = (p1[:, 0] - p0[:, 0]) * (p2[:, 1] - p0[:, 1]) - (p2[:, 0] - p0[:, 0]) * (p1[:, 1] - p0[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = ((x - p0[:, 0]) * (p2[:, 1] - p0[:, 1]) - (p2[:, 0] - p0[:, 0]) * (y - p0[:, 1])) / d
        l2 = ((p1[:, 0] - p0[:, 0]) * (y - p0[:, 1]) - (x - p0[:, 0]) * (p1[:, 1] - p0[:, 1])) / d
    return np.stack([1.0 - l1 - l2, l1, l2], axis=1)


def rasterize(tri: np.ndarray, width: int, height: int, depth: np.ndarray | None = None,
              conservative: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Rasterise 2D triangles into a ``height × width`` grid.

    Args:
        tri: float64 (F, 3, 2) vertex positions in pixel units (x right, y down).
        width: grid width in pixels.
        height: grid height in pixels.
        depth: optional float (F, 3) per-vertex depth; where triangles overlap the one with the
            *smallest* interpolated depth wins (a z-buffer). Without it, the triangle whose
            centroid is nearest to the pixel centre wins (stable for chart borders).
        conservative: cover every pixel whose square overlaps a triangle (exact separating-axis
            test: the three edges moved outwards by half a pixel in L1, clipped to the bounding box),
            not only pixels whose centre is inside.

    Returns:
        (face, bary): int32 (H, W) triangle index or -1, float64 (H, W, 3) barycentrics of the
        pixel centre (for pixels covered only conservatively, of the nearest point of the triangle,
        so interpolated values stay on the triangle).
    """
    tri = np.asarray(tri, dtype=np.float64)
    face = np.full(height * width, -1, dtype=np.int32)
    best = np.full(height * width, np.inf)
    bary_out = np.zeros((height * width, 3))
    a, b, c, area2 = _edge_coeffs(tri)
    ac = [np.ascontiguousarray(a[:, k]) for k in range(3)]
    bc_ = [np.ascontiguousarray(b[:, k]) for k in range(3)]
    cc = [np.ascontiguousarray(c[:, k]) for k in range(3)]
    valid = np.abs(area2) > 1e-12
    centroid = tri.mean(axis=1)
    pad = 0.5 if conservative else 0.0
    border: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
    for tri_idx, rows, cols in iter_candidates(tri, width, height, pad=pad):
        keep = valid[tri_idx]
        if not keep.all():
            tri_idx, rows, cols = tri_idx[keep], rows[keep], cols[keep]
        x = cols + 0.5
        y = rows + 0.5
        # One 1D array per edge: numpy is far slower on (n, 3) arrays (inner loops of length 3).
        e = []
        loose = None
        strict = None
        for k in range(3):
            ak, bk = ac[k][tri_idx], bc_[k][tri_idx]
            ek = ak * x
            ek += bk * y
            ek += cc[k][tri_idx]
            e.append(ek)
            inside_k = ek >= 0
            strict = inside_k if strict is None else strict & inside_k
            if conservative:
                lk = ek + 0.5 * (np.abs(ak) + np.abs(bk)) >= 0
                loose = lk if loose is None else loose & lk
        assert strict is not None
        if conservative and loose is not None:
            loose &= ~strict
            if loose.any():
                border.append((tri_idx[loose], rows[loose], cols[loose], np.zeros(0)))
        tri_idx, rows, cols = tri_idx[strict], rows[strict], cols[strict]
        # The edge function of edge k is twice the area of the sub-triangle opposite vertex k.
        inv = 1.0 / np.abs(area2[tri_idx])
        bc = np.stack([e[0][strict] * inv, e[1][strict] * inv, e[2][strict] * inv], axis=1)
        flat = rows * width + cols
        if depth is not None:
            key = np.einsum("ij,ij->i", bc, depth[tri_idx])
            f_sel, sel = _keep_nearest(flat, key, best)
        else:
            # Texel centres inside two triangles only happen where UVs overlap: the last one wins.
            sel = np.arange(len(flat))
            f_sel = flat
        face[f_sel] = tri_idx[sel]
        bary_out[f_sel] = bc[sel]
    # Conservative-only texels (centre outside every triangle): the nearest point of an overlapping
    # triangle; the triangle whose centroid is nearest wins.
    for tri_idx, rows, cols, _ in border:
        flat = rows * width + cols
        free = face[flat] < 0
        tri_idx, rows, cols, flat = tri_idx[free], rows[free], cols[free], flat[free]
        if len(flat) == 0:
            continue
        x = cols + 0.5
        y = rows + 0.5
        cen = centroid[tri_idx]
        key = np.hypot(cen[:, 0] - x, cen[:, 1] - y)
        f_sel, sel = _keep_nearest(flat, key, best)
        face[f_sel] = tri_idx[sel]
        bary_out[f_sel] = _clamp_to_triangle(tri, tri_idx[sel], x[sel], y[sel])
    return face.reshape(height, width), bary_out.reshape(height, width, 3)


def _keep_nearest(flat: np.ndarray, key: np.ndarray, best: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Of the candidates (texel ``flat[i]``, ordering ``key[i]``), the one with the smallest key per texel.

    Kept only where it beats ``best`` (updated in place). Returns (texels, candidate indices).
    """
    order = np.lexsort((key, flat))
    flat_s = flat[order]
    first = np.ones(len(flat_s), dtype=bool)
    first[1:] = flat_s[1:] != flat_s[:-1]
    sel = order[first]
    f_sel = flat[sel]
    better = key[sel] < best[f_sel]
    f_sel, sel = f_sel[better], sel[better]
    best[f_sel] = key[sel]
    return f_sel, sel


def _clamp_to_triangle(tri: np.ndarray, tri_idx: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Barycentrics of the point of each triangle nearest to (x, y) (2D closest point, vectorised)."""
    t = tri[tri_idx]
    p = np.stack([x, y], axis=1)
    best_d = np.full(len(x), np.inf)
    best_b = np.zeros((len(x), 3))
    bc = barycentric(tri, tri_idx, x, y)
    inside = np.all(bc >= 0, axis=1)
    best_d[inside] = 0.0
    best_b[inside] = bc[inside]
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        s0, s1 = t[:, i], t[:, j]
        d = s1 - s0
        ll = np.einsum("ij,ij->i", d, d)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.clip(np.einsum("ij,ij->i", p - s0, d) / ll, 0.0, 1.0)
        s = np.where(np.isfinite(s), s, 0.0)
        q = s0 + s[:, None] * d
        dist = np.hypot(*(q - p).T)
        better = dist < best_d
        best_d = np.where(better, dist, best_d)
        nb = np.zeros((len(x), 3))
        nb[np.arange(len(x)), i] = 1.0 - s
        nb[np.arange(len(x)), j] = s
        best_b[better] = nb[better]
    return best_b
