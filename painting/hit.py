"""Picking the painted surface: from a camera ray (trimesh's ray queries) or from a depth-buffer value.

Both give a :class:`Hit` on the document's paint layout (mesh units). The depth path lets the studio
pick from the GPU depth buffer it already has: ``depth_hit`` unprojects (NDC x, y, depth) with the
inverse view-projection matrix and snaps the point to the nearest surface triangle.

Conventions (:mod:`core.camera`'s, where the view and projection matrices are made): matrices are 4×4
numpy arrays acting on column vectors (``clip = P @ V @ [x, y, z, 1]``), OpenGL clip space (NDC z in
[-1, 1]); a depth-buffer value ``d`` in [0, 1] is NDC ``z = 2d − 1`` (the default ``glDepthRange(0, 1)``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from core.errors import SheerError
from painting.layer import as_vec3

if TYPE_CHECKING:
    import trimesh
    from numpy.typing import ArrayLike

    from painting.head import Head
    from painting.layout import UVLayout


class PickError(SheerError, ValueError):
    """Bad picking input (non-finite ray, zero direction, singular matrix…)."""


@dataclass(frozen=True)
class Hit:
    """A point on the surface.

    Attributes:
        face: triangle of the paint layout (``doc.layout.faces``); ``head_face`` the head's triangle.
        barycentric: (3,) weights of the triangle's corners.
        point: (3,) mesh units. uv: (2,) paint-atlas UV. normal: (3,) unit, smooth (interpolated).
        distance: along the ray (mesh units; for depth picks, from the unprojected point to the surface).
    """

    face: int
    head_face: int
    barycentric: np.ndarray
    point: np.ndarray
    uv: np.ndarray
    normal: np.ndarray
    distance: float


class PickTarget(Protocol):
    """What picking needs from a document (:class:`painting.document.Document` is the one)."""

    #: the paint layout picked on
    layout: UVLayout

    @property
    def pick_mesh(self) -> trimesh.Trimesh:
        """The layout as a mesh (built on the first pick and kept: its ray structures are reused)."""
        ...

    @property
    def mm_per_unit(self) -> float:
        """Millimetres per mesh unit of the head."""
        ...


def make_hit(doc: PickTarget, face: int, point: np.ndarray, distance: float) -> Hit:
    """A :class:`Hit` for ``point`` on layout triangle ``face``."""
    import trimesh

    layout = doc.layout
    corners = layout.faces[face]
    tri = layout.vertices[corners]
    bary = trimesh.triangles.points_to_barycentric(tri[None], np.asarray(point, dtype=np.float64)[None])[0]
    bary = np.clip(bary, 0.0, None)
    bary = bary / max(float(bary.sum()), 1e-300)
    uv = bary @ layout.uv[corners]
    n = bary @ layout.normals[corners]
    n = n / max(float(np.linalg.norm(n)), 1e-300)
    return Hit(face=int(face), head_face=int(layout.face_map[face]), barycentric=bary,
               point=np.asarray(point, dtype=np.float64), uv=uv, normal=n, distance=float(distance))


def ray_hit(doc: PickTarget, origin: ArrayLike, direction: ArrayLike) -> Hit | None:
    """The first surface hit of the ray ``origin + t·direction`` (t ≥ 0, mesh units), or None."""
    o = as_vec3(origin, "ray origin", PickError)
    d = as_vec3(direction, "ray direction", PickError)
    norm = float(np.linalg.norm(d))
    if norm == 0:
        raise PickError("ray direction must not be zero")
    d = d / norm
    mesh = doc.pick_mesh
    locations, _, tri = mesh.ray.intersects_location(o[None], d[None], multiple_hits=True)
    if len(tri) == 0:
        return None
    t = (locations - o) @ d
    ok = t >= 0
    if not np.any(ok):
        return None
    k = int(np.argmin(np.where(ok, t, np.inf)))
    return make_hit(doc, int(tri[k]), locations[k], float(t[k]))


def unproject(ndc_xy: ArrayLike, depth: float, inv_view_proj: ArrayLike) -> np.ndarray:
    """World point (mesh units) of NDC (x, y) in [-1, 1]² and depth-buffer value ``depth`` in [0, 1]."""
    xy = np.asarray(ndc_xy, dtype=np.float64).reshape(-1)
    m = np.asarray(inv_view_proj, dtype=np.float64)
    if xy.shape != (2,) or not np.all(np.isfinite(xy)):
        raise PickError(f"NDC position must be 2 finite numbers, got {ndc_xy!r}")
    if m.shape != (4, 4) or not np.all(np.isfinite(m)):
        raise PickError("inverse view-projection must be a finite 4×4 matrix")
    d = float(depth)
    if not np.isfinite(d) or not 0.0 <= d <= 1.0:
        raise PickError(f"depth must be in [0, 1], got {depth!r}")
    clip = m @ np.array([xy[0], xy[1], 2.0 * d - 1.0, 1.0])
    if abs(clip[3]) < 1e-300:
        raise PickError("the point unprojects to infinity (w = 0)")
    return clip[:3] / clip[3]


def pixel_to_ndc(px: float, py: float, width: int, height: int) -> tuple[float, float]:
    """NDC of the centre of pixel (column ``px``, row ``py`` counted from the *top*), each in [-1, 1].

    For a row read with ``glReadPixels`` (bottom first) pass ``height − 1 − row``.
    """
    return (2.0 * (px + 0.5) / width - 1.0, 1.0 - 2.0 * (py + 0.5) / height)


def depth_hit(doc: PickTarget, ndc_xy: ArrayLike, depth: float, inv_view_proj: ArrayLike,
              max_distance_mm: float = 2.0) -> Hit | None:
    """Pick from a depth-buffer value: unproject, then snap to the nearest surface point.

    None for the far plane (depth 1) or when the point is farther than ``max_distance_mm`` from the
    surface.
    """
    import trimesh

    if float(depth) >= 1.0:
        return None
    p = unproject(ndc_xy, depth, inv_view_proj)
    closest, dist, tri = trimesh.proximity.closest_point(doc.pick_mesh, p[None])
    if float(dist[0]) * float(doc.mm_per_unit) > max_distance_mm:
        return None
    return make_hit(doc, int(tri[0]), closest[0], float(dist[0]))


def albedo_colour_at(doc: PickTarget, head: Head, point: ArrayLike, radius_texels: int = 4) -> np.ndarray:
    """The head's diffuse colour (linear sRGB, 3 floats in [0, 1]) at a surface point (mesh units).

    The median of the albedo over a (2·``radius_texels`` + 1)² window of the head's texture around the
    point's UV (about 2 mm on the sample head's 1024² albedo): pores, hairs and freckles do not decide it.
    White when the head has no albedo.

    Raises:
        PickError: the point is not a finite 3-vector.
    """
    import trimesh

    from km.srgb import srgb_decode

    p = as_vec3(point, "point", PickError)
    if head.albedo is None:
        return np.ones(3)
    _, _, tri = trimesh.proximity.closest_point(doc.pick_mesh, p[None])
    hit = make_hit(doc, int(tri[0]), p, 0.0)
    corners = np.asarray(head.faces)[hit.head_face]
    u, v = hit.barycentric @ np.asarray(head.uv, dtype=np.float64)[corners]
    a = np.asarray(head.albedo)
    h, w = a.shape[:2]
    x, y = int(np.clip(u * w, 0, w - 1)), int(np.clip(v * h, 0, h - 1))  # row 0 = v 0, as every map here
    r = int(radius_texels)
    patch = a[max(y - r, 0):y + r + 1, max(x - r, 0):x + r + 1, :3].reshape(-1, 3).astype(np.float64)
    return np.asarray(srgb_decode(np.median(patch, axis=0) / 255.0), dtype=np.float64)
