"""Transfer a document's layers from one head to another by surface correspondence.

A painted look lives in head A's paint UV space; head B (another scan, or a person's own face captured
in the canonical face-mesh topology) has other UVs and another shape. The transfer:

1. **Landmark warp** (:class:`LandmarkWarp`): the named landmarks both heads' sidecars share (``chin``,
   ``nose_tip``, eye and mouth corners…) fit a thin-plate spline with an affine part
   (``scipy.interpolate.RBFInterpolator``) from B's space onto A's, in millimetres (each head's
   ``mm_per_unit``). Landmarks that coincide on either head (e.g. the canonical face's ``chin`` and
   ``gnathion`` if both were vertex 152) are dropped, as they would make the spline singular.
2. **Closest point** (:class:`Correspondence`): every covered texel of B's atlas is warped into A's space
   and snapped to A's surface (the closest point on the nearest few of A's triangles, found through a
   k-d tree over A's texels); its barycentric coordinates there give a UV on A. A texel with no
   counterpart — farther than ``max_gap_mm`` from A's surface, snapped onto A's open border from
   beyond it, or facing more than ``max_angle_deg`` away from it (e.g. the scalp, ears and neck of a
   whole head when A is only a face) — gets nothing (zero thickness, a neutral mask).
3. **Resampling** (:meth:`Correspondence.resample`): A's map is sampled bilinearly at those UVs, using
   only the texels of the chart the UV lies in (so nothing bleeds across A's UV seams), and B's padding
   texels copy their chart's border texel, as :func:`painting.atlas.bake` does (so B's seams stay
   clean under bilinear filtering).

What moves with a layer: its thickness map (µm), its mask's paint channel, its mask recipe (by region
name, re-evaluated on B's regions; baked into the channel when B lacks one of its regions), its
material (the same library name and object), name, visibility, opacity and maximum thickness.

What never receives paint: B's **inner mouth** (:func:`inner_mouth_texels`, its ``inner_mouth`` region: on a
face mesh the triangles across the mouth's opening, which span the teeth when she smiles), so a transferred
lipstick stops at her lips' inner contour as a built-in look replayed on her does.

Units: mesh units of each head for positions, mm for distances, µm for thickness.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from core.errors import SheerError

if TYPE_CHECKING:
    from collections.abc import Callable

    from painting.atlas import Atlas
    from painting.document import Document
    from painting.head import Head
    from painting.layer import Layer

#: The fewest shared, distinct landmarks a transfer accepts (the spline's affine part needs 4 off a plane).
MIN_SHARED_LANDMARKS = 6
#: Landmarks closer than this on one head (mm) count as the same point (one of them is dropped).
DUPLICATE_LANDMARK_MM = 1.0
#: A texel whose warped position is farther than this from the other surface has no counterpart (mm).
DEFAULT_MAX_GAP_MM = 10.0
#: … or whose warped normal is more than this from the other surface's (degrees).
DEFAULT_MAX_ANGLE_DEG = 100.0
#: A texel that snaps onto the source's open border from farther than this (mm) lies beyond it.
BORDER_SLACK_MM = 0.5
#: Layers finer than this (texels per side) are put in correspondence at this resolution, then upsampled
#: bilinearly in the target's UV space (1024² on a face is ~0.25 mm per texel, finer than any brush edge;
#: the correspondence's cost grows with the texels: measured 2048² ≈ 4× 1024²).
MAX_CORRESPONDENCE_RESOLUTION = 1024
#: Candidate triangles per texel for the closest point (the triangles of the nearest source texels).
_CANDIDATES = 4
#: Resolution of the source bake whose texels index the candidate triangles.
_SEARCH_RESOLUTION = 512


class TransferError(SheerError, ValueError):
    """Two heads that cannot be put in correspondence (too few shared landmarks…); the message says why."""


# ------------------------------------------------------------------------------------------- the warp

def shared_landmarks(source: Head, target: Head) -> tuple[list[str], dict[str, str]]:
    """The landmark names both heads define and can use, and the dropped ones with why.

    A name is dropped when its point on either head lies within :data:`DUPLICATE_LANDMARK_MM` of an
    earlier kept landmark's point on that head (the first in the source sidecar's order is kept).
    """
    src, tgt = source.metadata.landmarks, target.metadata.landmarks
    kept: list[str] = []
    dropped: dict[str, str] = {}
    for name in src:
        if name not in tgt:
            continue
        for head, table in ((source, src), (target, tgt)):
            p = np.asarray(table[name], dtype=float) * head.mm_per_unit
            twin = next((k for k in kept if np.linalg.norm(np.asarray(table[k]) * head.mm_per_unit - p)
                         < DUPLICATE_LANDMARK_MM), None)
            if twin is not None:
                dropped[name] = f"the same point as '{twin}' on head '{head.name}'"
                break
        else:
            kept.append(name)
    return kept, dropped


@dataclass
class LandmarkWarp:
    """A thin-plate-spline warp (with an affine part) from the target head's space onto the source's.

    Attributes:
        names: the landmarks it was fitted on.
        dropped: landmarks both heads name that were not used, with why.
        target_mm, source_mm: millimetres per mesh unit of each head.
        loo_mm: leave-one-out error per landmark (mm): how far the warp fitted without it puts it
            from its place on the source head; a measure of how well the warp does between landmarks.
    """

    names: list[str]
    dropped: dict[str, str]
    target_mm: float
    source_mm: float
    loo_mm: dict[str, float]
    _rbf: Any = field(repr=False)

    @classmethod
    def fit(cls, source: Head, target: Head) -> LandmarkWarp:
        """Fit the warp on the landmarks ``source`` and ``target`` share.

        Raises:
            TransferError: fewer than :data:`MIN_SHARED_LANDMARKS` usable shared landmarks, or all of
                them (nearly) on one plane.
        """
        from scipy.interpolate import RBFInterpolator

        names, dropped = shared_landmarks(source, target)
        if len(names) < MIN_SHARED_LANDMARKS:
            raise TransferError(
                f"heads '{source.name}' and '{target.name}' share {len(names)} usable landmark(s) "
                f"({', '.join(names) or 'none'}); a transfer needs at least {MIN_SHARED_LANDMARKS} "
                f"(add named landmarks to the head's sidecar)")
        y = np.array([source.metadata.landmarks[n] for n in names], dtype=float) * source.mm_per_unit
        x = np.array([target.metadata.landmarks[n] for n in names], dtype=float) * target.mm_per_unit
        for pts, head in ((x, target), (y, source)):
            s = np.linalg.svd(pts - pts.mean(axis=0), compute_uv=False)
            if s[2] < 0.02 * s[0]:
                raise TransferError(f"head '{head.name}': the landmarks shared with the other head lie on one "
                                    f"plane; a transfer needs some in depth (e.g. nose_tip)")
        loo: dict[str, float] = {}
        for i, name in enumerate(names):
            keep = np.arange(len(names)) != i
            part = RBFInterpolator(x[keep], y[keep], kernel="thin_plate_spline", degree=1)
            loo[name] = float(np.linalg.norm(part(x[i:i + 1])[0] - y[i]))
        rbf = RBFInterpolator(x, y, kernel="thin_plate_spline", degree=1)
        return cls(names, dropped, float(target.mm_per_unit), float(source.mm_per_unit), loo, rbf)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Target points (N, 3), target mesh units → their warped places, source mesh units (float64)."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        out: np.ndarray = self._rbf(pts * self.target_mm) / self.source_mm
        return out

    def directions(self, points: np.ndarray, normals: np.ndarray, warped: np.ndarray | None = None,
                   step_mm: float = 1.0) -> np.ndarray:
        """Unit directions (N, 3) the warp gives the target's ``normals`` at ``points`` (finite difference).

        ``warped``: ``self(points)`` if already known.
        """
        step = step_mm / self.target_mm
        d = self(np.asarray(points) + step * np.asarray(normals)) - (self(points) if warped is None else warped)
        n = np.linalg.norm(d, axis=1, keepdims=True)
        return np.asarray(d / np.maximum(n, 1e-12))


# ------------------------------------------------------------------------------------------- correspondence

def same_paint_layout(source: Document, target: Document) -> bool:
    """Whether the two documents paint in one layout (texel i the same place of the skin on both).

    The same triangles, UVs and charts: a head fitted from another, as the full head is from the sample head.
    """
    a, b = source.layout, target.layout
    return (a.faces.shape == b.faces.shape and a.uv.shape == b.uv.shape and np.array_equal(a.faces, b.faces)
            and np.array_equal(a.uv, b.uv) and np.array_equal(a.chart_of_face, b.chart_of_face))


def _open_edges(layout: Any) -> np.ndarray:
    """Whether the edge opposite each corner of a layout triangle is on the open border: bool (F, 3).

    Vertices are welded by position first, so the layout's UV seams (split vertices) are not borders.
    """
    import trimesh

    extent = float(np.ptp(layout.vertices, axis=0).max()) or 1.0
    _, inverse = trimesh.grouping.unique_rows(layout.vertices, digits=max(0, int(-np.floor(np.log10(extent))) + 7))
    welded = np.asarray(inverse)[layout.faces]
    edges = np.sort(np.stack([welded[:, [1, 2]], welded[:, [2, 0]], welded[:, [0, 1]]], axis=1).reshape(-1, 2), axis=1)
    _, which, counts = np.unique(edges[:, 0] * (int(welded.max()) + 1) + edges[:, 1], return_inverse=True,
                                 return_counts=True)
    return np.asarray(counts[which] == 1).reshape(-1, 3)


@dataclass
class Correspondence:
    """For each covered texel of the target's bake at ``resolution``, where it lies on the source.

    Attributes:
        resolution: the target's map resolution (texels per side).
        flat: int64 (M,) flat indices of the target texels that have a counterpart.
        source_uv: float64 (M, 2) their places in the source's paint UV space.
        source_chart: int32 (M,) the source chart holding each place.
        source_point: float64 (M, 3) the places on the source surface (source mesh units).
        gap_mm: float32 (M,) distance from the warped texel to the source surface (mm).
        covered: covered texels of the target at this resolution (matched or not).
        target: the target's bake at ``resolution`` (its padding is filled on resampling).
    """

    resolution: int
    flat: np.ndarray
    source_uv: np.ndarray
    source_chart: np.ndarray
    source_point: np.ndarray
    gap_mm: np.ndarray
    covered: int
    target: Atlas = field(repr=False)

    @property
    def matched_fraction(self) -> float:
        """Fraction of the target's covered texels that have a counterpart on the source."""
        return len(self.flat) / max(self.covered, 1)

    @classmethod
    def build(cls, source: Document, target: Document, resolution: int, warp: LandmarkWarp | None = None, *,
              max_gap_mm: float = DEFAULT_MAX_GAP_MM, max_angle_deg: float = DEFAULT_MAX_ANGLE_DEG) -> Correspondence:
        """Put ``target``'s texels at ``resolution`` in correspondence with ``source``'s surface.

        ``warp`` defaults to :meth:`LandmarkWarp.fit` on the two heads.
        """
        import trimesh
        from scipy.spatial import cKDTree

        if same_paint_layout(source, target):
            return cls.identity(source, target, resolution)
        warp = warp or LandmarkWarp.fit(source.head, target.head)
        atlas = target.atlas_at(resolution)
        covered = np.flatnonzero(atlas.coverage.reshape(-1))
        points = atlas.position.reshape(-1, 3)[covered]
        q = warp(points)
        qn = warp.directions(points, atlas.normal.reshape(-1, 3)[covered], q)
        layout = source.layout
        search = source.atlas_at(_SEARCH_RESOLUTION)
        s_flat = np.flatnonzero(search.coverage.reshape(-1))
        # Bounded: a texel far from the source (a whole head's scalp when the source is a face) costs
        # nothing to reject, where an unbounded query walks much of the tree for it.
        bound = (max_gap_mm + 4.0 * search.texel_mm) / warp.source_mm
        dist, k = cKDTree(search.position.reshape(-1, 3)[s_flat]).query(q, k=_CANDIDATES, distance_upper_bound=bound)
        near = np.isfinite(dist[:, 0])
        q, qn, covered_near = q[near], qn[near], covered[near]
        k = k[near]
        k = np.where(np.isfinite(dist[near]), k, k[:, :1])
        candidates = search.face.reshape(-1)[s_flat][k]
        tris = layout.vertices[layout.faces]
        best_f = candidates[:, 0].copy()
        best_p = trimesh.triangles.closest_point(tris[best_f], q)
        best_d = np.linalg.norm(best_p - q, axis=1)
        face_n = trimesh.triangles.normals(tris[best_f])[0]
        # Where the nearest texel's triangle holds the point's orthogonal projection, that is the closest
        # point; the other candidates are tried only where it fell on the triangle's edge.
        plane_d = np.abs(np.einsum("ij,ij->i", q - tris[best_f, 0], face_n))
        edge = np.flatnonzero(best_d > plane_d + 1e-9 * float(np.ptp(layout.vertices, axis=0).max()))
        for j in range(1, candidates.shape[1]):
            rows = edge[candidates[edge, j] != best_f[edge]]
            p = trimesh.triangles.closest_point(tris[candidates[rows, j]], q[rows])
            d = np.linalg.norm(p - q[rows], axis=1)
            better = rows[d < best_d[rows]]
            keep = d < best_d[rows]
            best_d[better], best_p[better], best_f[better] = d[keep], p[keep], candidates[better, j]
        face_n = trimesh.triangles.normals(tris[best_f])[0]
        facing = np.einsum("ij,ij->i", face_n, qn) >= np.cos(np.radians(max_angle_deg))
        gap = best_d * warp.source_mm
        bary = trimesh.triangles.points_to_barycentric(tris[best_f], best_p)
        # Snapped onto the source's open border from beyond it: past the source's edge, no counterpart.
        beyond = np.any((bary < 1e-6) & _open_edges(layout)[best_f], axis=1) & (gap > BORDER_SLACK_MM)
        ok = facing & (gap <= max_gap_mm) & ~beyond
        uv = np.einsum("ij,ijk->ik", bary[ok], layout.uv[layout.faces[best_f[ok]]])
        return cls(resolution=int(resolution), flat=covered_near[ok], source_uv=uv,
                   source_chart=layout.chart_of_face[best_f[ok]].astype(np.int32), source_point=best_p[ok],
                   gap_mm=gap[ok].astype(np.float32), covered=len(covered), target=atlas)

    @classmethod
    def identity(cls, source: Document, target: Document, resolution: int) -> Correspondence:
        """Texel for texel, for heads that share one paint layout (:func:`same_paint_layout`).

        A head fitted from another (the full head, warped from the sample head onto a face) has each texel
        on the same place of the skin, whatever its shape. Every covered texel of the target is matched to
        its own texel centre on the source (a resample then copies values exactly), gap 0.
        """
        atlas = target.atlas_at(resolution)
        covered = np.flatnonzero(atlas.coverage.reshape(-1))
        rows, cols = np.divmod(covered, resolution)
        uv = np.stack([(cols + 0.5) / resolution, (rows + 0.5) / resolution], axis=1)
        source_atlas = source.atlas_at(resolution)
        return cls(resolution=int(resolution), flat=covered, source_uv=uv,
                   source_chart=atlas.chart.reshape(-1)[covered].astype(np.int32),
                   source_point=source_atlas.position.reshape(-1, 3)[covered].astype(np.float64),
                   gap_mm=np.zeros(len(covered), dtype=np.float32), covered=len(covered), target=atlas)

    def resample(self, values: np.ndarray, source_atlas: Atlas, fill: float = 0.0) -> np.ndarray:
        """A source map (R, R) or (R, R, C) at the source bake's resolution → the target's, float32.

        Bilinear within the source chart of each place (texels of other charts get no weight; the
        source's padding is refilled from its bake first); texels with no counterpart get ``fill``; the
        target's padding texels copy their source texel.
        """
        src = np.array(values, dtype=np.float32, copy=True)
        res = src.shape[0]
        if src.shape[:2] != (res, res) or res != source_atlas.resolution:
            raise TransferError(f"map is {src.shape[:2]}, the source bake is {source_atlas.resolution}²")
        channels = src.reshape(res * res, -1)
        channels[source_atlas.pad_dst] = channels[source_atlas.pad_src]
        # Hand-written bilinear rather than scipy.ndimage.map_coordinates: each of the four taps is kept
        # only when it belongs to the place's own chart (map_coordinates cannot leave texels out).
        chart = source_atlas.chart.reshape(-1)
        x = self.source_uv[:, 0] * res - 0.5
        y = self.source_uv[:, 1] * res - 0.5
        x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
        fx, fy = (x - x0)[:, None], (y - y0)[:, None]
        total = np.zeros((len(x), channels.shape[1]), dtype=np.float64)
        weight = np.zeros((len(x), 1), dtype=np.float64)
        for dy, dx, w in ((0, 0, (1 - fy) * (1 - fx)), (0, 1, (1 - fy) * fx), (1, 0, fy * (1 - fx)), (1, 1, fy * fx)):
            idx = np.clip(y0 + dy, 0, res - 1) * res + np.clip(x0 + dx, 0, res - 1)
            w = w * (chart[idx] == self.source_chart)[:, None]
            total += w * channels[idx]
            weight += w
        nearest = (np.clip(np.rint(y), 0, res - 1) * res + np.clip(np.rint(x), 0, res - 1)).astype(np.int64)
        sampled = np.where(weight > 0, total / np.maximum(weight, 1e-12), channels[nearest])
        out = np.full((self.resolution * self.resolution, channels.shape[1]), fill, dtype=np.float32)
        out[self.flat] = sampled
        out[self.target.pad_dst] = out[self.target.pad_src]
        return out.reshape((self.resolution, self.resolution, *src.shape[2:]))


# ------------------------------------------------------------------------------------------- documents

@dataclass
class TransferReport:
    """What a transfer did (figures for the user and the tests).

    Attributes:
        source_head, target_head: the heads' names.
        landmarks: the landmarks the warp used; dropped: the shared ones it did not use, with why.
        loo_median_mm, loo_max_mm: the warp's leave-one-out landmark error (mm).
        matched_fraction: fraction of the target's covered texels with a counterpart on the source
            (at the first layer's resolution).
        gap_median_mm, gap_p95_mm: distance from the warped target texels to the source surface (mm).
        layers: per layer: ``name``, ``material``, ``mask`` ("recipe", "baked", "channel" or "none").
        seconds: wall time.
    """

    source_head: str
    target_head: str
    landmarks: list[str]
    dropped: dict[str, str]
    loo_median_mm: float
    loo_max_mm: float
    matched_fraction: float = 0.0
    gap_median_mm: float = float("nan")
    gap_p95_mm: float = float("nan")
    layers: list[dict[str, str]] = field(default_factory=list)
    seconds: float = 0.0

    def summary(self) -> str:
        """One line for the user."""
        return (f"{len(self.layers)} layer(s) from '{self.source_head}' to '{self.target_head}' on "
                f"{len(self.landmarks)} landmarks (leave-one-out median {self.loo_median_mm:.1f} mm); "
                f"{self.matched_fraction:.0%} of the target's texels matched "
                f"(gap median {self.gap_median_mm:.1f} mm); {self.seconds:.1f} s")


def _mask_recipe_fits(target: Document, mask: Any) -> bool:
    """Whether every region of a mask recipe exists on the target head."""
    from painting.regions import RegionError

    try:
        for _, name in mask.regions:
            target.regions.get(name)
    except RegionError:
        return False
    return True


def upsample(values: np.ndarray, atlas: Atlas, fill: float = 0.0) -> np.ndarray:
    """A target map at a coarser resolution → the bake ``atlas``'s, float32 (bilinear at texel centres).

    Texels outside the charts and their padding get ``fill``; padding texels copy their source texel.
    """
    from painting.regions import resample as bilinear

    out = bilinear(values, atlas.resolution).reshape(-1)
    out[~(atlas.coverage | atlas.padded).reshape(-1)] = fill
    out[atlas.pad_dst] = out[atlas.pad_src]
    return out.reshape(atlas.shape)


def _move(corr: Correspondence, values: np.ndarray, source: Document, target: Document, fill: float = 0.0) -> np.ndarray:
    """A source map (its layer's resolution) onto the target at the same resolution, through ``corr``."""
    res = int(values.shape[0])
    out = corr.resample(values, source.atlas_at(res), fill)
    return out if res == corr.resolution else upsample(out, target.atlas_at(res), fill)


def inner_mouth_texels(target: Document, resolution: int) -> np.ndarray | None:
    """Bool (resolution, resolution): the texels of ``target``'s inner mouth, which no transferred layer paints.

    Its ``inner_mouth`` region (≥ 0.5: the opening and a quarter of a millimetre around it, half the
    region's feather); for a face-mesh head whose stored regions predate the region (a face folder
    captured before), the mouth opening's triangles (:func:`painting.region_shapes.mouth_opening_texels`).
    None when the head has neither.
    """
    from painting.layer import DocumentError
    from painting.region_shapes import is_face_mesh, mouth_opening_texels

    try:
        inner = target.region_values("inner_mouth", resolution) >= 0.5
    except DocumentError:
        if not (is_face_mesh(target.head) and target.layout.source == "mesh"):
            return None
        inner = mouth_opening_texels(target.head, (resolution, resolution))
    return inner if inner.any() else None


def transfer_layers(source: Document, target: Document, *, warp: LandmarkWarp | None = None,
                    max_gap_mm: float = DEFAULT_MAX_GAP_MM, max_angle_deg: float = DEFAULT_MAX_ANGLE_DEG,
                    max_resolution: int = MAX_CORRESPONDENCE_RESOLUTION,
                    progress: Callable[[str, float], None] | None = None) -> TransferReport:
    """Add every layer of ``source`` on top of ``target``'s, resampled onto the target's head.

    Each added layer is one undo step per edit on the target (clear its history if it is new). Layers
    keep their resolution; materials come from ``target.library`` by name (give the target the
    source's library to be sure they exist). Layers finer than ``max_resolution`` are put in
    correspondence at ``max_resolution`` and upsampled (:func:`upsample`).

    Raises:
        TransferError: the heads cannot be put in correspondence (see :meth:`LandmarkWarp.fit`).
        DocumentError: a material the target's library lacks (nothing is added then).
    """
    start = time.perf_counter()
    report_progress = progress or (lambda stage, fraction: None)
    report_progress("transfer", 0.0)
    warp = warp or LandmarkWarp.fit(source.head, target.head)
    loo = list(warp.loo_mm.values())
    report = TransferReport(source.head.name, target.head.name, list(warp.names), dict(warp.dropped),
                            float(np.median(loo)), float(np.max(loo)))
    for lay in source.layers:  # check every material first: a missing one changes nothing
        target.lookup_material(lay.material)
    corrs: dict[int, Correspondence] = {}
    inner_mouth: dict[int, np.ndarray | None] = {}  # by resolution
    layers = source.layers
    for i, lay in enumerate(layers):
        res = lay.resolution
        work = min(res, int(max_resolution))
        if work not in corrs:
            corrs[work] = Correspondence.build(source, target, work, warp, max_gap_mm=max_gap_mm,
                                               max_angle_deg=max_angle_deg)
        corr = corrs[work]
        new = target.add_layer(lay.material, resolution=res, name=lay.name, max_thickness=lay.max_thickness)
        thickness = np.clip(_move(corr, lay.thickness, source, target), 0.0, None)
        if res not in inner_mouth:
            inner_mouth[res] = inner_mouth_texels(target, res)
        if inner_mouth[res] is not None:
            thickness[inner_mouth[res]] = 0.0
        if np.any(thickness):
            target.set_thickness(new, thickness, detail="transfer")
        target.set_layer(new, visible=lay.visible, opacity=lay.opacity)
        report.layers.append({"name": lay.name, "material": lay.material, "mask": _transfer_mask(lay, new, corr,
                                                                                                  source, target)})
        report_progress("transfer", (i + 1) / len(layers))
    if corrs:
        first = corrs[min(layers[0].resolution, int(max_resolution))]
        report.matched_fraction = first.matched_fraction
        if len(first.gap_mm):
            report.gap_median_mm = float(np.median(first.gap_mm))
            report.gap_p95_mm = float(np.percentile(first.gap_mm, 95))
    report.seconds = time.perf_counter() - start
    report_progress("transfer", 1.0)
    return report


def _transfer_mask(lay: Layer, new: Layer, corr: Correspondence, source: Document, target: Document) -> str:
    """Give ``new`` (on the target) the mask of ``lay`` (on the source); how it went (see :class:`TransferReport`)."""
    if not lay.has_mask:
        return "none"
    from painting.mask import CHANNEL_MAX, CHANNEL_NEUTRAL

    if lay.mask is not None and not _mask_recipe_fits(target, lay.mask):
        # The target lacks a region of the recipe: carry the mask as rendered, as a channel with no recipe.
        values = source.mask_values(lay)
        assert values is not None
        channel = np.clip(_move(corr, values, source, target, CHANNEL_NEUTRAL), 0.0, 1.0)
        target.set_layer_mask(new, None, channel)
        return "baked"
    channel = None
    if lay.mask_channel is not None:
        channel = np.clip(_move(corr, lay.mask_channel, source, target, CHANNEL_NEUTRAL), 0.0, CHANNEL_MAX)
    target.set_layer_mask(new, lay.mask, channel)
    return "recipe" if lay.mask is not None else "channel"


def transfer_document(source: Document, target_head: Head, *, max_gap_mm: float = DEFAULT_MAX_GAP_MM,
                      max_angle_deg: float = DEFAULT_MAX_ANGLE_DEG,
                      max_resolution: int = MAX_CORRESPONDENCE_RESOLUTION,
                      progress: Callable[[str, float], None] | None = None,
                      **doc_kwargs: Any) -> tuple[Document, TransferReport]:
    """A new document on ``target_head`` holding ``source``'s layers, transferred (no undo history).

    ``doc_kwargs`` go to :class:`painting.document.Document` (``resolution`` defaults to the source's,
    ``library`` to the source's library, ``progress`` to ``progress``).
    """
    from painting.document import Document

    warp = LandmarkWarp.fit(source.head, target_head)  # before any bake: bad heads fail fast
    doc_kwargs.setdefault("resolution", source.resolution)
    doc_kwargs.setdefault("library", source.library)
    doc_kwargs.setdefault("progress", progress)
    target = Document(target_head, **doc_kwargs)
    report = transfer_layers(source, target, warp=warp, max_gap_mm=max_gap_mm, max_angle_deg=max_angle_deg,
                             max_resolution=max_resolution, progress=progress)
    target.clear_history()
    return target, report
