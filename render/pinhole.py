"""A photograph's pinhole camera as a render camera, optionally turned about the head.

The capture (``capture.camera.Camera``, face.json's ``camera``) describes the photograph's camera by
K (pixels), R (world → camera) and t (mesh units), with x right, y down and z forward (OpenCV's
convention). :func:`pinhole_camera` turns that into an :class:`render.camera.OrbitCamera` whose
``view``/``projection``/``eye`` draw exactly what the photograph's camera saw: an image drawn with it
and read back bottom row first, then flipped, lines up with the photograph pixel for pixel (at any
size of the same aspect ratio). ``yaw``/``pitch`` orbit that camera about a pivot in the head (the
relight view's "turn the face"); the lights, in head space, stay with the head.

render/ may not import capture/ (they are siblings): the camera comes in as arrays.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from render.camera import OrbitCamera

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


def clip_from_camera(K: np.ndarray, width: int, height: int, near: float, far: float) -> np.ndarray:
    """GL's clip matrix (4, 4) from camera space (x right, y down, z forward) for intrinsics ``K``.

    Pixel (x, y) = (K·x_cam)[:2] / z with pixel j covering [j, j + 1): x_ndc = 2x/W − 1, y_ndc = 1 − 2y/H,
    w_clip = z, depth [``near``, ``far``] (mesh units) → [−1, 1]. Independent of the image's scale.
    """
    k = np.asarray(K, dtype=float)
    w, h = float(width), float(height)
    return np.array([
        [2 * k[0, 0] / w, 2 * k[0, 1] / w, 2 * k[0, 2] / w - 1, 0.0],
        [0.0, -2 * k[1, 1] / h, 1 - 2 * k[1, 2] / h, 0.0],
        [0.0, 0.0, (far + near) / (far - near), -2 * far * near / (far - near)],
        [0.0, 0.0, 1.0, 0.0],
    ])


def pinhole_camera(K: np.ndarray, R: np.ndarray, t: np.ndarray, width: int, height: int, vertices: np.ndarray,
                   yaw: float = 0.0, pitch: float = 0.0, pivot: np.ndarray | None = None) -> OrbitCamera:
    """An :class:`OrbitCamera` that renders what the pinhole camera (K, R, t) sees, orbited by ``yaw``/``pitch``.

    Args:
        K: (3, 3) intrinsics, pixels of a ``width`` × ``height`` image.
        R: (3, 3) rotation world → camera.
        t: (3,) translation, mesh units.
        width: the width of the image the camera was made for, pixels (any size of its aspect renders).
        height: that image's height, pixels.
        vertices: the head's vertices (N, 3), mesh units: the depth range is fitted to them.
        yaw: degrees the camera orbits about ``pivot`` about +Y (see :func:`turn_matrix`); 0 = the photograph.
        pitch: degrees it orbits about +X; 0 = the photograph.
        pivot: the orbit's centre, mesh units (default: the vertices' bounding-box centre).

    Its ``view()`` is GL's eye space (y up, looking along −z); ``eye()`` is the camera's centre (mesh
    units); ``projection(aspect)`` ignores ``aspect`` (the photograph's own); ``fov_y``, ``target`` and
    ``distance`` are set for what reads them.
    """
    v = np.asarray(vertices, dtype=float)
    rot, tr = np.asarray(R, dtype=float), np.asarray(t, dtype=float)
    if pivot is None:
        pivot = (v.min(0) + v.max(0)) / 2.0
    inv_turn = np.linalg.inv(turn_matrix(yaw, pitch, np.asarray(pivot, dtype=float)))
    world_to_cam = np.eye(4)
    world_to_cam[:3, :3], world_to_cam[:3, 3] = rot, tr
    world_to_cam = world_to_cam @ inv_turn
    depths = v @ world_to_cam[:3, :3].T + world_to_cam[:3, 3]
    near, far = max(1e-3, 0.5 * float(depths[:, 2].min())), 2.0 * float(depths[:, 2].max())
    flip = np.diag([1.0, -1.0, -1.0, 1.0])
    view = flip @ world_to_cam
    proj = clip_from_camera(K, width, height, near, far) @ np.linalg.inv(flip)
    centre_cam = -rot.T @ tr
    eye = (np.linalg.inv(inv_turn) @ np.r_[centre_cam, 1.0])[:3]

    class PinholeCamera(OrbitCamera):
        def eye(self) -> np.ndarray:
            return eye

        def view(self) -> np.ndarray:
            return view

        def projection(self, aspect: float) -> np.ndarray:
            return proj

    target = v.mean(axis=0)
    cam = PinholeCamera(fov_y=math.degrees(2 * math.atan(height / (2 * float(np.asarray(K)[1, 1])))),
                        target=target, near=near, far=far)
    cam.distance = float(np.linalg.norm(eye - target))
    return cam
