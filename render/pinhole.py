"""A photograph's pinhole camera as a render camera, optionally turned about the head.

The capture describes the photograph's camera as a :class:`core.camera.Pinhole` (K pixels, R world →
camera, t mesh units, OpenCV's convention; :class:`capture.camera.Camera`, face.json's ``camera``).
:func:`pinhole_camera` turns it into an :class:`render.camera.OrbitCamera` whose ``view``/``projection``/
``eye`` draw exactly what the photograph's camera saw (:mod:`core.camera` converts the conventions): an
image drawn with it and read back bottom row first, then flipped, lines up with the photograph pixel for
pixel (at any size of the same aspect ratio). ``yaw``/``pitch`` orbit that camera about a pivot in the
head (the relight view's "turn the face"); the lights, in head space, stay with the head.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from core.camera import GL_FROM_CV
from render.camera import OrbitCamera

if TYPE_CHECKING:
    from core.camera import Pinhole

#: Behind the nose tip, where a head turns (mm): about the distance from the nose tip to the cervical
#: spine's axis of rotation (C1/C2) in adults (~9 cm).
PIVOT_BEHIND_NOSE_MM = 90.0


def turn_pivot(vertices: np.ndarray, landmarks: dict[str, Any] | None, mm_per_unit: float) -> np.ndarray:
    """The point a head turns about, mesh units (3,).

    :data:`PIVOT_BEHIND_NOSE_MM` behind the ``nose_tip`` landmark along −z (the head's front is +z), at
    the landmarks' middle height; without a nose tip, the centre of the mesh's bounding box.
    """
    v = np.asarray(vertices, dtype=float)
    lm = landmarks or {}
    if "nose_tip" in lm:
        pts = np.array(list(lm.values()), dtype=float)
        nose = np.asarray(lm["nose_tip"], dtype=float)
        mid_y = 0.5 * (pts[:, 1].min() + pts[:, 1].max())
        return np.array([nose[0], mid_y, nose[2] - PIVOT_BEHIND_NOSE_MM / float(mm_per_unit)])
    return (v.min(0) + v.max(0)) / 2.0


def turn_matrix(yaw_deg: float, pitch_deg: float, pivot: np.ndarray) -> np.ndarray:
    """The 4×4 rigid motion that orbits a camera by ``yaw`` about +Y and ``pitch`` about +X, about ``pivot``.

    Positive yaw moves the camera towards the subject's left (+x), positive pitch upwards (+y), as
    :class:`render.camera.OrbitCamera`'s angles do.
    """
    y, p = math.radians(yaw_deg), math.radians(pitch_deg)
    ry = np.array([[math.cos(y), 0.0, math.sin(y)], [0.0, 1.0, 0.0], [-math.sin(y), 0.0, math.cos(y)]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(p), math.sin(p)], [0.0, -math.sin(p), math.cos(p)]])
    m = np.eye(4)
    m[:3, :3] = ry @ rx
    m[:3, 3] = pivot - m[:3, :3] @ pivot
    return m


def pinhole_camera(camera: Pinhole, vertices: np.ndarray, yaw: float = 0.0, pitch: float = 0.0,
                   pivot: np.ndarray | None = None) -> OrbitCamera:
    """An :class:`OrbitCamera` that renders what the pinhole ``camera`` sees, orbited by ``yaw``/``pitch``.

    Args:
        camera: the photograph's camera (K pixels of its ``width`` × ``height`` image, R, t mesh units);
            any image size of its aspect ratio renders.
        vertices: the head's vertices (N, 3), mesh units: the depth range is fitted to them.
        yaw: degrees the camera orbits about ``pivot`` about +Y (see :func:`turn_matrix`); 0 = the photograph.
        pitch: degrees it orbits about +X; 0 = the photograph.
        pivot: the orbit's centre, mesh units (default: the vertices' bounding-box centre).

    Its ``view()`` is GL's eye space (y up, looking along −z); ``eye()`` is the camera's centre (mesh
    units); ``projection(aspect)`` ignores ``aspect`` (the photograph's own); ``fov_y``, ``target`` and
    ``distance`` are set for what reads them.
    """
    v = np.asarray(vertices, dtype=float)
    if pivot is None:
        pivot = (v.min(0) + v.max(0)) / 2.0
    inv_turn = np.linalg.inv(turn_matrix(yaw, pitch, np.asarray(pivot, dtype=float)))
    world_to_cam = camera.camera_from_world() @ inv_turn
    depths = v @ world_to_cam[:3, :3].T + world_to_cam[:3, 3]
    near, far = max(1e-3, 0.5 * float(depths[:, 2].min())), 2.0 * float(depths[:, 2].max())
    view = GL_FROM_CV @ world_to_cam
    proj = camera.clip_from_eye(near, far)
    eye = (np.linalg.inv(inv_turn) @ np.r_[camera.centre, 1.0])[:3]

    class PinholeCamera(OrbitCamera):
        def eye(self) -> np.ndarray:
            return eye

        def view(self) -> np.ndarray:
            return view

        def projection(self, aspect: float) -> np.ndarray:
            return proj

    target = v.mean(axis=0)
    cam = PinholeCamera(fov_y=camera.fov_y, target=target, near=near, far=far)
    cam.distance = float(np.linalg.norm(eye - target))
    return cam
