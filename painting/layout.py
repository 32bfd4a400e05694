"""The paint layout: mesh cleaning, the check of a mesh's own UVs, and the UVs painted.

The UVs painted are the file's own when they can be painted, else an xatlas unwrap.

Units: positions in **mesh units** (as loaded, see :mod:`painting.head`); normals are unit vectors;
UVs in [0, 1] (texture space as :mod:`painting.head`: row ``i`` covers ``v ∈ [i/H, (i+1)/H)``).

Pipeline::

    layout = build_layout(head)          # clean + validate UVs (+ xatlas if needed); cached on disk
    atlas = painting.atlas.bake(layout, 2048)   # the per-texel maps (see :mod:`painting.atlas`)

What :func:`clean_mesh` and :func:`check_uvs` find is cached on disk per mesh (the ``layout`` folder of
:func:`core.cache.cache_dir`).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from core.cache import cache_dir
from core.errors import SheerError
from painting.raster import barycentric, iter_candidates

if TYPE_CHECKING:
    from pathlib import Path

    import trimesh

    from painting.head import Head

#: ``progress(stage, fraction)``: stage is "clean", "check", "unwrap" or "bake"; fraction in [0, 1].
ProgressCallback = Callable[[str, float], None]

#: Resolution at which UV overlaps are checked (independent of the layers' resolutions).
CHECK_RESOLUTION = 1024
#: A UV layout is rejected when more than this fraction of its covered texels is covered twice.
MAX_OVERLAP_FRACTION = 1e-3
#: Triangles with zero UV area are tolerated (left unpainted) while their 3D area is below this fraction.
MAX_DEGENERATE_AREA_FRACTION = 1e-3


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

    def source_uv(self, head: Head) -> np.ndarray:
        """The file's own UVs per layout triangle corner, float64 (F, 3, 2) in [0, 1].

        For textures authored on them, e.g. the albedo, when the paint layout is an xatlas unwrap;
        layout triangle ``i`` is the head's triangle ``face_map[i]``, with corners 1 and 2 swapped where
        cleaning flipped it.
        """
        corners = np.asarray(head.faces)[self.face_map]
        if self.clean.flipped is not None and self.clean.flipped.any():
            corners = corners.copy()
            corners[self.clean.flipped] = corners[self.clean.flipped][:, [0, 2, 1]]
        return np.asarray(head.uv, dtype=np.float64)[corners]

    def trimesh(self) -> trimesh.Trimesh:
        """The layout as an (unprocessed) ``trimesh.Trimesh``."""
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, vertex_normals=self.normals, process=False)


# ---------------------------------------------------------------------------------------------- cleaning

def clean_mesh(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                     CleanReport]:
    """Weld seam-split vertices, drop degenerate triangles and make the winding consistent (trimesh).

    Args:
        vertices: (N, 3) mesh units.
        faces: (F, 3) int, into ``vertices``.

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
    """How many triangles strictly contain each pixel centre (int32 (H, W)).

    ``tri``: (F, 3, 2) corners in pixels. Shared edges count once (points within a tiny tolerance of an
    edge count for neither triangle).
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

def build_layout(head: Head, progress: ProgressCallback | None = None, force_unwrap: bool = False,
                 check_resolution: int = CHECK_RESOLUTION) -> UVLayout:
    """Clean the head's mesh and choose its paint UVs.

    The file's own when :func:`check_uvs` accepts them (and ``force_unwrap`` is False), otherwise an
    xatlas unwrap.

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
    """Where :func:`clean_mesh` + :func:`check_uvs` results for this mesh are cached.

    The ``layout`` cache folder, keyed by the SHA-256 of the mesh arrays and the check resolution.
    """
    h = hashlib.sha256()
    for arr, dtype in ((vertices, np.float64), (faces, np.int64), (uv, np.float64)):
        a = np.ascontiguousarray(arr, dtype=dtype)
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return cache_dir("layout") / f"{h.hexdigest()[:32]}-c{int(check_resolution)}-v{_PREP_CACHE_VERSION}.cache"


def _save_prep(path: Path, faces: np.ndarray, face_index: np.ndarray, normals: np.ndarray, clean: CleanReport,
               check: UVCheck, chart: np.ndarray, utilisation: float) -> None:
    from core.cache import save_arrays

    flipped = clean.flipped if clean.flipped is not None else np.zeros(len(faces), dtype=bool)
    save_arrays(path, {"faces": faces, "face_index": face_index, "normals": normals, "chart": chart,
                       "flipped": flipped, "utilisation": float(utilisation), "watertight": bool(clean.watertight),
                       "valid": bool(check.valid), "reason": np.array(check.reason),
                       "clean_ints": np.array([getattr(clean, k) for k in _CLEAN_INTS]),
                       "check_ints": np.array([getattr(check, k) for k in _CHECK_INTS])}, _PREP_CACHE_VERSION)


def _load_prep(path: Path) -> tuple[Any, ...] | None:
    """The cached (faces, face_index, normals, clean, check, chart, utilisation), or None."""
    from core.cache import load_arrays

    d = load_arrays(path, _PREP_CACHE_VERSION)  # None when absent or damaged (then deleted)
    if d is None:
        return None
    try:
        faces, face_index, normals = d["faces"], d["face_index"], d["normals"]
        chart, flipped = d["chart"], d["flipped"]
        ci, ki = [int(x) for x in d["clean_ints"]], [int(x) for x in d["check_ints"]]
        clean = CleanReport(**dict(zip(_CLEAN_INTS, ci)), watertight=bool(d["watertight"]), flipped=flipped)
        check = UVCheck(valid=bool(d["valid"]), reason=str(d["reason"]), **dict(zip(_CHECK_INTS, ki)))
        utilisation = float(d["utilisation"])
    except (KeyError, TypeError, ValueError):  # an entry of another layout (same version): compute again
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
    pack_options.padding = 8  # texels at 2048²: room for painting.atlas.DEFAULT_PADDING at 1024² and above
    pack_options.bilinear = True
    # A chart longer than the atlas (a sliver triangle 1e8 times longer than wide) is scaled down to fit,
    # not packed into an atlas millions of texels long (seconds to forever, and the memory for it).
    pack_options.max_chart_size = pack_options.resolution - 2 * pack_options.padding
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
