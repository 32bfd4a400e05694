"""The stroke engine: the dabs of one stroke on one layer, from a surface point to the texels it paints.

A :class:`Stroke` (from :meth:`painting.document.Document.stroke`) turns each dab into capsules along the
surface, finds the texels within the brush radius that face the brush, weights them by the falloff and
composites them into the layer map (or smooths, or fills a chart), saving each 64² tile it touches once
for undo. Each dab takes one of two paths, bit-identical in maps, events and undo records:
:meth:`Stroke._paint_compiled` (the numba kernels of :mod:`painting.kernels`, once loaded) or
:meth:`Stroke._paint_numpy` (the numpy reference).

Units: points in mesh units, brush radii in mm (through the document's ``mm_per_unit``), thickness in µm.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Protocol

import numpy as np

from painting import kernels
from painting.history import Step, TileDelta
from painting.layer import ChangeEvent, DocumentError, as_vec3
from painting.tiles import TILE, tile_of

if TYPE_CHECKING:
    from types import TracebackType

    from numpy.typing import ArrayLike

    from painting.atlas import Atlas
    from painting.brush import Brush
    from painting.layer import Layer
    from painting.spatial import TexelIndex

#: A dab point must lie within this distance of the surface (mm), plus one texel.
SURFACE_TOLERANCE_MM = 2.0
#: Most cells per axis of a smoothing dab's local grid (only reached when ``smooth_radius`` is a tiny
#: fraction of a huge brush; the kernel then widens to the dab's extent / this).
SMOOTH_MAX_CELLS_PER_AXIS = 128

#: (tile row, tile column) of the 64² tiles a change touched.
Tiles = tuple[tuple[int, int], ...]
#: Capsules (a, b, facing normal) a dab sweeps: float64 (3,) points in mesh units and a unit normal.
Pieces = list[tuple[np.ndarray, np.ndarray, np.ndarray]]


class StrokeHost(Protocol):
    """What a stroke needs from its document (:class:`painting.document.Document` is the host)."""

    @property
    def mm_per_unit(self) -> float:
        """Millimetres per mesh unit of the head."""
        ...

    def atlas_at(self, resolution: int) -> Atlas:
        """The bake at ``resolution`` texels per side."""
        ...

    def mirror_point(self, point: ArrayLike) -> np.ndarray:
        """``point`` reflected about the head's midplane (mesh units)."""
        ...

    def mirror_vector(self, v: np.ndarray) -> np.ndarray:
        """Direction ``v`` reflected about the head's midplane."""
        ...

    def scratch_maps(self, res: int) -> tuple[np.ndarray, np.ndarray]:
        """(mask, base) flat float32 scratch maps shared by the strokes at ``res`` (mask zero between them)."""
        ...

    def region_values(self, name: str, resolution: int) -> np.ndarray:
        """Region ``name`` at ``resolution``² texels (float32 [0, 1])."""
        ...

    def emit(self, event: ChangeEvent) -> None:
        """Deliver ``event`` to the document's subscribers."""
        ...

    def push_step(self, step: Step) -> None:
        """Record a finished step on the document's undo history."""
        ...

    def begin_stroke(self, stroke: Stroke) -> None:
        """Make ``stroke`` the one in progress (:class:`DocumentError` when another is)."""
        ...

    def end_stroke(self) -> None:
        """No stroke is in progress any more."""
        ...


class Stroke:
    """A stroke in progress (from :meth:`painting.document.Document.stroke`): call :meth:`dab` per point.

    Use it as a context manager: the stroke becomes one undo step when the block ends, and is rolled
    back (the map restored, a "rollback" paint event sent) if the block raises.

    Args:
        doc: the document (its atlas, scratch maps, history and subscribers).
        layer: the layer painted (a layer of ``doc``).
        brush: a validated brush.
        mirror: also paint the dab mirrored about the head's midplane.
        detail: the ``detail`` of the paint events and the undo step's label ("stroke", "fill", "import"…).
    """

    def __init__(self, doc: StrokeHost, layer: Layer, brush: Brush, mirror: bool,
                 detail: str = "stroke") -> None:
        self.doc = doc
        self.layer = layer
        self.brush = brush
        self.mirror = mirror
        self.detail = detail
        self.atlas = doc.atlas_at(layer.resolution)
        self.dabs = 0
        self._last: tuple[np.ndarray, np.ndarray] | None = None  # last dab (point, normal)
        self._last_mirror: tuple[np.ndarray, np.ndarray] | None = None
        self._open = False
        res = layer.resolution
        self._W = res
        self._data = layer.data.reshape(-1)
        # Scratch maps shared by the document's strokes at this resolution, reset tile-wise at the end of
        # each stroke, so a stroke costs nothing proportional to the map size. ``base`` receives a whole
        # 64² tile of the layer the first time the stroke touches the tile (the undo record and the
        # values dabs composite over); ``mask`` is the stroke's coverage.
        self._mask, self._base = doc.scratch_maps(res)
        self._nt = res // TILE
        self._touched = np.zeros(self._nt * self._nt, dtype=bool)
        self._tile_mark = np.zeros(self._nt * self._nt, dtype=bool)
        self._amount = layer.default_thickness if brush.amount_um is None else float(brush.amount_um)
        # The falloff as the compiled kernels take it (kind, hardness, curve samples as float64).
        curve = np.zeros(2)
        xs = np.zeros(2)
        hardness = np.float32(min(max(brush.hardness, 0.0), 1.0))
        if brush.falloff_curve is not None:
            kind = kernels.FALLOFF_CURVE
            c32 = np.asarray(brush.falloff_curve, dtype=np.float32)
            curve = c32.astype(np.float64)
            xs = np.linspace(0.0, 1.0, len(c32), dtype=np.float32).astype(np.float64)
        elif hardness >= 1.0:
            kind = kernels.FALLOFF_HARD
        else:
            kind = kernels.FALLOFF_SMOOTH
        self._falloff_args = (kind, hardness, xs, curve)
        # The brush's region as a per-texel factor on the dab weights (flat float32), or None.
        self._clip: np.ndarray | None = None
        if brush.region is not None:
            m = doc.region_values(brush.region, res).reshape(-1)
            self._clip = m if brush.region_mode == "inside" else (np.float32(1.0) - m)

    # ---- context manager
    def __enter__(self) -> Stroke:
        self.doc.begin_stroke(self)
        self._open = True
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self._open = False
        self.doc.end_stroke()
        if exc_type is not None:
            self._rollback()
            return
        self._commit()

    def _tiles(self) -> np.ndarray:
        ids = np.flatnonzero(self._touched)
        return np.stack([ids // self._nt, ids % self._nt], axis=1).astype(np.int32)

    def _view(self, a: np.ndarray) -> np.ndarray:
        return a.reshape(self._nt, TILE, self._nt, TILE)

    def _reset_scratch(self, tiles: np.ndarray) -> None:
        self._view(self._mask)[tiles[:, 0], :, tiles[:, 1], :] = 0.0

    def _commit(self) -> None:
        tiles = self._tiles()
        if len(tiles) == 0:
            return
        old = self._view(self._base)[tiles[:, 0], :, tiles[:, 1], :]  # a copy (fancy indexing)
        self._reset_scratch(tiles)
        label = f"{self.detail} on {self.layer.name}"
        self.doc.push_step(Step(label, deltas=[TileDelta(self.layer, tiles, old)]))

    def _rollback(self) -> None:
        tiles = self._tiles()
        if len(tiles) == 0:
            return
        ty, tx = tiles[:, 0], tiles[:, 1]
        self._view(self._data)[ty, :, tx, :] = self._view(self._base)[ty, :, tx, :]
        self._reset_scratch(tiles)
        self.doc.emit(ChangeEvent("paint", self.layer.id, tuple(map(tuple, tiles.tolist())), "rollback"))

    # ---- texel writes
    def _prepare(self, flat: np.ndarray,
                 sidx: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, Tiles]:
        """Get ready to write covered texels ``flat`` (``sidx``: their spatial-index entries, a shortcut).

        Returns the padding texels they feed (dst, src), and the touched tiles, whose old values are
        saved in ``base`` if this stroke had not touched them yet.
        """
        index = self.atlas.index if sidx is not None else None
        dst, src = self.atlas.pads_of(flat, None if index is None else index.has_pad[sidx])
        res = self._W
        nt = self._nt
        # Mark tiles in a small boolean table instead of np.unique (no sort of the texel list).
        mark = self._tile_mark
        if index is not None:
            mark[index.tile[sidx]] = True
        else:
            mark[tile_of(flat, res)] = True
        if len(dst):
            mark[tile_of(dst, res)] = True
        ids = np.flatnonzero(mark)
        mark[ids] = False
        new = ids[~self._touched[ids]]
        if len(new):
            ty, tx = new // nt, new % nt
            self._view(self._base)[ty, :, tx, :] = self._view(self._data)[ty, :, tx, :]
            self._touched[new] = True
        return dst, src, tuple(zip((ids // nt).tolist(), (ids % nt).tolist()))

    def _store(self, flat: np.ndarray, values: np.ndarray, dst: np.ndarray, src: np.ndarray) -> None:
        self._data[flat] = values
        if len(dst):
            self._data[dst] = self._data[src]

    def _write(self, flat: np.ndarray, values: np.ndarray) -> Tiles:
        """Write covered texels and the padding texels they feed; returns the touched tiles."""
        dst, src, tiles = self._prepare(flat)
        self._store(flat, values, dst, src)
        return tiles

    # ---- dabs
    def dab(self, point: ArrayLike, pressure: float = 1.0, normal: ArrayLike | None = None) -> Tiles:
        """Paint at a surface point.

        Args:
            point: (x, y, z) in mesh units, on the surface (within :data:`SURFACE_TOLERANCE_MM` plus one
                texel).
            pressure: in [0, 1]; scales the radius and/or the flow as the brush says.
            normal: the direction the brush faces from (default: the surface normal at the point);
                texels facing more than ``brush.max_angle_deg`` away from it are not painted.

        Returns:
            The touched tiles, (tile row, tile column) each (empty when nothing was painted, e.g. a dab
            closer to the last one than the brush's spacing).

        Raises:
            DocumentError: (document unchanged) a non-finite point or pressure, a zero normal, a point
                too far from the surface, or a call outside the ``with`` block.
        """
        if not self._open:
            raise DocumentError("dab() outside the stroke's 'with' block")
        p = as_vec3(point, "dab point")
        try:
            pr = float(pressure)
        except (TypeError, ValueError):
            raise DocumentError(f"pressure must be a number in [0, 1], got {pressure!r}") from None
        if not math.isfinite(pr) or not 0.0 <= pr <= 1.0:
            raise DocumentError(f"pressure must be a number in [0, 1], got {pressure!r}")
        n_user = None
        if normal is not None:
            n_user = as_vec3(normal, "dab normal")
            norm = float(np.linalg.norm(n_user))
            if norm == 0:
                raise DocumentError("dab normal must not be zero")
            n_user = n_user / norm
        brush = self.brush
        mpu = self.doc.mm_per_unit
        index = self.atlas.index
        tol = (SURFACE_TOLERANCE_MM + 1.5 * self.atlas.texel_mm) / mpu
        k, _ = index.nearest(p, tol)
        if k < 0:
            raise DocumentError(f"dab point ({p[0]:.4g}, {p[1]:.4g}, {p[2]:.4g}) is more than "
                                f"{tol * mpu:.2f} mm from the surface of layer {self.layer.name!r}'s head")
        r = brush.radius_mm * (pr if brush.pressure_radius else 1.0) / mpu
        if r <= 0:
            return ()
        alpha = brush.flow * (pr if brush.pressure_strength else 1.0)
        n0 = n_user if n_user is not None else index.normal(k)
        if self._last is not None and brush.mode != "fill" \
                and float(np.linalg.norm(p - self._last[0])) < brush.spacing * r:
            return ()
        pieces = self._path(self._last, p, n0, r, index)
        if self.mirror:
            pm = self.doc.mirror_point(p)
            km_, _ = index.nearest(pm, max(tol, r))
            if km_ >= 0:
                pm = index.point(km_)
                nm = self.doc.mirror_vector(n0) if n_user is not None else index.normal(km_)
                pieces += self._path(self._last_mirror, pm, nm, r, index)
                self._last_mirror = (pm, nm)
        self._last = (p, n0)
        self.dabs += 1
        if brush.mode == "fill":
            amount = min(brush.strength * self._amount, self.layer.max_thickness)
            if self._clip is not None:
                tiles = self.fill_soft(self._clip, amount, emit=False)
            else:
                chart = int(self.atlas.chart.reshape(-1)[index.flat[k]])
                tiles = self.fill_region(self.atlas, chart, amount, emit=False)
        else:
            # The compiled kernels once loaded, else the numpy reference: bit-identical results.
            paint = self._paint_compiled if kernels.active() else self._paint_numpy
            tiles = paint(pieces, r, np.float32(alpha), index)
        if tiles:
            self.doc.emit(ChangeEvent("paint", self.layer.id, tiles, self.detail))
        return tiles

    def _path(self, last: tuple[np.ndarray, np.ndarray] | None, p: np.ndarray, n: np.ndarray, r: float,
              index: TexelIndex) -> Pieces:
        """Capsules (a, b, normal) from the last dab (point, normal) to ``p`` (mesh units, radius ``r``).

        One sphere for the first dab; long gaps are split into pieces no longer than the radius with the
        joints snapped to the surface. A piece faces the mean of its end normals (so a quick stroke round
        the nose keeps the texels facing either end).
        """
        if last is None:
            return [(p, p, n)]
        q0, n_last = last
        length = float(np.linalg.norm(p - q0))
        pieces = max(1, int(math.ceil(length / r)))
        pts = [q0]
        normals = [n_last]
        for i in range(1, pieces):
            q = q0 + (p - q0) * (i / pieces)
            k, _ = index.nearest(q, max(r, 0.5 * length))
            pts.append(index.point(k) if k >= 0 else q)
            normals.append(index.normal(k) if k >= 0 else n)
        pts.append(p)
        normals.append(n)
        out = []
        for i in range(pieces):
            m = normals[i] + normals[i + 1]
            norm = float(np.linalg.norm(m))
            out.append((pts[i], pts[i + 1], m / norm if norm > 1e-9 else normals[i + 1]))
        return out

    def _weights(self, pieces: Pieces, r: float,
                 index: TexelIndex) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Texels within ``r`` of any capsule and facing its normal: (flat, weight, sorted index).

        The weight (falloff, in [0, 1]) of a texel reached by several capsules is the largest.
        """
        cos_max = np.float32(math.cos(math.radians(self.brush.max_angle_deg)))
        r2 = np.float32(r * r)
        out_idx, out_w = [], []
        f32 = np.float32
        for a, b, n in pieces:
            idx = index.query_sphere((a + b) / 2.0, r + float(np.linalg.norm(b - a)) / 2.0)
            if len(idx) == 0:
                continue
            # Separate x/y/z arrays: far faster in numpy than (N, 3) rows.
            dx = index.x[idx] - f32(a[0])
            dy = index.y[idx] - f32(a[1])
            dz = index.z[idx] - f32(a[2])
            if not np.array_equal(a, b):
                ab = (b - a).astype(np.float32)
                abab = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2]  # float32, summed left to right
                t = (dx * ab[0] + dy * ab[1] + dz * ab[2]) / abab
                np.clip(t, 0.0, 1.0, out=t)
                dx -= t * ab[0]
                dy -= t * ab[1]
                dz -= t * ab[2]
            d2 = dx * dx + dy * dy + dz * dz
            inside = np.flatnonzero(d2 < r2)
            idx = idx[inside]
            d2 = d2[inside]
            if self.brush.max_angle_deg < 180.0:
                facing = (index.nx[idx] * f32(n[0]) + index.ny[idx] * f32(n[1])
                          + index.nz[idx] * f32(n[2])) >= cos_max
                idx = idx[facing]
                d2 = d2[facing]
            out_idx.append(idx)
            out_w.append(self.brush.falloff(np.sqrt(d2) / f32(r)))
        if not out_idx:
            empty = np.zeros(0, dtype=np.int64)
            return empty, np.zeros(0, dtype=np.float32), empty
        idx = np.concatenate(out_idx)
        w = np.concatenate(out_w)
        if len(out_idx) > 1:
            order = np.lexsort((-w, idx))
            idx, w = idx[order], w[order]
            first = np.ones(len(idx), dtype=bool)
            first[1:] = idx[1:] != idx[:-1]
            idx, w = idx[first], w[first]
        return index.flat[idx], w, idx

    def _paint_compiled(self, pieces: Pieces, r: float, alpha: np.float32, index: TexelIndex) -> Tiles:
        """Paint the dab's capsules through the compiled kernels (:mod:`painting.kernels`).

        The one entry point to them: :func:`painting.kernels.weights`, then
        :func:`painting.kernels.composite` (or :meth:`_smooth`). Bit-identical to :meth:`_paint_numpy`:
        the same texels and weights (with several capsules the texels come out ascending, as in the
        reference), map, coverage, saved tiles and returned tiles.

        Args:
            pieces: the capsules of :meth:`_path`.
            r: the brush radius (mesh units).
            alpha: the dab's flow × pressure, in [0, 1].
            index: the atlas's texel index.

        Returns:
            The touched tiles (empty when no texel was painted).
        """
        a = np.array([piece[0] for piece in pieces], dtype=np.float64)
        b = np.array([piece[1] for piece in pieces], dtype=np.float64)
        n = np.array([piece[2] for piece in pieces], dtype=np.float64)
        kind, hardness, xs, curve = self._falloff_args
        cos_max = np.float32(math.cos(math.radians(self.brush.max_angle_deg)))
        sidx, w = kernels.weights(index.pn, index.origin, float(index.cell), index.dims_array, index.cell_start,
                                  a, b, n, float(r), cos_max, bool(self.brush.max_angle_deg < 180.0), kind,
                                  hardness, xs, curve)
        if self._clip is not None:
            sidx, w = self._clipped(sidx, w, index)
        if len(sidx) == 0:
            return ()
        if self.brush.mode == "smooth":
            return self._smooth(index.flat[sidx], w * alpha, sidx, r, index)
        atlas = self.atlas
        ids = kernels.composite(sidx, w, alpha, index.flat, index.tile, index.has_pad, atlas.pad_src,
                                atlas.pad_dst, self._data, self._mask, self._base, self._touched,
                                self._tile_mark, self._W, kernels.MODE_CODES[self.brush.mode],
                                np.float32(self.brush.strength), np.float32(self._amount),
                                np.float32(self.layer.max_thickness))
        nt = self._nt
        return tuple(zip((ids // nt).tolist(), (ids % nt).tolist()))

    def _paint_numpy(self, pieces: Pieces, r: float, alpha: np.float32, index: TexelIndex) -> Tiles:
        """Paint the dab's capsules through the numpy reference (arguments and result as the compiled path).

        The one entry point to it: :meth:`_weights`, then :meth:`_composite` (or :meth:`_smooth`);
        bit-identical to :meth:`_paint_compiled`.
        """
        flat, w, sidx = self._weights(pieces, r, index)
        if self._clip is not None:
            sidx, w = self._clipped(sidx, w, index)
            flat = index.flat[sidx]
        if len(flat) == 0:
            return ()
        if self.brush.mode == "smooth":
            return self._smooth(flat, w * alpha, sidx, r, index)
        return self._composite(flat, w * alpha, sidx)

    def _clipped(self, sidx: np.ndarray, w: np.ndarray, index: TexelIndex) -> tuple[np.ndarray, np.ndarray]:
        """The dab's texels (index entries, weights) times the brush region's factor, zeros dropped."""
        assert self._clip is not None
        w = (w * self._clip[index.flat[sidx]]).astype(np.float32)
        keep = np.flatnonzero(w > 0)
        return sidx[keep], w[keep]

    def _composite(self, flat: np.ndarray, alpha: np.ndarray,
                   sidx: np.ndarray | None = None) -> Tiles:
        dst, src, tiles = self._prepare(flat, sidx)
        m = self._mask[flat]
        m += (np.float32(1.0) - m) * alpha
        self._mask[flat] = m
        base = self._base[flat]
        s = np.float32(self.brush.strength)
        mode = self.brush.mode
        if mode == "add":
            top = np.float32(self.layer.max_thickness)
            values = np.minimum(base + (s * np.float32(self._amount)) * m, top)
            values = np.where(base > top, base, values)
        elif mode == "erase":
            values = base * (np.float32(1.0) - s * m)
        else:  # set
            target = np.float32(min(self._amount, self.layer.max_thickness))
            values = base + (target - base) * (s * m)
        self._store(flat, values.astype(np.float32, copy=False), dst, src)
        return tiles

    def _smooth(self, flat: np.ndarray, alpha: np.ndarray, sidx: np.ndarray, r: float,
                index: TexelIndex) -> Tiles:
        """One conservative diffusion step over the dab's texels, in 3D, with no neighbour cap.

        The kernel is ``K_ij = Σ_c φ_c(p_i) φ_c(p_j)``, ``φ_c`` the trilinear hat functions of a local
        grid of spacing ``h = smooth_radius · r`` (at least one texel): symmetric, non-negative, reaching
        texels up to 2h apart (per axis). With ``s_i = √alpha_i`` the step is
        ``Δt_i = β Σ_j s_i s_j K_ij (t_j − t_i)``: antisymmetric, so the sum of thickness is conserved
        (up to float rounding), and with ``β = strength / max_i(s_i Σ_j K_ij s_j)`` every new value is a
        convex combination of the old ones (no overshoot, never negative). It costs O(texels · 8) through
        splatting to and gathering from the grid nodes — a few ms on the finest maps, where the pair list
        of a uniform ball had to be capped.
        """
        cols = [a[sidx].astype(np.float64) for a in (index.x, index.y, index.z)]
        texel = self.atlas.texel_mm / self.doc.mm_per_unit
        lo = [float(col.min()) for col in cols]
        extent = max(float(col.max()) - low for col, low in zip(cols, lo))
        h = max(self.brush.smooth_radius * r, texel, extent / SMOOTH_MAX_CELLS_PER_AXIS)
        n = len(flat)
        cells, hats = [], []
        for col, low in zip(cols, lo):
            u = (col - low) / h
            i = np.floor(u)
            frac = u - i
            cells.append(i.astype(np.int64))
            hats.append(np.stack([1.0 - frac, frac], axis=1))  # the two hat weights along this axis
        dims = [int(c.max()) + 2 for c in cells]
        # Node (cx, cy, cz) ∈ {0, 1}³ of each texel's cell, x slowest: its key and trilinear weight.
        offs = np.array([cx + dims[0] * (cy + dims[1] * cz) for cx in (0, 1) for cy in (0, 1) for cz in (0, 1)])
        keys = (cells[0] + dims[0] * (cells[1] + dims[1] * cells[2]))[:, None] + offs[None, :]
        phi = (hats[0][:, :, None, None] * hats[1][:, None, :, None] * hats[2][:, None, None, :]).reshape(n, 8)
        ncell = int(dims[0] * dims[1] * dims[2])
        s = np.sqrt(alpha.astype(np.float64))
        t = self._data[flat].astype(np.float64)
        ps = phi * s[:, None]
        node_w = np.bincount(keys.ravel(), ps.ravel(), minlength=ncell)  # Σ_j φ_c(p_j) s_j
        node_t = np.bincount(keys.ravel(), (ps * t[:, None]).ravel(), minlength=ncell)  # … · t_j
        gather_w = (phi * node_w[keys]).sum(axis=1)  # Σ_j K_ij s_j
        gather_t = (phi * node_t[keys]).sum(axis=1)  # Σ_j K_ij s_j t_j
        rate = s * gather_w
        top = float(rate.max(initial=0.0))
        if top <= 0.0:
            return ()
        beta = float(self.brush.strength) / top
        new = t + beta * s * (gather_t - t * gather_w)
        return self._write(flat, np.maximum(new, 0.0).astype(np.float32))

    def fill_region(self, atlas: Atlas, chart: int | None, value: float, emit: bool = True) -> Tiles:
        """Set every covered texel (of one ``chart``, or all) to ``value``; returns the touched tiles.

        ``emit``: send the "paint" event here (a fill dab sends its own).
        """
        cov = atlas.coverage.reshape(-1)
        if chart is None:
            flat = np.flatnonzero(cov)
        else:
            flat = np.flatnonzero(cov & (atlas.chart.reshape(-1) == chart))
        if len(flat) == 0:
            return ()
        tiles = self._write(flat, np.full(len(flat), value, dtype=np.float32))
        if emit and tiles:
            self.doc.emit(ChangeEvent("paint", self.layer.id, tiles, self.detail))
        return tiles

    def fill_soft(self, weights: np.ndarray, value: float, emit: bool = True) -> Tiles:
        """Move every covered texel towards ``value`` (µm) by its weight (flat float32 in [0, 1]): ``t + (value − t)·w``."""
        flat = np.flatnonzero((weights > 0) & self.atlas.coverage.reshape(-1))
        if len(flat) == 0:
            return ()
        t = self._data[flat]
        w = weights[flat].astype(np.float32)
        tiles = self._write(flat, (t + (np.float32(value) - t) * w).astype(np.float32))
        if emit and tiles:
            self.doc.emit(ChangeEvent("paint", self.layer.id, tiles, self.detail))
        return tiles

    def replace_all(self, values: np.ndarray) -> None:
        """Replace the whole map (import); only tiles that really change are recorded."""
        new = values.reshape(-1)
        c = np.flatnonzero(self._data != new)
        if len(c) == 0:
            return
        _, _, tiles = self._prepare(c)
        self._data[c] = new[c]
        self.doc.emit(ChangeEvent("paint", self.layer.id, tiles, self.detail))
