"""A uniform 3D grid over the covered texels' positions, so a dab visits only texels near it.

Hand-written rather than ``scipy.spatial.cKDTree.query_ball_point``: the grid is built with one sort
(no tree), and a box query returns contiguous runs of a cell-sorted array (one run per grid row), so a
dab costs a few array slices plus work proportional to the texels in its box, independent of the map
size. (cKDTree is used for the smoothing neighbourhoods, where pairs are needed.)

Units: mesh units throughout.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from painting.tiles import tile_of

if TYPE_CHECKING:
    from pathlib import Path

#: Grid cell edge in millimetres (brush radii are a few mm to a few cm).
CELL_MM = 2.5


@dataclass
class TexelIndex:
    """Covered texels sorted by grid cell.

    Attributes:
        origin: float64 (3,) grid origin (mesh units). cell: cell edge (mesh units).
        dims: (nx, ny, nz) cells.
        cell_start: int64 (nx·ny·nz + 1,) first sorted texel of each cell (x fastest).
        pn: float32 (N, 6) cell-sorted texel positions and unit normals, one row per texel (a dab
            reads a texel's six values from one place: about a third faster from cold memory than six
            separate arrays). x, y, z, nx, ny, nz: its columns (views, for numpy).
        flat: int64 (N,) flat texel index (row·W + column) of each sorted texel.
        tile: int32 (N,) its 64² tile (tile row · tiles per row + tile column).
        has_pad: bool (N,) whether it feeds padding texels.
    """

    origin: np.ndarray
    cell: float
    dims: tuple[int, int, int]
    cell_start: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    nx: np.ndarray
    ny: np.ndarray
    nz: np.ndarray
    flat: np.ndarray
    tile: np.ndarray
    has_pad: np.ndarray
    pn: np.ndarray

    @classmethod
    def build(cls, atlas: Any, cell_mm: float = CELL_MM) -> TexelIndex:
        """Index the covered texels of an :class:`painting.atlas.Atlas`."""
        flat = np.flatnonzero(atlas.coverage.reshape(-1))
        pos = atlas.position.reshape(-1, 3)[flat]
        nrm = atlas.normal.reshape(-1, 3)[flat]
        cell = float(cell_mm) / float(atlas.mm_per_unit)
        if len(flat) == 0:
            origin = np.zeros(3)
            dims = (1, 1, 1)
        else:
            origin = pos.min(axis=0).astype(np.float64) - cell
            dims_arr = np.maximum(np.ceil((pos.max(axis=0) - origin) / cell).astype(np.int64) + 2, 1)
            # Keep the dense cell table bounded (coarser cells for huge, finely scaled meshes).
            while int(np.prod(dims_arr)) > 8_000_000:
                cell *= 2.0
                dims_arr = np.maximum(np.ceil((pos.max(axis=0) - origin) / cell).astype(np.int64) + 2, 1)
            dims = (int(dims_arr[0]), int(dims_arr[1]), int(dims_arr[2]))
        ijk = np.floor((pos - origin) / cell).astype(np.int64)
        keys = ijk[:, 0] + dims[0] * (ijk[:, 1] + dims[1] * ijk[:, 2])
        order = np.argsort(keys, kind="stable")
        keys = keys[order]
        ncell = dims[0] * dims[1] * dims[2]
        cell_start = np.searchsorted(keys, np.arange(ncell + 1, dtype=np.int64)).astype(np.int64)
        pn = np.empty((len(order), 6), dtype=np.float32)
        pn[:, :3] = pos[order]
        pn[:, 3:] = nrm[order]
        cols = [pn[:, k] for k in range(6)]
        flat = flat[order].astype(np.int64)
        res = int(atlas.resolution)
        tile = tile_of(flat, res).astype(np.int32)
        has_pad = np.zeros(res * res, dtype=bool)
        has_pad[atlas.pad_src] = True
        return cls(origin=origin, cell=cell, dims=dims, cell_start=cell_start, x=cols[0], y=cols[1],
                   z=cols[2], nx=cols[3], ny=cols[4], nz=cols[5], flat=flat, tile=tile, has_pad=has_pad[flat], pn=pn)

    def __len__(self) -> int:
        return len(self.flat)

    #: arrays written by :meth:`save` (``meta``: origin x, y, z, cell, dims x, y, z)
    _SAVED = ("cell_start", "pn", "flat", "tile", "has_pad")

    def save(self, path: Path, version: int | str = 0) -> bool:
        """Write the index to the cache entry ``path`` (:func:`core.cache.save_arrays`); whether it was kept.

        Failing to write is not an error: the index is a cache (it takes about 2 s to build at 2048²,
        0.1 s to read).
        """
        from core.cache import save_arrays

        meta = np.array([*self.origin, self.cell, *self.dims], dtype=np.float64)
        return save_arrays(path, {"meta": meta, **{name: getattr(self, name) for name in self._SAVED}}, version)

    @classmethod
    def load(cls, path: Path, count: int, version: int | str = 0) -> TexelIndex | None:
        """An index written by :meth:`save`, or None if ``path`` is missing, damaged or inconsistent.

        ``count``: the number of covered texels it must hold.
        """
        from core.cache import load_arrays

        arrays = load_arrays(path, version)
        if arrays is None or any(k not in arrays for k in ("meta", *cls._SAVED)):
            return None
        meta = arrays.pop("meta")
        if meta.shape != (7,) or not np.all(np.isfinite(meta)):
            return None
        dims = tuple(int(v) for v in meta[4:])
        pn, cs = arrays["pn"], arrays["cell_start"]
        if (pn.shape != (count, 6) or pn.dtype != np.float32 or arrays["flat"].shape != (count,)
                or arrays["tile"].shape != (count,) or arrays["has_pad"].shape != (count,)
                or cs.shape != (dims[0] * dims[1] * dims[2] + 1,) or int(cs[-1]) != count or meta[3] <= 0):
            return None
        cols = [pn[:, k] for k in range(6)]
        return cls(origin=meta[:3].copy(), cell=float(meta[3]), dims=(dims[0], dims[1], dims[2]), cell_start=cs,
                   x=cols[0], y=cols[1], z=cols[2], nx=cols[3], ny=cols[4], nz=cols[5], flat=arrays["flat"],
                   tile=arrays["tile"], has_pad=arrays["has_pad"], pn=pn)

    @property
    def dims_array(self) -> np.ndarray:
        """int64 (3,) :attr:`dims`, for the compiled kernels."""
        arr = self.__dict__.get("_dims_array")
        if arr is None:
            arr = np.array(self.dims, dtype=np.int64)
            self.__dict__["_dims_array"] = arr
        return arr

    def point(self, k: int) -> np.ndarray:
        """Position (float64 (3,), mesh units) of sorted texel ``k``."""
        return np.array([self.x[k], self.y[k], self.z[k]], dtype=np.float64)

    def normal(self, k: int) -> np.ndarray:
        """Unit normal (float64 (3,)) of sorted texel ``k``."""
        return np.array([self.nx[k], self.ny[k], self.nz[k]], dtype=np.float64)

    def distance2(self, idx: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Squared distances (float32) from sorted texels ``idx`` to point ``p``."""
        dx = self.x[idx] - np.float32(p[0])
        dy = self.y[idx] - np.float32(p[1])
        dz = self.z[idx] - np.float32(p[2])
        return dx * dx + dy * dy + dz * dz

    def query_box(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Sorted-texel indices of every texel in the cells overlapping the box [lo, hi] (mesh units).

        A superset of the texels inside the box.
        """
        nx, ny, nz = self.dims
        a = np.floor((np.asarray(lo, dtype=np.float64) - self.origin) / self.cell).astype(np.int64)
        b = np.floor((np.asarray(hi, dtype=np.float64) - self.origin) / self.cell).astype(np.int64)
        a = np.maximum(a, 0)
        b = np.minimum(b, np.array([nx - 1, ny - 1, nz - 1]))
        if np.any(b < a):
            return np.zeros(0, dtype=np.int64)
        iy, iz = np.meshgrid(np.arange(a[1], b[1] + 1), np.arange(a[2], b[2] + 1), indexing="ij")
        row = nx * (iy.ravel() + ny * iz.ravel())
        starts = self.cell_start[row + a[0]]
        ends = self.cell_start[row + b[0] + 1]
        n = ends - starts
        total = int(n.sum())
        if total == 0:
            return np.zeros(0, dtype=np.int64)
        # Concatenate the runs [starts[k], ends[k]) without a Python loop.
        offs = np.repeat(starts - (np.cumsum(n) - n), n)
        return np.arange(total, dtype=np.int64) + offs

    def query_sphere(self, centre: np.ndarray, radius: float) -> np.ndarray:
        """Sorted-texel indices of the texels in grid cells that intersect the sphere (mesh units).

        A superset of the texels inside it: per grid row only the x-run under the sphere's chord is
        taken, so the candidates are about the sphere's, not its bounding box's.
        """
        nx, ny, nz = self.dims
        c = np.asarray(centre, dtype=np.float64)
        lo = np.floor((c - radius - self.origin) / self.cell).astype(np.int64)
        hi = np.floor((c + radius - self.origin) / self.cell).astype(np.int64)
        lo = np.maximum(lo, 0)
        hi = np.minimum(hi, np.array([nx - 1, ny - 1, nz - 1]))
        if np.any(hi < lo):
            return np.zeros(0, dtype=np.int64)
        jy = np.arange(lo[1], hi[1] + 1)
        jz = np.arange(lo[2], hi[2] + 1)
        y0 = self.origin[1] + jy * self.cell
        z0 = self.origin[2] + jz * self.cell
        dy = np.maximum(np.maximum(y0 - c[1], c[1] - (y0 + self.cell)), 0.0)
        dz = np.maximum(np.maximum(z0 - c[2], c[2] - (z0 + self.cell)), 0.0)
        rem = radius * radius - (dy[:, None] ** 2 + dz[None, :] ** 2)
        iy, iz = np.nonzero(rem >= 0)
        if len(iy) == 0:
            return np.zeros(0, dtype=np.int64)
        half = np.sqrt(rem[iy, iz])
        ix0 = np.maximum(np.floor((c[0] - half - self.origin[0]) / self.cell).astype(np.int64), 0)
        ix1 = np.minimum(np.floor((c[0] + half - self.origin[0]) / self.cell).astype(np.int64), nx - 1)
        row = nx * (jy[iy] + ny * jz[iz])
        return self._runs(self.cell_start[row + ix0], self.cell_start[row + ix1 + 1])

    def _runs(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        n = np.maximum(ends - starts, 0)
        total = int(n.sum())
        if total == 0:
            return np.zeros(0, dtype=np.int64)
        offs = np.repeat(starts - (np.cumsum(n) - n), n)
        return np.arange(total, dtype=np.int64) + offs

    def nearest(self, point: np.ndarray, max_distance: float) -> tuple[int, float]:
        """Sorted index and distance of the texel nearest to ``point`` within ``max_distance``, or (-1, inf).

        Mesh units. Uses the compiled kernel when enabled (same result as :meth:`nearest_reference`).
        """
        from painting import kernels

        if kernels.active():
            k, d = kernels.nearest(self.pn, self.origin, float(self.cell), self.dims_array,
                                   self.cell_start, np.asarray(point, dtype=np.float64).reshape(3),
                                   float(max_distance))
            return int(k), float(d)
        return self.nearest_reference(point, max_distance)

    def nearest_reference(self, point: np.ndarray, max_distance: float) -> tuple[int, float]:
        """:meth:`nearest` in numpy (the reference)."""
        p = np.asarray(point, dtype=np.float64)
        idx = self.query_sphere(p, max_distance)
        if len(idx) == 0:
            return -1, float("inf")
        d2 = self.distance2(idx, p)
        k = int(np.argmin(d2))
        d = float(np.sqrt(d2[k]))
        if d > max_distance:
            return -1, float("inf")
        return int(idx[k]), d
