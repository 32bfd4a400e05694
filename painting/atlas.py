"""The paint atlas: the per-texel bake of a :class:`painting.layout.UVLayout`, and its cache on disk.

Per texel: 3D position, normal, triangle id, chart id and coverage, with padding beyond chart borders.

Units: positions in **mesh units** (as loaded, see :mod:`painting.head`); normals are unit vectors;
texture space follows :mod:`painting.head` (row ``i`` covers ``v ∈ [i/H, (i+1)/H)``).

Pipeline::

    layout = painting.layout.build_layout(head)   # the paint UVs (see :mod:`painting.layout`)
    atlas = bake(layout, 2048)           # per-texel maps; cached on disk (see ``cache_dir``)
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from painting.layout import AtlasError
from painting.raster import rasterize
from painting.spatial import TexelIndex
from painting.tiles import TILE

if TYPE_CHECKING:
    from pathlib import Path

    from painting.layout import ProgressCallback, UVLayout

#: Texels of padding (dilation) beyond every chart border, so bilinear sampling shows no seams.
DEFAULT_PADDING = 4
MIN_RESOLUTION = 64
MAX_RESOLUTION = 8192

_CACHE_VERSION = 5
#: one texel index loads at a time (see :attr:`Atlas.index`)
_INDEX_LOCK = threading.Lock()
#: version of the spatial index kept beside a cached bake (see :attr:`Atlas.index`)
_INDEX_CACHE_VERSION = 1


@dataclass
class Atlas:
    """Per-texel maps of one resolution (``H = W = resolution``), top row first.

    Attributes:
        position: float32 (H, W, 3) mesh units (padding texels copy their source texel).
        normal: float32 (H, W, 3) unit normals (smooth across seams).
        face: int32 (H, W) layout triangle id, -1 where nothing was baked.
        chart: int32 (H, W) chart id, -1 where nothing was baked.
        coverage: bool (H, W) texels overlapping a triangle (conservative rasterisation).
        padded: bool (H, W) texels filled by dilation beyond chart borders (not covered).
        pad_dst, pad_src: int64 flat indices; padding texel ``pad_dst[k]`` copies covered texel
            ``pad_src[k]`` (sorted by ``pad_src``).
        texel_mm: median 3D size of a texel (mm).
    """

    resolution: int
    position: np.ndarray
    normal: np.ndarray
    face: np.ndarray
    chart: np.ndarray
    coverage: np.ndarray
    padded: np.ndarray
    pad_dst: np.ndarray
    pad_src: np.ndarray
    padding: int
    texel_mm: float
    mm_per_unit: float
    _index: TexelIndex | None = field(default=None, repr=False)
    _has_pad: np.ndarray | None = field(default=None, repr=False)
    _cache_path: Path | None = field(default=None, repr=False)  # the bake's cache file, if any

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of every map: (resolution, resolution) texels."""
        return (self.resolution, self.resolution)

    @property
    def tiles(self) -> tuple[int, int]:
        """Number of 64² tiles (rows, columns)."""
        return (self.resolution // TILE, self.resolution // TILE)

    @property
    def index(self) -> TexelIndex:
        """The texel spatial index (:class:`painting.spatial.TexelIndex`), built on first use.

        Kept in the cache beside a cached bake (building it takes about 2 s at 2048², reading it 0.1 s).
        """
        with _INDEX_LOCK:  # a background warm-up and the first dab may ask at once: one load
            return self._load_index()

    def _load_index(self) -> TexelIndex:
        if self._index is None:
            from core.cache import cache_dir as core_cache_dir

            entry = (None if self._cache_path is None  # the cache's "index" kind, named after the bake
                     else core_cache_dir("index") / f"{self._cache_path.stem}-i{_INDEX_CACHE_VERSION}.cache")
            count = int(np.count_nonzero(self.coverage))
            index = TexelIndex.load(entry, count, _INDEX_CACHE_VERSION) if entry is not None else None
            if index is None:
                index = TexelIndex.build(self)
                if entry is not None:
                    index.save(entry, _INDEX_CACHE_VERSION)
            self._index = index
        return self._index

    def pads_of(self, flat: np.ndarray, has_pad: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Padding texels fed by the covered texels ``flat``: (dst, src) flat index arrays.

        ``has_pad`` (optional, bool like ``flat``) says which of them feed any (a shortcut).
        """
        if len(self.pad_src) == 0 or len(flat) == 0:
            empty = np.zeros(0, dtype=np.int64)
            return empty, empty
        if has_pad is None:
            if self._has_pad is None:
                self._has_pad = np.zeros(self.resolution * self.resolution, dtype=bool)
                self._has_pad[self.pad_src] = True
            has_pad = self._has_pad[flat]
        flat = flat[has_pad]
        lo = np.searchsorted(self.pad_src, flat, side="left")
        hi = np.searchsorted(self.pad_src, flat, side="right")
        n = hi - lo
        has = n > 0
        if not np.any(has):
            empty = np.zeros(0, dtype=np.int64)
            return empty, empty
        lo, n = lo[has], n[has]
        total = int(n.sum())
        starts = np.repeat(lo - np.cumsum(n) + n, n)
        k = np.arange(total, dtype=np.int64) + starts
        return self.pad_dst[k], self.pad_src[k]

    def charts_at(self, flat: np.ndarray) -> np.ndarray:
        """Chart id (int32, -1 where nothing was baked) of each flat texel index in ``flat``."""
        return self.chart.reshape(-1)[flat]


def check_resolution(resolution: Any) -> int:
    """Validate a map resolution: an int, a multiple of 64 in [64, 8192]."""
    try:
        res = int(resolution)
    except (TypeError, ValueError):
        raise AtlasError(f"resolution must be an integer, got {resolution!r}") from None
    if res != resolution or res < MIN_RESOLUTION or res > MAX_RESOLUTION or res % TILE:
        raise AtlasError(f"resolution must be a multiple of {TILE} in [{MIN_RESOLUTION}, {MAX_RESOLUTION}], "
                         f"got {resolution!r}")
    return res


def cache_dir() -> Path:
    """Where baked atlases are cached: the ``atlas`` folder of :func:`core.cache.cache_dir`.

    ``$SHEER_CACHE_DIR/atlas`` or ``$XDG_CACHE_HOME/sheer/atlas`` (default ``~/.cache/sheer/atlas``).
    """
    from core.cache import cache_dir as km_cache_dir

    return km_cache_dir("atlas")


def bake(layout: UVLayout, resolution: int, padding: int = DEFAULT_PADDING,
         progress: ProgressCallback | None = None, cache: bool = True) -> Atlas:
    """Bake position, normal, triangle and chart ids and coverage at ``resolution``² texels.

    Conservative rasterisation covers every texel a triangle overlaps; texels within ``padding``
    texels outside the covered area copy their nearest covered texel. Bakes at 512² and above are
    cached on disk (:func:`cache_dir`) keyed by the layout hash, resolution and padding; a broken
    cache file is ignored and rewritten.
    """
    res = check_resolution(resolution)
    report = progress or (lambda stage, fraction: None)
    path = cache_dir() / f"{layout.key}-{res}-p{padding}-v{_CACHE_VERSION}.cache"
    cached = _load_cached(path, layout.mm_per_unit, res, padding) if cache and res >= 512 else None
    if cached is not None:
        cached._cache_path = path
        report("bake", 1.0)
        return cached
    report("bake", 0.0)
    tri = layout.uv[layout.faces] * float(res)
    face, bary = rasterize(tri, res, res, conservative=True)
    report("bake", 0.6)
    covered = face >= 0
    cov_flat = np.flatnonzero(covered.reshape(-1))
    fidx = face.reshape(-1)[cov_flat]
    # Interpolate per coordinate (1D arrays; numpy is slow on (n, 3) rows).
    bflat = bary.reshape(-1, 3)
    weights = [bflat[cov_flat, k] for k in range(3)]
    del bary, bflat
    corner = [layout.faces[fidx, k] for k in range(3)]
    position = np.zeros((res, res, 3), dtype=np.float32)
    normal = np.zeros((res, res, 3), dtype=np.float32)
    position_rows = position.reshape(-1, 3)  # views, one row per texel
    normal_rows = normal.reshape(-1, 3)
    ncomp = []
    for axis in range(3):
        vcol = np.ascontiguousarray(layout.vertices[:, axis])
        ncol = np.ascontiguousarray(layout.normals[:, axis])
        position_rows[cov_flat, axis] = sum(weights[k] * vcol[corner[k]] for k in range(3))
        ncomp.append(sum(weights[k] * ncol[corner[k]] for k in range(3)))
    length = np.sqrt(ncomp[0] ** 2 + ncomp[1] ** 2 + ncomp[2] ** 2)
    np.maximum(length, 1e-12, out=length)
    for axis in range(3):
        normal_rows[cov_flat, axis] = ncomp[axis] / length
    del ncomp, weights, corner
    chart = np.full((res, res), -1, dtype=np.int32)
    chart.reshape(-1)[cov_flat] = layout.chart_of_face[fidx]
    report("bake", 0.8)
    padded = np.zeros((res, res), dtype=bool)
    pad_dst = np.zeros(0, dtype=np.int64)
    pad_src = np.zeros(0, dtype=np.int64)
    if padding > 0 and covered.any() and not covered.all():
        pad_dst, pad_src = _padding_sources(covered, padding)
        padded.reshape(-1)[pad_dst] = True
        for arr in (position, normal):
            flat = arr.reshape(-1, 3)
            flat[pad_dst] = flat[pad_src]
        face.reshape(-1)[pad_dst] = face.reshape(-1)[pad_src]
        chart.reshape(-1)[pad_dst] = chart.reshape(-1)[pad_src]
    texel_mm = _texel_size_mm(position, covered, layout.mm_per_unit)
    atlas = Atlas(resolution=res, position=position, normal=normal, face=face, chart=chart, coverage=covered,
                  padded=padded, pad_dst=pad_dst, pad_src=pad_src, padding=padding, texel_mm=texel_mm,
                  mm_per_unit=layout.mm_per_unit)
    report("bake", 1.0)
    if cache and res >= 512 and _save_cached(path, atlas):
        atlas._cache_path = path
    return atlas


def _padding_sources(covered: np.ndarray, padding: int) -> tuple[np.ndarray, np.ndarray]:
    """Uncovered texels near a covered one, and their nearest covered texel: (dst, src) sorted by src.

    ``dst`` are the texels within ``padding`` texels (Euclidean, centre to centre) of a covered one;
    both are flat indices.

    Same result as ``scipy.ndimage.distance_transform_edt(..., return_indices=True)`` restricted to the
    band (ties aside), but only the band is searched: a square dilation bounds it and a cKDTree over the
    covered texels on the chart borders (the nearest covered texel is always one) finds the sources.
    """
    from scipy import ndimage
    from scipy.spatial import cKDTree

    res_w = covered.shape[1]
    square = np.ones((3, 3), dtype=bool)
    band = ndimage.binary_dilation(covered, structure=square, iterations=padding) & ~covered
    border = covered & ~ndimage.binary_erosion(covered, structure=square, border_value=0)
    br, bc = np.nonzero(border)
    qr, qc = np.nonzero(band)
    if len(br) == 0 or len(qr) == 0:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty
    tree = cKDTree(np.stack([br, bc], axis=1).astype(np.float64))
    dist, k = tree.query(np.stack([qr, qc], axis=1).astype(np.float64), distance_upper_bound=padding + 1e-9)
    ok = dist <= padding
    dst = (qr[ok] * res_w + qc[ok]).astype(np.int64)
    src = (br[k[ok]] * res_w + bc[k[ok]]).astype(np.int64)
    order = np.argsort(src, kind="stable")
    return dst[order], src[order]


def _texel_size_mm(position: np.ndarray, covered: np.ndarray, mm_per_unit: float) -> float:
    """Median 3D distance between horizontally adjacent covered texels (every 4th row), in mm."""
    pos = position[::4]
    cov = covered[::4]
    both = cov[:, :-1] & cov[:, 1:]
    if not both.any():
        return float("nan")
    d2 = sum((pos[:, 1:, k][both] - pos[:, :-1, k][both]).astype(np.float64) ** 2 for k in range(3))
    return float(np.median(np.sqrt(d2))) * mm_per_unit


_FIELDS = ("position", "normal", "face", "chart", "coverage", "padded", "pad_dst", "pad_src")


def _save_cached(path: Path, atlas: Atlas) -> bool:
    """Write ``atlas`` to the cache entry ``path`` (:func:`core.cache.save_arrays`); whether it was kept.

    The cache's one policy decides the rest: atomic, checked on reading, evicted least recently used.
    """
    from core.cache import save_arrays

    meta = np.array([atlas.resolution, atlas.padding, atlas.texel_mm], dtype=np.float64)
    return save_arrays(path, {"meta": meta, **{k: getattr(atlas, k) for k in _FIELDS}}, _CACHE_VERSION)


def _load_cached(path: Path, mm_per_unit: float, res: int, padding: int) -> Atlas | None:
    """The bake cached at ``path`` for ``res`` and ``padding``, or None (absent, damaged or inconsistent)."""
    from core.cache import load_arrays

    values = load_arrays(path, _CACHE_VERSION)
    if values is None or any(k not in values for k in ("meta", *_FIELDS)):
        return None
    meta = values.pop("meta")
    if meta.shape != (3,) or int(meta[0]) != res or int(meta[1]) != padding:
        return None
    for k in ("position", "normal"):
        if values[k].shape != (res, res, 3):
            return None
    for k in ("face", "chart", "coverage", "padded"):
        if values[k].shape != (res, res):
            return None
    return Atlas(resolution=res, padding=padding, texel_mm=float(meta[2]), mm_per_unit=mm_per_unit,
                 position=values["position"], normal=values["normal"], face=values["face"], chart=values["chart"],
                 coverage=values["coverage"], padded=values["padded"], pad_dst=values["pad_dst"],
                 pad_src=values["pad_src"])
