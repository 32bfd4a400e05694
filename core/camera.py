"""The one camera: its conventions, the pinhole camera, and the matrices every view is drawn with.

Every camera in Sheer — the studio's orbit camera (:class:`render.camera.OrbitCamera`), a photograph's
camera (:class:`Pinhole`; the capture's :class:`capture.camera.Camera` is one), the shadow maps' views —
is built from the functions here, in one convention each, and the conversion between them is named once.

Conventions:

- **World** (head) space: right-handed, +y up, the face towards +z; lengths in mesh units (a head's
  ``mm_per_unit`` gives millimetres). Angles are in degrees.
- **Matrices** are float64 4×4 acting on column vectors: ``clip = P @ V @ [x, y, z, 1]``. GLSL reads
  column-major, so upload one with ``m.T.astype("f4").tobytes()``.
- **OpenGL eye space** (:func:`look_at`, an orbit camera's ``view()``): right-handed, x right, y up, the
  camera looking down **−z**. **Clip space** is OpenGL's: NDC x, y, z in [−1, 1], x right, y up, the near
  plane at z = −1; a depth-buffer value d in [0, 1] is ``z_ndc = 2d − 1`` (the default ``glDepthRange``).
- **OpenCV camera space** (a photograph's camera, :class:`Pinhole`): x right, y **down**, z **forward**
  (into the scene), ``x_cam = R · X + t``. The two eye spaces differ by a half turn about x:
  :data:`GL_FROM_CV` = diag(1, −1, −1, 1), its own inverse; :func:`view_from_pose` and
  :func:`pose_from_view` convert a pose (R, t) to a view matrix and back.
- **Pixels**: x right, y down from the image's top-left corner; pixel (column j, row i) covers
  [j, j + 1) × [i, i + 1), so its centre is (j + 0.5, i + 0.5). A pinhole with intrinsics K (pixels) sees
  ``x_cam`` at ``(K · x_cam)[:2] / z``; in NDC that pixel position is ``x_ndc = 2x/W − 1``,
  ``y_ndc = 1 − 2y/H`` (:func:`clip_from_camera`). An image drawn through these matrices and read back with
  ``glReadPixels`` (bottom row first), then flipped, lines up with the photograph pixel for pixel.

May import numpy only (it is :mod:`core`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, TypeVar

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["GL_FROM_CV", "Pinhole", "clip_from_camera", "intrinsics", "look_at", "orthographic",
           "perspective", "pose_from_view", "view_from_pose"]

#: OpenCV camera space → OpenGL eye space (and back: it is its own inverse): y and z flip sign.
GL_FROM_CV = np.diag([1.0, -1.0, -1.0, 1.0])
GL_FROM_CV.setflags(write=False)


def look_at(eye: ArrayLike, target: ArrayLike, up: ArrayLike = (0.0, 1.0, 0.0)) -> np.ndarray:
    """The OpenGL view matrix (4×4, world → eye) of a camera at ``eye`` looking at ``target`` (mesh units).

    The camera looks along −z of its eye space, ``up`` points up in the image. Looking straight along
    ``up``, any perpendicular serves as the image's x axis.
    """
    e, t, u = (np.asarray(v, dtype=np.float64) for v in (eye, target, up))
    f = t - e
    f /= np.linalg.norm(f)
    s = np.cross(f, u)
    if np.linalg.norm(s) < 1e-9:  # looking straight along ``up``: any perpendicular will do
        s = np.cross(f, np.array([0.0, 0.0, 1.0]))
    s /= np.linalg.norm(s)
    uu = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, uu, -f
    m[:3, 3] = -m[:3, :3] @ e
    return m


def perspective(fovy_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    """OpenGL's perspective projection (eye → clip, NDC z in [−1, 1]).

    ``fovy_deg``: the vertical field of view, degrees; ``aspect`` = width / height; ``near``, ``far``: the
    clip planes' distances in front of the camera (mesh units, 0 < near < far).
    """
    f = 1.0 / np.tan(np.radians(fovy_deg) / 2.0)
    m = np.zeros((4, 4))
    m[0, 0] = f / aspect
    m[1, 1] = f
    m[2, 2] = (far + near) / (near - far)
    m[2, 3] = 2.0 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def orthographic(half_w: float, half_h: float, near: float, far: float) -> np.ndarray:
    """OpenGL's orthographic projection (eye → clip) of a box.

    The box: x in [−``half_w``, ``half_w``], y in [−``half_h``, ``half_h``], and ``near``…``far`` in front of
    the camera (eye z = −near … −far); mesh units.
    """
    m = np.eye(4)
    m[0, 0] = 1.0 / half_w
    m[1, 1] = 1.0 / half_h
    m[2, 2] = -2.0 / (far - near)
    m[2, 3] = -(far + near) / (far - near)
    return m


def view_from_pose(R: ArrayLike, t: ArrayLike) -> np.ndarray:
    """The OpenGL view matrix (4×4) of an OpenCV pose (R world → camera, t mesh units): ``GL_FROM_CV @ [R | t]``."""
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = np.asarray(R, dtype=np.float64), np.asarray(t, dtype=np.float64)
    return GL_FROM_CV @ m


def pose_from_view(view: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """The OpenCV pose (R (3, 3) world → camera, t (3,) mesh units) of a rigid OpenGL view matrix (4×4)."""
    m = GL_FROM_CV @ np.asarray(view, dtype=np.float64)
    return m[:3, :3].copy(), m[:3, 3].copy()


def intrinsics(fov_y_deg: float, width: float, height: float) -> np.ndarray:
    """The intrinsics K (3×3, pixels) of a ``width`` × ``height`` image, vertical field of view ``fov_y_deg``.

    Square pixels, no skew, the principal point at the image's centre.
    """
    f = 0.5 * height / np.tan(np.radians(fov_y_deg) / 2)
    return np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1.0]])


def clip_from_camera(K: ArrayLike, width: float, height: float, near: float, far: float) -> np.ndarray:
    """OpenGL's clip matrix (4×4) from OpenCV camera space, for intrinsics ``K`` of a ``width`` × ``height`` image.

    Pixel (x, y) = (K·x_cam)[:2] / z (module docstring: pixel j covers [j, j + 1)) lands at
    x_ndc = 2x/W − 1, y_ndc = 1 − 2y/H; w_clip = z; depth [``near``, ``far``] (mesh units, 0 < near < far)
    maps to [−1, 1]. K and the size scaled together give the same matrix.
    """
    k = np.asarray(K, dtype=float)
    w, h = float(width), float(height)
    return np.array([
        [2 * k[0, 0] / w, 2 * k[0, 1] / w, 2 * k[0, 2] / w - 1, 0.0],
        [0.0, -2 * k[1, 1] / h, 1 - 2 * k[1, 2] / h, 0.0],
        [0.0, 0.0, (far + near) / (far - near), -2 * far * near / (far - near)],
        [0.0, 0.0, 1.0, 0.0],
    ])


_P = TypeVar("_P", bound="Pinhole")


@dataclass
class Pinhole:
    """A pinhole camera in OpenCV's convention (module docstring).

    Attributes:
        K: (3, 3) intrinsics, pixels of the ``width`` × ``height`` image.
        R: (3, 3) rotation world → camera.
        t: (3,) translation, mesh units.
        width: the image's width, pixels.
        height: the image's height, pixels.
    """

    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    width: int
    height: int

    @classmethod
    def looking_at(cls: type[_P], eye: ArrayLike, target: ArrayLike, up: ArrayLike, fov_y_deg: float,
                   width: int, height: int) -> _P:
        """A camera at ``eye`` looking at ``target`` (mesh units), ``up`` up in the image.

        The pose is :func:`look_at`'s, converted (:func:`pose_from_view`); the intrinsics :func:`intrinsics`.
        """
        R, t = pose_from_view(look_at(eye, target, up))
        return cls(K=intrinsics(fov_y_deg, width, height), R=R, t=t, width=width, height=height)

    @property
    def P(self) -> np.ndarray:
        """The (3, 4) projection matrix K [R | t]."""
        return np.asarray(self.K @ np.hstack([self.R, self.t[:, None]]))

    @property
    def centre(self) -> np.ndarray:
        """The camera centre in mesh units."""
        return np.asarray(-self.R.T @ self.t)

    @property
    def fov_y(self) -> float:
        """The vertical field of view, degrees."""
        return math.degrees(2 * math.atan(self.height / (2 * float(np.asarray(self.K)[1, 1]))))

    def scaled_to(self: _P, width: int, height: int) -> _P:
        """This camera for the same photograph resampled to ``width`` × ``height`` pixels (pose unchanged).

        The intrinsics scale with the image, x by ``width / self.width`` and y by ``height / self.height``:
        pixel positions are continuous, pixel j covering [j, j + 1) (module docstring), so a point at (x, y)
        in this image is at (x·sx, y·sy) in the resampled one, its principal point included.

        Raises:
            ValueError: a size that is not positive, or an aspect ratio that disagrees with this camera's by
                more than a pixel (measured in the smaller of the two images: the rounding of a resize).
        """
        w, h = int(width), int(height)
        if w < 1 or h < 1:
            raise ValueError(f"an image size must be positive, got {w}×{h}")
        (sw, sh), (bw, bh) = sorted(((self.width, self.height), (w, h)), key=lambda s: s[0] * s[1])
        if abs(sw - sh * bw / bh) > 1.0 or abs(sh - sw * bh / bw) > 1.0:
            raise ValueError(f"a {w}×{h} image is not of the camera's {self.width}×{self.height} aspect ratio")
        k = np.diag([w / self.width, h / self.height, 1.0]) @ np.asarray(self.K, dtype=np.float64)
        return replace(self, K=k, width=w, height=h)

    def to_camera(self, points: ArrayLike) -> np.ndarray:
        """Mesh-unit points (N, 3) → camera coordinates (N, 3)."""
        return np.asarray(np.asarray(points, dtype=float) @ self.R.T + self.t)

    def project(self, points: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Project mesh-unit points (N, 3): returns (pixels (N, 2), camera depth z (N,))."""
        xc = self.to_camera(points)
        z = xc[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uvw = xc @ self.K.T
            px = uvw[:, :2] / uvw[:, 2:3]
        return px, z

    def camera_from_world(self) -> np.ndarray:
        """The rigid motion (4×4) world → OpenCV camera space, ``[R | t]``."""
        m = np.eye(4)
        m[:3, :3] = self.R
        m[:3, 3] = self.t
        return m

    def view(self) -> np.ndarray:
        """The OpenGL view matrix (4×4, world → eye): :func:`view_from_pose` of (R, t)."""
        return view_from_pose(self.R, self.t)

    def clip_from_eye(self, near: float, far: float) -> np.ndarray:
        """The OpenGL projection (4×4, eye → clip): :func:`clip_from_camera` after :data:`GL_FROM_CV`.

        Any image size of the camera's aspect ratio draws the same view.
        """
        return clip_from_camera(self.K, self.width, self.height, near, far) @ GL_FROM_CV

    def clip_from_world(self, near: float, far: float, scale: float = 1.0) -> np.ndarray:
        """The OpenGL clip matrix (4×4, world → clip) of this camera for an image ``scale`` times its size.

        :func:`clip_from_camera` (depth [``near``, ``far``], mesh units) after :meth:`camera_from_world`.
        """
        k = np.diag([scale, scale, 1.0]) @ self.K
        clip = clip_from_camera(k, self.width * scale, self.height * scale, near, far)
        return clip @ self.camera_from_world()
