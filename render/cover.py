"""A few-triangle cover of the head for the composite: its convex hull.

The composite reads every input at its own pixel (``texelFetch`` at ``gl_FragCoord``), so it needs
geometry that covers the head's pixels, not the head itself. On llvmpipe a draw's cost grows with its
triangles (vertex processing, clipping and binning run per triangle): the head's 17.7k triangles cost the
composite about a quarter of the baseline frame, its ~1.1k-triangle convex hull a fraction of that,
although the hull covers about 30 % more pixels (they take the background branch). The convex hull
covers the head's pixels from every view outside it; :meth:`CoverMesh.usable` says when a view is not
(the eye inside the hull, or the hull reaching the near plane), and the composite then draws the head.

The hull is computed with scipy (Qhull) and kept in the render cache (the import alone takes about half
a second): :func:`load_cover` returns the cached hull, :func:`compute_cover` makes and stores it.
"""

from __future__ import annotations

import hashlib
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from pathlib import Path

    import moderngl

#: the cache entry's version (bump when the hull's arrays change meaning)
_VERSION = 1
#: depth (mesh units, in front of the near plane) the hull must keep, as a fraction of the near distance
_NEAR_MARGIN = 0.01


def _cache_path(vertices: np.ndarray) -> Path:
    from core.cache import cache_dir

    key = hashlib.sha256(np.ascontiguousarray(vertices, dtype="<f4").tobytes()).hexdigest()[:32]
    return cache_dir("render") / f"hull-{key}-v{_VERSION}.cache"


def compute_cover(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The convex hull of ``vertices`` (N, 3, mesh units), stored in the render cache.

    Returns:
        (points (M, 3) float32, faces (F, 3) uint32 indexing points, wound counter-clockwise seen from
        outside, as the head's front faces).
    """
    from scipy.spatial import ConvexHull

    v = np.asarray(vertices, np.float64)
    hull = ConvexHull(v)
    used = np.unique(hull.simplices)
    remap = np.full(len(v), -1, np.int64)
    remap[used] = np.arange(len(used))
    faces = remap[hull.simplices]
    points = v[used]
    # Qhull's simplices have no consistent winding: face each away from the hull's inside
    centre = points.mean(axis=0)
    n = np.cross(points[faces[:, 1]] - points[faces[:, 0]], points[faces[:, 2]] - points[faces[:, 0]])
    flip = np.einsum("ij,ij->i", n, points[faces[:, 0]] - centre) < 0
    faces[flip] = faces[flip][:, ::-1]
    out = points.astype(np.float32), faces.astype(np.uint32)
    from core.cache import save_arrays

    save_arrays(_cache_path(vertices), {"points": out[0], "faces": out[1]}, _VERSION)
    return out


def load_cover(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The cached hull of ``vertices`` (see :func:`compute_cover`), or None when it is not cached."""
    from core.cache import load_arrays

    got = load_arrays(_cache_path(vertices), _VERSION)
    if got is None or "points" not in got or "faces" not in got:
        return None
    return np.asarray(got["points"], np.float32), np.asarray(got["faces"], np.uint32)


class CoverMesh:
    """The hull on the GPU, drawn with programs that take ``in_position`` only.

    Attributes: ``points`` (M, 3) and ``faces`` (F, 3) as :func:`compute_cover` returns them.
    """

    def __init__(self, ctx: moderngl.Context, points: np.ndarray, faces: np.ndarray) -> None:
        self.ctx = ctx
        self.points = np.asarray(points, np.float64)
        self.faces = np.asarray(faces)
        tri = self.points[self.faces]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        self._normals = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
        self._offsets = np.einsum("ij,ij->i", self._normals, tri[:, 0])
        self.vbo = ctx.buffer(np.asarray(points, np.float32).tobytes())
        self.ibo = ctx.buffer(np.asarray(faces, np.uint32).tobytes())
        self._vaos: dict[int, moderngl.VertexArray] = {}

    def usable(self, eye: np.ndarray, view: np.ndarray, near: float) -> bool:
        """Whether the hull's front faces cover the head's pixels in this view.

        Args:
            eye: the camera's position (mesh units).
            view: the view matrix (4×4, column vectors; the camera looks down −z).
            near: the near plane's distance (mesh units).

        Returns:
            False when the eye is inside the hull (every face would be culled) or a hull point lies within
            the near plane's margin (a clipped front face would uncover pixels).
        """
        outside = bool(np.any(self._normals @ np.asarray(eye, float) - self._offsets > 0.0))
        depth = -(self.points @ view[2, :3] + view[2, 3])
        return outside and float(depth.min()) > near * (1.0 + _NEAR_MARGIN)

    def draw(self, program: moderngl.Program) -> None:
        """Draw the hull's triangles with ``program`` (its uniforms set by the caller)."""
        vao = self._vaos.get(program.glo)
        if vao is None:
            vao = self._vaos[program.glo] = self.ctx.vertex_array(program, [(self.vbo, "3f", "in_position")],
                                                                  self.ibo)
        vao.render()

    def release(self) -> None:
        """Free every GPU object (call with the context current)."""
        from render.glutil import release_all

        release_all(self.ctx, [*self._vaos.values(), self.vbo, self.ibo])
        self._vaos = {}
