"""The paint atlas: mesh cleaning, the UV layout (the mesh's own UVs or an xatlas unwrap) and the per-texel
bake (3D position, normal, triangle id, chart id, coverage) with padding beyond chart borders.

Units: positions in **mesh units** (as loaded, see :mod:`painting.head`); normals are unit vectors;
texture space follows :mod:`painting.head` (row ``i`` covers ``v ∈ [i/H, (i+1)/H)``).

Pipeline::

    layout = build_layout(head)          # clean + validate UVs (+ xatlas if needed); cheap
    atlas = bake(layout, 2048)           # per-texel maps; cached on disk (see ``cache_dir``)
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from core.errors import SheerError
from painting.raster import barycentric, iter_candidates, rasterize
from painting.tiles import TILE

if TYPE_CHECKING:
    from pathlib import Path

#: ``progress(stage, fraction)``: stage is "clean", "check", "unwrap" or "bake"; fraction in [0, 1].
ProgressCallback = Callable[[str, float], None]

#: Texels of padding (dilation) beyond every chart border, so bilinear sampling shows no seams.
DEFAULT_PADDING = 4
#: Resolution at which UV overlaps are checked (independent of the layers' resolutions).
CHECK_RESOLUTION = 1024
#: A UV layout is rejected when more than this fraction of its covered texels is covered twice.
MAX_OVERLAP_FRACTION = 1e-3
#: Triangles with zero UV area are tolerated (left unpainted) while their 3D area is below this fraction.
MAX_DEGENERATE_AREA_FRACTION = 1e-3
MIN_RESOLUTION = 64
MAX_RESOLUTION = 8192

_CACHE_VERSION = 5
#: version of the spatial index kept beside a cached bake (see :attr:`Atlas.index`)
_INDEX_CACHE_VERSION = 1


class AtlasError(SheerError, ValueError):
    """A mesh or UV layout that cannot be painted, or a bad bake request; the message says why."""


@dataclass
class CleanReport:
    """What :func:`clean_mesh` changed (counts refer to the mesh as loaded).

    Attributes:
        vertices: vertices as loaded. faces: triangles as loaded.
        welded_vertices: vertices that share a position with another one (split by UV seams or normals);
            they are merged for adjacency and smooth normals only (the paint atlas keeps the split).
        degenerate_faces: triangles with (near) zero 3D area or repeated corners, dropped.
        flipped_faces: triangles whose winding was made consistent with their neighbours / outward
            (``flipped``: bool per kept triangle).
        components: connected pieces of the welded mesh.
        watertight: the welded mesh is closed.
    """

    vertices: int
    faces: int
    welded_vertices: int = 0
    degenerate_faces: int = 0
    flipped_faces: int = 0
    components: int = 1
    watertight: bool = False
    flipped: np.ndarray | None = field(default=None, repr=False)

    def summary(self) -> str:
        """One line for logs and the studio's status bar."""
        return (f"{self.vertices:,} vertices, {self.faces:,} triangles: welded {self.welded_vertices:,} "
                f"seam-split vertices, dropped {self.degenerate_faces} degenerate triangles, "
                f"flipped {self.flipped_faces}, {self.components} component(s)"
                f"{', watertight' if self.watertight else ''}")


@dataclass
class UVCheck:
    """Whether a mesh's own UVs can be painted directly.

    Attributes:
        valid: inside [0, 1], (almost) no degenerate UV triangles, (almost) no overlapping triangles
            (at most :data:`MAX_OVERLAP_FRACTION` of the covered texels).
        reason: why not (empty when valid).
        out_of_range: vertices with a UV outside [0, 1].
        degenerate: triangles with a 3D area but (near) zero UV area (tolerated, unpainted, while they
            are under :data:`MAX_DEGENERATE_AREA_FRACTION` of the surface).
        overlapping_texels: texels (at :data:`CHECK_RESOLUTION`) covered by more than one triangle.
        mirrored_faces: triangles whose UV orientation is opposite to their chart's majority (folds).
        mirrored_charts: charts whose UV orientation is flipped relative to the 3D winding (harmless
            when they do not overlap anything).
        charts: connected UV charts.
    """

    valid: bool
    reason: str = ""
    out_of_range: int = 0
    degenerate: int = 0
    overlapping_texels: int = 0
    mirrored_faces: int = 0
    mirrored_charts: int = 0
    charts: int = 0


@dataclass
class UVLayout:
    """The mesh as painted: vertices split along UV seams, with one UV each.

    Attributes:
        vertices: float64 (N, 3) mesh units. faces: int64 (F, 3) into ``vertices``.
        uv: float64 (N, 2) in [0, 1]. normals: float64 (N, 3) unit, smooth across UV seams.
        vertex_map: int64 (N,) original (head) vertex of each layout vertex.
        face_map: int64 (F,) original (head) triangle of each layout triangle (degenerate ones dropped).
        chart_of_face: int32 (F,) chart id per triangle. charts: number of charts.
        source: "mesh" (the file's own UVs) or "xatlas".
        utilisation: fraction of the UV square covered by charts (at :data:`CHECK_RESOLUTION`).
        check: the verdict on the file's own UVs. clean: what cleaning changed.
        mm_per_unit: scale of the head (millimetres per mesh unit).
    """

    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray
    normals: np.ndarray
    vertex_map: np.ndarray
    face_map: np.ndarray
    chart_of_face: np.ndarray
    charts: int
    source: str
    utilisation: float
    check: UVCheck
    clean: CleanReport
    mm_per_unit: float = 1.0
    _key: str = field(default="", repr=False)

    @property
    def key(self) -> str:
        """A hash of everything a bake depends on (for caches)."""
        if not self._key:
            h = hashlib.sha1()
            for arr in (self.vertices, self.faces, self.uv, self.normals, self.chart_of_face):
                h.update(np.ascontiguousarray(arr).tobytes())
            self._key = h.hexdigest()[:20]
        return self._key

    def source_uv(self, head: Any) -> np.ndarray:
        """The file's own UVs per layout triangle corner, float64 (F, 3, 2) (for textures authored on
        them, e.g. the albedo, when the paint layout is an xatlas unwrap; layout triangle ``i`` is the
        head's triangle ``face_map[i]``, with corners 1 and 2 swapped where cleaning flipped it).
        """
        corners = np.asarray(head.faces)[self.face_map]
        if self.clean.flipped is not None and self.clean.flipped.any():
            corners = corners.copy()
            corners[self.clean.flipped] = corners[self.clean.flipped][:, [0, 2, 1]]
        return np.asarray(head.uv, dtype=np.float64)[corners]

    def trimesh(self) -> Any:
        """The layout as an (unprocessed) ``trimesh.Trimesh``."""
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, vertex_normals=self.normals, process=False)


# ---------------------------------------------------------------------------------------------- cleaning

def clean_mesh(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                     CleanReport]:
    """Weld seam-split vertices, drop degenerate triangles and make the winding consistent (trimesh).

    Args:
        vertices: (N, 3) mesh units. faces: (F, 3) int.

    Returns:
        (faces_kept, face_index, welded_normals, report): ``faces_kept`` (F', 3) still index the
        *unwelded* vertices (UV seams kept) with consistent winding; ``face_index`` (F',) are their
        indices in ``faces``; ``welded_normals`` (N, 3) smooth unit vertex normals, equal for all
        vertices sharing a position.
    """
    import trimesh

    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    report = CleanReport(vertices=len(vertices), faces=len(faces))
    extent = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 1.0
    digits = max(0, int(-np.floor(np.log10(max(extent, 1e-12)))) + 7)
    _, inverse = trimesh.grouping.unique_rows(vertices, digits=digits)
    welded_count = int(inverse.max()) + 1 if len(inverse) else 0
    report.welded_vertices = len(vertices) - welded_count
    welded_faces = inverse[faces]
    tri = vertices[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    repeated = ((welded_faces[:, 0] == welded_faces[:, 1]) | (welded_faces[:, 1] == welded_faces[:, 2])
                | (welded_faces[:, 0] == welded_faces[:, 2]))
    keep = (area > (extent * 1e-9) ** 2) & ~repeated
    report.degenerate_faces = int((~keep).sum())
    face_index = np.nonzero(keep)[0]
    if len(face_index) == 0:
        raise AtlasError("the mesh has no non-degenerate triangles")
    welded_vertices = np.zeros((welded_count, 3))
    welded_vertices[inverse] = vertices
    mesh = trimesh.Trimesh(welded_vertices, welded_faces[face_index], process=False)
    before = mesh.faces.copy()
    trimesh.repair.fix_normals(mesh, multibody=True)
    after = np.asarray(mesh.faces)
    flipped = ~np.all(before == after, axis=1)
    report.flipped_faces = int(flipped.sum())
    report.flipped = flipped
    kept = faces[face_index].copy()
    kept[flipped] = kept[flipped][:, [0, 2, 1]]
    report.components = int(len(mesh.split(only_watertight=False))) if len(mesh.faces) < 500_000 else 1
    report.watertight = bool(mesh.is_watertight)
    wn = np.asarray(mesh.vertex_normals, dtype=np.float64)
    normals = wn[inverse]
    bad = ~np.isfinite(normals).all(axis=1) | (np.linalg.norm(normals, axis=1) < 0.5)
    normals[bad] = (0.0, 0.0, 1.0)
    return kept, face_index, normals, report


# ---------------------------------------------------------------------------------------------- UV check

def uv_charts(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, int]:
    """Chart id per triangle: triangles sharing a (UV-split) vertex belong to the same chart."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    f = np.asarray(faces, dtype=np.int64)
    rows = np.concatenate([f[:, 0], f[:, 1]])
    cols = np.concatenate([f[:, 1], f[:, 2]])
    graph = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(n_vertices, n_vertices))
    count, labels = connected_components(graph, directed=False)
    used, chart = np.unique(labels[f[:, 0]], return_inverse=True)
    return chart.astype(np.int32), len(used)


def coverage_count(tri: np.ndarray, width: int, height: int) -> np.ndarray:
    """How many triangles strictly contain each pixel centre (int32 (H, W)); shared edges count once
    (points within a tiny tolerance of an edge count for neither triangle).
    """
    count = np.zeros(height * width, dtype=np.int32)
    for tri_idx, rows, cols in iter_candidates(tri, width, height):
        bc = barycentric(tri, tri_idx, cols + 0.5, rows + 0.5)
        inside = np.all(bc > 1e-9, axis=1)
        np.add.at(count, rows[inside] * width + cols[inside], 1)
    return count.reshape(height, width)


def check_uvs(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray,
              resolution: int = CHECK_RESOLUTION) -> tuple[UVCheck, np.ndarray, float]:
    """Validate a mesh's own UVs for painting (see :class:`UVCheck`).

    Returns (check, chart_of_face, utilisation).
    """
    uv = np.asarray(uv, dtype=np.float64)
    out = int(np.sum(np.any((uv < -1e-6) | (uv > 1 + 1e-6), axis=1)))
    t = uv[faces]
    signed = 0.5 * ((t[:, 1, 0] - t[:, 0, 0]) * (t[:, 2, 1] - t[:, 0, 1])
                    - (t[:, 2, 0] - t[:, 0, 0]) * (t[:, 1, 1] - t[:, 0, 1]))
    flat_uv = np.abs(signed) < 1e-14
    degenerate = int(np.sum(flat_uv))
    p = np.asarray(vertices, dtype=np.float64)[faces]
    area3 = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    degenerate_fraction = float(area3[flat_uv].sum() / max(area3.sum(), 1e-300))
    chart, n_charts = uv_charts(faces, len(uv))
    # Orientation per chart: the majority sign of the UV area; minority triangles are folds.
    pos = np.bincount(chart, weights=(signed > 0).astype(float), minlength=n_charts)
    neg = np.bincount(chart, weights=(signed < 0).astype(float), minlength=n_charts)
    major = np.where(pos >= neg, 1.0, -1.0)
    mirrored_faces = int(np.sum(np.sign(signed) == -major[chart]))
    # Charts oriented against the majority of charts are mirrored (valid if they overlap nothing).
    mirrored_charts = int(min(np.sum(major > 0), np.sum(major < 0)))
    tri = t * np.array([resolution, resolution], dtype=np.float64)
    count = coverage_count(tri, resolution, resolution)
    covered = int(np.sum(count > 0))
    overlapping = int(np.sum(count > 1))
    utilisation = covered / float(resolution * resolution)
    reasons = []
    if out:
        reasons.append(f"{out} UVs outside [0, 1]")
    if degenerate_fraction > MAX_DEGENERATE_AREA_FRACTION:
        reasons.append(f"{degenerate} triangles with zero UV area ({degenerate_fraction:.2%} of the surface)")
    if overlapping > MAX_OVERLAP_FRACTION * max(covered, 1):
        reasons.append(f"overlapping UVs ({overlapping} of {covered} texels covered twice at "
                       f"{resolution}², e.g. mirrored or stacked charts)")
    if mirrored_faces:
        reasons.append(f"{mirrored_faces} folded (mirrored) triangles inside charts")
    check = UVCheck(valid=not reasons, reason="; ".join(reasons), out_of_range=out, degenerate=degenerate,
                    overlapping_texels=overlapping, mirrored_faces=mirrored_faces,
                    mirrored_charts=mirrored_charts, charts=n_charts)
    return check, chart, utilisation


# ---------------------------------------------------------------------------------------------- layout

def build_layout(head: Any, progress: ProgressCallback | None = None, force_unwrap: bool = False,
                 check_resolution: int = CHECK_RESOLUTION) -> UVLayout:
    """Clean the head's mesh and choose its paint UVs: the file's own when :func:`check_uvs` accepts them
    (and ``force_unwrap`` is False), otherwise an xatlas unwrap.

    ``head`` needs ``vertices``, ``faces``, ``uv`` and ``mm_per_unit`` (a :class:`painting.head.Head`).
    """
    report = progress or (lambda stage, fraction: None)
    uv = np.asarray(head.uv, dtype=np.float64)
    cache = _prep_cache_path(head.vertices, head.faces, uv, check_resolution)
    cached = _load_prep(cache)
    if cached is not None:
        for stage in ("clean", "check"):
            report(stage, 0.0)
            report(stage, 1.0)
        faces, face_index, normals, clean, check, chart, utilisation = cached
    else:
        report("clean", 0.0)
        faces, face_index, normals, clean = clean_mesh(head.vertices, head.faces)
        report("clean", 1.0)
        report("check", 0.0)
        check, chart, utilisation = check_uvs(head.vertices, faces, uv, check_resolution)
        report("check", 1.0)
        _save_prep(cache, faces, face_index, normals, clean, check, chart, utilisation)
    mm = float(getattr(head, "mm_per_unit", 1.0))
    if check.valid and not force_unwrap:
        return UVLayout(vertices=np.asarray(head.vertices, dtype=np.float64), faces=faces, uv=uv,
                        normals=normals, vertex_map=np.arange(len(head.vertices), dtype=np.int64),
                        face_map=face_index.astype(np.int64), chart_of_face=chart, charts=check.charts,
                        source="mesh", utilisation=utilisation, check=check, clean=clean, mm_per_unit=mm)
    return unwrap(np.asarray(head.vertices, dtype=np.float64), faces, face_index, normals, check, clean, mm,
                  report, check_resolution)


#: Bump when :func:`clean_mesh` or :func:`check_uvs` give different results for the same mesh.
_PREP_CACHE_VERSION = 1
_CLEAN_INTS = ("vertices", "faces", "welded_vertices", "degenerate_faces", "flipped_faces", "components")
_CHECK_INTS = ("out_of_range", "degenerate", "overlapping_texels", "mirrored_faces", "mirrored_charts", "charts")


def _prep_cache_path(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray, check_resolution: int) -> Path:
    """Where :func:`clean_mesh` + :func:`check_uvs` results for this mesh are cached (beside the atlas
    cache, keyed by the SHA-256 of the mesh arrays and the check resolution).
    """
    h = hashlib.sha256()
    for arr, dtype in ((vertices, np.float64), (faces, np.int64), (uv, np.float64)):
        a = np.ascontiguousarray(arr, dtype=dtype)
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return cache_dir().parent / "layout" / f"{h.hexdigest()[:32]}-c{int(check_resolution)}-v{_PREP_CACHE_VERSION}.npz"


def _save_prep(path: Path, faces: np.ndarray, face_index: np.ndarray, normals: np.ndarray, clean: CleanReport,
               check: UVCheck, chart: np.ndarray, utilisation: float) -> None:
    from core.atomicio import atomic_write_bytes

    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        buf = io.BytesIO()
        flipped = clean.flipped if clean.flipped is not None else np.zeros(len(faces), dtype=bool)
        np.savez(buf, faces=faces, face_index=face_index, normals=normals, chart=chart, flipped=flipped,
                 utilisation=float(utilisation), watertight=bool(clean.watertight), valid=bool(check.valid),
                 reason=np.array(check.reason), clean_ints=np.array([getattr(clean, k) for k in _CLEAN_INTS]),
                 check_ints=np.array([getattr(check, k) for k in _CHECK_INTS]))
        atomic_write_bytes(path, buf.getvalue())
    except OSError:
        pass  # the cache is an optimisation only


def _load_prep(path: Path) -> tuple[Any, ...] | None:
    """The cached (faces, face_index, normals, clean, check, chart, utilisation), or None."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as d:
            faces, face_index, normals = d["faces"], d["face_index"], d["normals"]
            chart, flipped = d["chart"], d["flipped"]
            ci, ki = [int(x) for x in d["clean_ints"]], [int(x) for x in d["check_ints"]]
            clean = CleanReport(**dict(zip(_CLEAN_INTS, ci)), watertight=bool(d["watertight"]), flipped=flipped)
            check = UVCheck(valid=bool(d["valid"]), reason=str(d["reason"]), **dict(zip(_CHECK_INTS, ki)))
            utilisation = float(d["utilisation"])
    except Exception:  # a truncated or stale cache file: compute again
        return None
    n = len(face_index)
    ok = (faces.dtype == np.int64 and faces.shape == (n, 3) and face_index.dtype == np.int64
          and normals.dtype == np.float64 and normals.ndim == 2 and chart.dtype == np.int32
          and chart.shape == (n,) and flipped.dtype == bool and flipped.shape == (n,)
          and len(ci) == len(_CLEAN_INTS) and len(ki) == len(_CHECK_INTS))
    return (faces, face_index, normals, clean, check, chart, utilisation) if ok else None


def unwrap(vertices: np.ndarray, faces: np.ndarray, face_index: np.ndarray, normals: np.ndarray,
           check: UVCheck, clean: CleanReport, mm_per_unit: float, progress: ProgressCallback,
           check_resolution: int = CHECK_RESOLUTION) -> UVLayout:
    """Unwrap with xatlas (charts packed with padding) and keep the map from new to original vertices.

    xatlas's Python binding has no progress hook, so ``progress("unwrap", f)`` is called at the start,
    after chart generation and packing, and at the end.
    """
    import xatlas

    progress("unwrap", 0.0)
    # Unwrap the welded mesh so charts are not cut along the file's old UV seams.
    import trimesh

    extent = float(np.ptp(vertices, axis=0).max())
    digits = max(0, int(-np.floor(np.log10(max(extent, 1e-12)))) + 7)
    _, inverse = trimesh.grouping.unique_rows(vertices, digits=digits)
    welded = np.zeros((int(inverse.max()) + 1, 3))
    welded[inverse] = vertices
    first_original = np.full(len(welded), -1, dtype=np.int64)
    first_original[inverse[::-1]] = np.arange(len(vertices))[::-1]
    wfaces = inverse[faces]
    atlas = xatlas.Atlas()
    atlas.add_mesh(welded.astype(np.float32), wfaces.astype(np.uint32))
    chart_options = xatlas.ChartOptions()
    pack_options = xatlas.PackOptions()
    pack_options.resolution = 2048
    pack_options.padding = 8  # texels at 2048²: room for DEFAULT_PADDING at 1024² and above
    pack_options.bilinear = True
    progress("unwrap", 0.1)
    try:
        atlas.generate(chart_options, pack_options)
    except Exception as exc:  # xatlas raises RuntimeError on broken input
        raise AtlasError(f"xatlas could not unwrap the mesh: {exc}") from None
    progress("unwrap", 0.8)
    vmapping, indices, new_uv = atlas[0]
    vmapping = np.asarray(vmapping, dtype=np.int64)
    new_faces = np.asarray(indices, dtype=np.int64).reshape(-1, 3)
    new_uv = np.asarray(new_uv, dtype=np.float64)
    vertex_map = first_original[vmapping]
    try:
        _, chart_of_vertex = atlas.get_mesh_vertex_assignment(0)
        chart = np.asarray(chart_of_vertex, dtype=np.int64)[new_faces[:, 0]].astype(np.int32)
        n_charts = int(atlas.chart_count)
    except Exception:  # older bindings: derive charts from connectivity
        chart, n_charts = uv_charts(new_faces, len(new_uv))
    new_check, _, utilisation = check_uvs(vertices[vertex_map], new_faces, new_uv, check_resolution)
    progress("unwrap", 1.0)
    return UVLayout(vertices=vertices[vertex_map], faces=new_faces, uv=new_uv, normals=normals[vertex_map],
                    vertex_map=vertex_map, face_map=face_index.astype(np.int64), chart_of_face=chart,
                    charts=n_charts, source="xatlas", utilisation=utilisation, check=check, clean=clean,
                    mm_per_unit=mm_per_unit)


# ---------------------------------------------------------------------------------------------- bake

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
    _index: Any = field(default=None, repr=False)
    _has_pad: np.ndarray | None = field(default=None, repr=False)
    _cache_path: Path | None = field(default=None, repr=False)  # the bake's cache file, if any

    @property
    def shape(self) -> tuple[int, int]:
        return (self.resolution, self.resolution)

    @property
    def tiles(self) -> tuple[int, int]:
        """Number of 64² tiles (rows, columns)."""
        return (self.resolution // TILE, self.resolution // TILE)

    @property
    def index(self) -> Any:
        """The texel spatial index (:class:`painting.spatial.TexelIndex`), built on first use and kept on
        disk beside a cached bake (building it takes about 2 s at 2048², reading it 0.1 s).
        """
        if self._index is None:
            from painting.spatial import TexelIndex

            folder = (None if self._cache_path is None
                      else self._cache_path.with_name(f"{self._cache_path.name}.index-v{_INDEX_CACHE_VERSION}"))
            count = int(np.count_nonzero(self.coverage))
            index = TexelIndex.load(folder, count) if folder is not None else None
            if index is None:
                index = TexelIndex.build(self)
                if folder is not None:
                    shutil.rmtree(folder, ignore_errors=True)  # a damaged copy, if any
                    index.save(folder)
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
    """Where baked atlases are cached: ``$SHEER_CACHE_DIR`` or ``$XDG_CACHE_HOME/sheer/atlas``
    (default ``~/.cache/sheer/atlas``).
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
    path = cache_dir() / f"{layout.key}-{res}-p{padding}-v{_CACHE_VERSION}"
    if cache and res >= 512 and path.is_dir():
        try:
            atlas = _load_cached(path, layout.mm_per_unit)
            atlas._cache_path = path
            report("bake", 1.0)
            return atlas
        except Exception:  # a truncated or stale cache: bake again, and write it anew
            shutil.rmtree(path, ignore_errors=True)
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
    position = np.zeros((res * res, 3), dtype=np.float32)
    normal = np.zeros((res * res, 3), dtype=np.float32)
    ncomp = []
    for axis in range(3):
        vcol = np.ascontiguousarray(layout.vertices[:, axis])
        ncol = np.ascontiguousarray(layout.normals[:, axis])
        position[cov_flat, axis] = sum(weights[k] * vcol[corner[k]] for k in range(3))
        ncomp.append(sum(weights[k] * ncol[corner[k]] for k in range(3)))
    length = np.sqrt(ncomp[0] ** 2 + ncomp[1] ** 2 + ncomp[2] ** 2)
    np.maximum(length, 1e-12, out=length)
    for axis in range(3):
        normal[cov_flat, axis] = ncomp[axis] / length
    del ncomp, weights, corner
    position = position.reshape(res, res, 3)
    normal = normal.reshape(res, res, 3)
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
    if cache and res >= 512:
        _save_cached(path, atlas)
        if path.is_dir():
            atlas._cache_path = path
    return atlas


def _padding_sources(covered: np.ndarray, padding: int) -> tuple[np.ndarray, np.ndarray]:
    """Uncovered texels within ``padding`` texels (Euclidean, centre to centre) of a covered one, and
    their nearest covered texel: (dst, src) flat indices sorted by src.

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


#: The atlas cache keeps its newest files within this many bytes.
CACHE_LIMIT_BYTES = 3 * 1024**3


def _save_cached(path: Path, atlas: Atlas) -> None:
    """Write ``atlas`` as a folder of ``.npy`` files (no zip: reading a 2048² bake from a ``.npz``
    spent half its second on decompressing nothing and checking CRCs), made atomically: a sibling
    folder renamed into place.
    """
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        if path.exists():
            return
        tmp.mkdir(parents=True, exist_ok=True)
        np.save(tmp / "meta.npy", np.array([atlas.resolution, atlas.padding, atlas.texel_mm], dtype=np.float64))
        for k in _FIELDS:
            np.save(tmp / f"{k}.npy", getattr(atlas, k), allow_pickle=False)
        os.replace(tmp, path)
        _prune_cache(path.parent, keep=path)
    except OSError:
        pass  # the cache is an optimisation only
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def _folder_bytes(folder: Path) -> int:
    return sum(f.stat().st_size for f in folder.glob("*.npy"))


def _prune_cache(folder: Path, keep: Path) -> None:
    """Delete the oldest cached atlases beyond :data:`CACHE_LIMIT_BYTES` (never ``keep``), each with its
    spatial index.
    """
    bakes = sorted((d for d in folder.glob(f"*-v{_CACHE_VERSION}") if d.is_dir()),
                   key=lambda d: d.stat().st_mtime, reverse=True)
    total = 0
    for d in bakes:
        total += _folder_bytes(d)
        if total > CACHE_LIMIT_BYTES and d != keep:
            shutil.rmtree(d, ignore_errors=True)
            for index in folder.glob(f"{d.name}.index-v*"):
                shutil.rmtree(index, ignore_errors=True)


def _load_cached(path: Path, mm_per_unit: float) -> Atlas:
    with contextlib.suppress(OSError):
        os.utime(path)  # most recently used: pruned last
    meta = np.load(path / "meta.npy", allow_pickle=False)
    values = {k: np.load(path / f"{k}.npy", allow_pickle=False) for k in _FIELDS}
    res = int(meta[0])
    for k in ("position", "normal"):
        if values[k].shape != (res, res, 3):
            raise ValueError(f"cached {k} has shape {values[k].shape}")
    for k in ("face", "chart", "coverage", "padded"):
        if values[k].shape != (res, res):
            raise ValueError(f"cached {k} has shape {values[k].shape}")
    return Atlas(resolution=res, padding=int(meta[1]), texel_mm=float(meta[2]), mm_per_unit=mm_per_unit, **values)
