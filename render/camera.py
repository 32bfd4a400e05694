"""Orbit camera: yaw, pitch (degrees) and distance (mesh units) around a target; perspective projection.

Matrices are float64 4×4 for column vectors (``clip = P @ V @ p``), built by :mod:`core.camera` (its
docstring states the conventions); upload them with ``.T.astype('f4').tobytes()`` (GLSL reads
column-major, i.e. the transpose of numpy's row-major bytes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from core.camera import look_at, perspective


@dataclass
class OrbitCamera:
    """An orbit camera.

    Attributes:
        yaw: degrees about +Y; 0 looks at the face (+Z side) head-on, positive turns to the subject's left.
        pitch: degrees above the horizontal plane through the target.
        distance: eye-target distance, mesh units.
        fov_y: vertical field of view, degrees.
        target: orbit centre, mesh units.
        near, far: clip planes, mesh units.
    """

    yaw: float = 0.0
    pitch: float = 0.0
    distance: float = 10.0
    fov_y: float = 30.0
    target: np.ndarray = field(default_factory=lambda: np.zeros(3))
    near: float = 0.1
    far: float = 100.0

    def eye(self) -> np.ndarray:
        """Camera position, mesh units."""
        y, p = math.radians(self.yaw), math.radians(self.pitch)
        d = np.array([math.cos(p) * math.sin(y), math.sin(p), math.cos(p) * math.cos(y)])
        return np.asarray(self.target, dtype=float) + self.distance * d

    def view(self) -> np.ndarray:
        """The 4×4 view matrix (world → eye, column vectors, float64), +Y up."""
        return look_at(self.eye(), np.asarray(self.target, dtype=float), np.array([0.0, 1.0, 0.0]))

    def projection(self, aspect: float) -> np.ndarray:
        """The 4×4 perspective projection for ``aspect`` = width / height (> 0), float64.

        The clip planes widen with the distance (near ≥ 5 %, far ≥ 4× of it), so zooming out never clips.
        """
        near = max(self.near, self.distance * 0.05)
        far = max(self.far, self.distance * 4.0)
        return perspective(self.fov_y, aspect, near, far)

    def view_projection(self, aspect: float) -> np.ndarray:
        """Projection × view for ``aspect`` = width / height (4×4 float64, column vectors)."""
        return self.projection(aspect) @ self.view()

    def frame(self, centre: np.ndarray, radius: float, margin: float = 1.15) -> None:
        """Aim at ``centre`` from far enough that a sphere of ``radius`` (mesh units) fills the view."""
        self.target = np.asarray(centre, dtype=float)
        self.distance = margin * radius / math.sin(math.radians(self.fov_y) / 2.0)

    @classmethod
    def for_face(cls, head_vertices: np.ndarray, landmarks: dict[str, tuple[float, float, float]] | None = None,
                 fov_y: float = 30.0) -> OrbitCamera:
        """A camera framing the face: the landmarks' box if any, else the top 45 % of the mesh."""
        cam = cls(fov_y=fov_y)
        v = np.asarray(head_vertices, dtype=float)
        pts = np.array(list(landmarks.values()), dtype=float) if landmarks and len(landmarks) >= 3 else None
        if pts is not None:
            centre = (pts.min(0) + pts.max(0)) / 2.0
            radius = 1.3 * float(np.linalg.norm(pts.max(0) - pts.min(0))) / 2.0
        else:
            lo, hi = v.min(0), v.max(0)
            top = v[v[:, 1] > hi[1] - 0.45 * (hi[1] - lo[1])]
            tlo, thi = top.min(0), top.max(0)
            centre = (tlo + thi) / 2.0
            centre[2] = (tlo[2] + thi[2]) / 2.0
            radius = 0.5 * float(max(thi[0] - tlo[0], thi[1] - tlo[1]))
        cam.frame(centre, radius)
        return cam
