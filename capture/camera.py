"""The photograph's camera: a 3×4 projection matrix, given or computed from 2D–3D correspondences.

Conventions (OpenCV's, as :mod:`core.camera` states them with their conversion to OpenGL's): camera
coordinates x right, y down, z forward (into the scene); ``x_cam = R · X + t`` with ``X`` in mesh units;
pixel ``(x, y) = (K · x_cam)[:2] / z`` where the pixel grid has x right, y down, and the centre of the
top-left pixel at (0.5, 0.5).

From ≥ 6 correspondences: the normalised direct linear transform (Hartley & Zisserman, Alg. 7.1), the
RQ decomposition into K, R, t, then a non-linear refinement of the reprojection error with
``scipy.optimize.least_squares`` on (focal length, rotation vector, translation) — square pixels, zero
skew and the principal point at the image centre unless asked (a photographic camera; it also keeps a
few hand-picked points from over-fitting) — started from the DLT and from six axis-aligned views, the
best solution with every point in front of the camera kept.

How well clicked landmarks fix the camera (tests/capture/test_out_of_sample.py, the validation's
telephoto framing: 2.36 m, 6.4° vertical field, 512²; the sample head's 22 landmarks): clicked to the
centre of their pixel (±0.5 px) the rotation is 0.32° off, the focal length −22 % (the prior's pull)
and the capture's flash direction 0.44° off (0.14° with the true camera), s −6.9 %; with 1 px Gaussian
clicks (five seeds) the rotation is off by 0.6–1.8° and the focal length by −44 to +43 % — the face's
landmarks are nearly planar and seen almost orthographically, so rotation trades against translation
and the focal length against the distance — and since the probe gives the flash in camera coordinates,
the flash is off in the head's coordinates by as much (0.62–1.90°), s by −3 to −15 % and i_s by −4 to
−12 %. A 25° lens at the same framing roughly halves the rotation error (0.4–1.35° at 1 px).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.linalg
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from capture.raster import GBuffer, rasterize
from core.camera import Pinhole
from core.errors import SheerError


class CameraError(SheerError, ValueError):
    """A camera or correspondence file that cannot be used; the message says what and where."""


@dataclass
class Camera(Pinhole):
    """The photograph's pinhole camera (a :class:`core.camera.Pinhole`: K, R, t, size) and how it was fitted.

    Attributes:
        K: (3, 3) intrinsics in pixels. R: (3, 3) rotation world→camera. t: (3,) translation (mesh units).
        width, height: the photograph's size in pixels.
        reprojection_error_px: RMS reprojection error of the correspondences it was fitted to (pixels),
            or None for a camera given directly.
        rotation_covariance_deg2: (2, 2) how uncertain the correspondences leave the head's rotation
            about the camera's x and y axes (degrees², the focal length and translation marginalised;
            :func:`pose_covariance`), or None for a camera given directly. :mod:`capture.pose` refines
            those two angles on the photograph and weighs the refinement against it.
        parameter_covariance: (7, 7) the same fit's whole covariance (:func:`parameter_covariance`), or
            None for a camera given directly: :func:`capture.pose.image_similarity_covariance` reads the
            image's scale and roll from it.
        parameter_pivot: (3,) the point that covariance's rotation is about (mesh units: the centroid of the
            correspondences' mesh points), or None for a camera given directly.

    The projection (``P``, ``project``, ``centre``), the GL matrices (``view``, ``clip_from_world``) and
    :meth:`~core.camera.Pinhole.looking_at` are :class:`core.camera.Pinhole`'s.
    """

    reprojection_error_px: float | None = None
    rotation_covariance_deg2: np.ndarray | None = None
    parameter_covariance: np.ndarray | None = None
    parameter_pivot: np.ndarray | None = None

    def gbuffer(self, vertices: np.ndarray, faces: np.ndarray, scale: float = 1.0) -> GBuffer:
        """Rasterise a mesh as this camera sees it (image ``scale`` times the photo's size)."""
        px, z = self.project(vertices)
        w = max(1, round(self.width * scale))
        h = max(1, round(self.height * scale))
        # NDC-like depth 1/z is linear in screen space; nearer = larger 1/z, so rasterise -1/z.
        with np.errstate(divide="ignore"):
            d = np.where(z > 1e-9, -1.0 / z, np.inf)
        return rasterize(px * scale, d, faces, w, h, w=np.where(z > 1e-9, z, -1.0))

    def turned(self, rotvec_camera: np.ndarray, pivot: np.ndarray) -> Camera:
        """This camera with the scene turned about ``pivot`` (mesh units) by ``rotvec_camera``.

        ``rotvec_camera``: radians, a rotation vector E in camera coordinates; R' = E·R, and t' chosen so
        ``pivot`` stays where it projects. For a small turn the head's image stays in place (a point at depth d from the pivot moves by about
        d·|rotvec|) while its normals, the light and the view turn by the angle relative to each other.
        """
        E = Rotation.from_rotvec(np.asarray(rotvec_camera, dtype=float)).as_matrix()
        R2 = E @ self.R
        t2 = self.t + self.R @ pivot - R2 @ pivot
        return Camera(K=self.K.copy(), R=R2, t=t2, width=self.width, height=self.height,
                      reprojection_error_px=self.reprojection_error_px,
                      rotation_covariance_deg2=self.rotation_covariance_deg2,
                      parameter_covariance=self.parameter_covariance, parameter_pivot=self.parameter_pivot)

    def to_json(self) -> dict[str, Any]:
        """K, R, t, P (pixels, mesh units) and the size as JSON lists and numbers (face.json's ``camera``)."""
        return {
            "K": self.K.tolist(), "R": self.R.tolist(), "t": self.t.tolist(), "P": self.P.tolist(),
            "width": self.width, "height": self.height,
            "reprojection_error_px": self.reprojection_error_px,
        }

    @classmethod
    def from_projection(cls, P: np.ndarray, width: int, height: int) -> Camera:
        """Decompose a (3, 4) projection matrix into K, R, t (K with a positive diagonal, det R = +1)."""
        P = np.asarray(P, dtype=float)
        if P.shape != (3, 4) or not np.all(np.isfinite(P)):
            raise CameraError(f"a projection matrix must be 3×4 finite numbers, got shape {P.shape}")
        M = P[:, :3]
        if abs(np.linalg.det(M)) < 1e-12 * max(1.0, float(np.abs(M).max()) ** 3):
            raise CameraError("the projection matrix is singular (its left 3×3 block has no inverse)")
        if np.linalg.det(M) < 0:
            P = -P
            M = -M
        K, R = scipy.linalg.rq(M)
        S = np.diag(np.sign(np.diag(K)))
        K = K @ S
        R = S @ R
        t = np.linalg.solve(K, P[:, 3])
        scale = K[2, 2]
        K = K / scale
        t = t  # K/scale with P/scale: t is unchanged up to the overall scale of P
        if np.linalg.det(R) < 0:
            R = -R
            t = -t
        return cls(K=K, R=R, t=t / 1.0, width=int(width), height=int(height))


def _normalise_2d(x: np.ndarray) -> np.ndarray:
    c = x.mean(axis=0)
    d = np.sqrt(((x - c) ** 2).sum(axis=1)).mean()
    s = np.sqrt(2.0) / max(d, 1e-12)
    return np.array([[s, 0, -s * c[0]], [0, s, -s * c[1]], [0, 0, 1.0]])


def _normalise_3d(X: np.ndarray) -> np.ndarray:
    c = X.mean(axis=0)
    d = np.sqrt(((X - c) ** 2).sum(axis=1)).mean()
    s = np.sqrt(3.0) / max(d, 1e-12)
    T = np.eye(4)
    T[:3, :3] *= s
    T[:3, 3] = -s * c
    return T


def dlt(points2d: np.ndarray, points3d: np.ndarray) -> np.ndarray:
    """The normalised DLT: a (3, 4) projection matrix from ≥ 6 correspondences (pixels ↔ mesh units)."""
    x = np.asarray(points2d, dtype=float)
    X = np.asarray(points3d, dtype=float)
    T = _normalise_2d(x)
    U = _normalise_3d(X)
    xn = (np.hstack([x, np.ones((len(x), 1))]) @ T.T)
    Xn = (np.hstack([X, np.ones((len(X), 1))]) @ U.T)
    rows = []
    for (u, v, w), Xh in zip(xn, Xn):
        rows.append(np.concatenate([np.zeros(4), -w * Xh, v * Xh]))
        rows.append(np.concatenate([w * Xh, np.zeros(4), -u * Xh]))
    A = np.asarray(rows)
    _, _, vt = np.linalg.svd(A)
    Pn = vt[-1].reshape(3, 4)
    P = np.linalg.inv(T) @ Pn @ U
    # Make the points lie in front of the camera.
    depth = np.hstack([X, np.ones((len(X), 1))]) @ P[2]
    if np.median(depth) < 0:
        P = -P
    return P


#: How tightly a known focal length (:func:`calibrate`'s ``focal_px``, e.g. from the photograph's EXIF)
#: holds: its log's standard deviation. EXIF stores the 35 mm-equivalent focal length in whole millimetres
#: (±0.5 mm: 0.2 % at 270 mm, 1.4 % at 35 mm) and a lens focused closer than infinity lengthens its focal
#: length by a few per cent (a 1:10 magnification: 10 %); 3 % covers a portrait at ≥ 1 m.
KNOWN_FOCAL_SIGMA = 0.03


def _rotation_matrix(rotvec: np.ndarray) -> np.ndarray:
    """``Rotation.from_rotvec(rotvec).as_matrix()`` (3, 3) by scipy's own arithmetic, step for step.

    The unit quaternion from the angle's half (its Taylor series below 1 mrad), then the matrix from the
    quaternion: the same matrix to the last bit, without the per-call overhead that made a quarter of
    :func:`calibrate`'s time (its refinement evaluates the residual some 200 times).
    """
    x, y, z = (float(v) for v in rotvec)
    angle = math.sqrt(x * x + y * y + z * z)
    if angle <= 1e-3:
        angle2 = angle * angle
        scale = 0.5 - angle2 / 48 + angle2 * angle2 / 3840
    else:
        scale = math.sin(angle / 2) / angle
    qx, qy, qz, qw = scale * x, scale * y, scale * z, math.cos(angle / 2)
    x2, y2, z2, w2 = qx * qx, qy * qy, qz * qz, qw * qw
    xy, zw, xz, yw, yz, xw = qx * qy, qz * qw, qx * qz, qy * qw, qy * qz, qx * qw
    return np.array([[x2 - y2 - z2 + w2, 2 * (xy - zw), 2 * (xz + yw)],
                     [2 * (xy + zw), -x2 + y2 - z2 + w2, 2 * (yz - xw)],
                     [2 * (xz - yw), 2 * (yz + xw), -x2 - y2 + z2 + w2]])


def _residuals(params: np.ndarray, x: np.ndarray, X: np.ndarray, pp: tuple[float, float] | None = None,
               f_prior: float | None = None, f_sigma: float = 1.0) -> np.ndarray:
    return _residuals_from_rotated(X @ _rotation_matrix(params[3:6]).T, params, x, pp, f_prior, f_sigma)


#: The relative step of scipy's '2-point' finite differences (``least_squares``' default Jacobian): √ε.
_FD_STEP = float(np.finfo(np.float64).eps) ** 0.5


def _residuals_jacobian(params: np.ndarray, x: np.ndarray, X: np.ndarray, pp: tuple[float, float] | None = None,
                        f_prior: float | None = None, f_sigma: float = 1.0) -> np.ndarray:
    """:func:`_residuals`' forward-difference Jacobian, the very one ``least_squares``' '2-point' computes.

    The same steps (√ε · max(1, |p|), signed as p, ≥ 0 taken as +), the same perturbed parameters and the
    same arithmetic element by element, so the same numbers to the last bit (the camera :func:`calibrate`
    returns is unchanged), in one pass over the nine perturbed parameter vectors instead of nine calls:
    the points are turned once for the six parameters that leave the rotation as it is (focal length,
    principal point, translation), and the rest is done for all nine at once.
    """
    p0 = np.asarray(params, dtype=float)
    n = len(p0)
    h = _FD_STEP * ((p0 >= 0).astype(float) * 2 - 1) * np.maximum(1.0, np.abs(p0))
    p1 = np.repeat(p0[None], n, axis=0)
    p1[np.arange(n), np.arange(n)] = p0 + h
    rotated0 = X @ _rotation_matrix(p0[3:6]).T
    rotated = np.repeat(rotated0[None], n + 1, axis=0)  # the last: p0 itself
    for i in range(3, 6):
        rotated[i] = X @ _rotation_matrix(p1[i, 3:6]).T
    every = np.concatenate([p1, p0[None]])
    f, cx, cy = every[:, 0:1], every[:, 1:2], every[:, 2:3]
    if pp is not None:
        cx, cy = pp
    xc = rotated + every[:, None, 6:9]
    proj = np.stack([f * xc[:, :, 0] / xc[:, :, 2] + cx, f * xc[:, :, 1] / xc[:, :, 2] + cy], axis=2)
    res = (proj - x).reshape(n + 1, -1)
    if f_prior is not None:
        res = np.concatenate([res, [[np.log(max(fk, 1e-9) / f_prior) / f_sigma] for fk in every[:, 0]]], axis=1)
    columns = (res[:n] - res[n]) / ((p0 + h) - p0)[:, None]
    return columns.T  # scipy's layout: its transpose, filled a parameter at a time


def _residuals_from_rotated(rotated: np.ndarray, params: np.ndarray, x: np.ndarray,
                            pp: tuple[float, float] | None, f_prior: float | None, f_sigma: float) -> np.ndarray:
    """:func:`_residuals` with ``X @ R.T`` (the points turned by ``params``' rotation vector) given."""
    f, cx, cy = params[:3]
    if pp is not None:
        cx, cy = pp
    xc = rotated + params[6:9]
    proj = np.stack([f * xc[:, 0] / xc[:, 2] + cx, f * xc[:, 1] / xc[:, 2] + cy], axis=1)
    res = (proj - x).ravel()
    if f_prior is not None:
        # A weak prior on the focal length (1 px of residual per factor e): a face's landmarks are nearly
        # planar, so focal length and distance trade off and the fit otherwise runs off to infinity.
        # A known focal length (f_sigma = KNOWN_FOCAL_SIGMA): 1 px of residual per f_sigma of log f.
        res = np.append(res, np.log(max(f, 1e-9) / f_prior) / f_sigma)
    return res


def calibrate(points2d: np.ndarray, points3d: np.ndarray, width: int, height: int,
              source: str = "correspondences", free_principal_point: bool = False,
              good_enough_px: float | None = None, focal_px: float | None = None) -> Camera:
    """A camera from ≥ 6 2D (pixels) ↔ 3D (mesh units) correspondences: DLT, then refinement.

    ``focal_px``: the focal length when it is known (pixels, > 0; e.g. from the photograph's EXIF,
    :mod:`capture.exif`): it replaces the weak portrait-lens prior by a tight one
    (:data:`KNOWN_FOCAL_SIGMA`), and the rotation and translation still come from the points. None: the
    prior of 2 × the image's longer side.

    ``good_enough_px``: stop at the first start whose refined RMS error is below it (pixels; None: try
    every start — the automatic capture's own mesh fits its points exactly from the DLT).

    The principal point is held at the image centre unless ``free_principal_point`` (a handful of face
    landmarks cannot separate it from the rotation: left free it drifts to far off-axis cameras).
    Returns a :class:`Camera` whose ``reprojection_error_px`` is the RMS error (pixels) after refinement.
    Raises :class:`CameraError` (naming ``source``) for too few, non-finite or degenerate points.
    """
    x = np.asarray(points2d, dtype=float)
    X = np.asarray(points3d, dtype=float)
    if x.ndim != 2 or x.shape[1] != 2 or X.ndim != 2 or X.shape[1] != 3 or len(x) != len(X):
        raise CameraError(f"{source}: need matching lists of 2D points [x, y] and 3D points [x, y, z]")
    if focal_px is not None and not (np.isfinite(focal_px) and focal_px > 0):
        raise CameraError(f"{source}: the focal length must be a positive number of pixels, got {focal_px}")
    if len(x) < 6:
        raise CameraError(f"{source}: a camera needs at least 6 correspondences, got {len(x)}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(X))):
        raise CameraError(f"{source}: a correspondence has a NaN or infinite coordinate")
    sv = np.linalg.svd(X - X.mean(axis=0), compute_uv=False)
    if sv[2] < 1e-6 * sv[0]:
        raise CameraError(f"{source}: the 3D points are coplanar or collinear; pick points at several depths")
    starts = []
    try:  # an affine (orthographic) DLT solution has a singular 3×3 block: then only the axis starts below
        cam0: Camera | None = Camera.from_projection(dlt(x, X), width, height)
    except CameraError:
        cam0 = None
    f0 = float(0.5 * (cam0.K[0, 0] + cam0.K[1, 1])) if cam0 is not None else 0.0
    if cam0 is not None and np.all(np.isfinite(cam0.K)) and f0 > 0:
        starts.append(np.concatenate([[f0, cam0.K[0, 2], cam0.K[1, 2]], Rotation.from_matrix(cam0.R).as_rotvec(),
                                      cam0.t]))
    # With few, nearly planar points (a face's landmarks) the DLT can land on the mirror solution behind
    # the points; also start from cameras looking at the points from each axis direction, framed so the
    # points' extent matches the image points' extent.
    centre = X.mean(axis=0)
    extent3 = float(np.ptp(X, axis=0).max())
    extent2 = float(np.ptp(x, axis=0).max())
    for axis in np.vstack([np.eye(3), -np.eye(3)]):
        dist = 10.0 * extent3 if focal_px is None else focal_px * extent3 / max(extent2, 1e-12)
        up = np.array([0.0, 1.0, 0.0]) if abs(axis[1]) < 0.9 else np.array([0.0, 0.0, 1.0])
        cam = Camera.looking_at(centre + axis * dist, centre, up, 30.0, width, height)
        f = extent2 * dist / max(extent3, 1e-12)
        starts.append(np.concatenate([[f, width / 2, height / 2], Rotation.from_matrix(cam.R).as_rotvec(), cam.t]))
    pp = None if free_principal_point else (width / 2.0, height / 2.0)
    f_prior = 2.0 * max(width, height) if focal_px is None else float(focal_px)  # 2×: a ~70 mm portrait lens
    f_sigma = 1.0 if focal_px is None else KNOWN_FOCAL_SIGMA
    best = None
    for p0 in starts:
        try:
            r = least_squares(_residuals, p0, jac=_residuals_jacobian, args=(x, X, pp, f_prior, f_sigma), method="trf")
        except ValueError:
            continue
        depth = (X @ Rotation.from_rotvec(r.x[3:6]).as_matrix().T + r.x[6:9])[:, 2]
        if r.x[0] <= 0 or np.any(depth <= 0):
            continue  # the points must lie in front of the camera
        if best is None or r.cost < best.cost:
            best = r
        if good_enough_px is not None and np.sqrt(2.0 * r.cost / len(x)) < good_enough_px:
            break
    if best is None:
        raise CameraError(f"{source}: the correspondences do not determine a camera with the points in front of it")
    res = best
    p = res.x.copy()
    if pp is not None:
        p[1:3] = pp
    K = np.array([[p[0], 0, p[1]], [0, p[0], p[2]], [0, 0, 1.0]])
    R = Rotation.from_rotvec(p[3:6]).as_matrix()
    rms = float(np.sqrt(np.mean(_residuals(p, x, X).reshape(-1, 2) ** 2 @ np.ones(2))))
    cam = Camera(K=K, R=R, t=p[6:9].copy(), width=int(width), height=int(height), reprojection_error_px=rms)
    cam.parameter_covariance = parameter_covariance(cam, x, X, f_prior, f_sigma)
    cam.parameter_pivot = X.mean(axis=0)  # what parameter_covariance turns about
    cam.rotation_covariance_deg2 = np.degrees(np.degrees(cam.parameter_covariance[:2, :2]))
    return cam


def pose_covariance(camera: Camera, points2d: np.ndarray, points3d: np.ndarray,
                    f_prior: float | None = None, f_sigma: float = 1.0) -> np.ndarray:
    """How uncertain the correspondences leave the head's rotation about the camera's x and y axes.

    The (2, 2) block of :func:`parameter_covariance` of the rotation about x and y (degrees²): the two
    angles a face's nearly planar points leave loose.
    """
    return np.degrees(np.degrees(parameter_covariance(camera, points2d, points3d, f_prior, f_sigma)[:2, :2]))


def parameter_covariance(camera: Camera, points2d: np.ndarray, points3d: np.ndarray,
                         f_prior: float | None = None, f_sigma: float = 1.0) -> np.ndarray:
    """The calibration's (7, 7) covariance: rotation vector (3, radians), translation (3, mesh units), log f.

    The Gauss–Newton covariance σ²(JᵀJ)⁻¹ of the reprojection error (plus :func:`calibrate`'s focal
    prior row when ``f_prior`` is given, ``f_sigma`` its log's standard deviation) at ``camera``, over
    the scene's rotation about the points' centroid (a rotation vector in camera coordinates, as
    :meth:`Camera.turned`), the translation added to ``t`` and log f, with σ² the residual variance per
    coordinate (pixels², 2N − 7 degrees of freedom).
    """
    x = np.asarray(points2d, dtype=float)
    X = np.asarray(points3d, dtype=float)
    pivot = X.mean(axis=0)
    f0 = float(camera.K[0, 0])

    def residuals(e: np.ndarray) -> np.ndarray:
        cam = camera.turned(e[:3], pivot)
        p = np.concatenate([[f0 * np.exp(e[6]), camera.K[0, 2], camera.K[1, 2]],
                            Rotation.from_matrix(cam.R).as_rotvec(), cam.t + e[3:6]])
        return _residuals(p, x, X, (camera.K[0, 2], camera.K[1, 2]), f_prior, f_sigma)

    r0 = residuals(np.zeros(7))
    scale = np.array([1e-5, 1e-5, 1e-5, *(1e-5 * max(1.0, float(np.abs(camera.t).max())),) * 3, 1e-5])
    J = np.stack([(residuals(np.eye(7)[k] * scale[k]) - residuals(-np.eye(7)[k] * scale[k])) / (2 * scale[k])
                  for k in range(7)], axis=1)
    n = 2 * len(x)
    sigma2 = float(r0[:n] @ r0[:n]) / max(n - 7, 1)
    return np.asarray(np.linalg.pinv(J.T @ J) * sigma2)


def load_points(path: str | Path, width: int, height: int, focal_px: float | None = None) -> Camera:
    """Read a correspondence file and calibrate (``focal_px``: a known focal length, see :func:`calibrate`).

    JSON: ``{"points": [{"name": "...", "image": [x, y], "mesh": [x, y, z]}, ...]}`` with image points
    in pixels (x right, y down, top-left pixel centre at 0.5) and mesh points in mesh units.
    """
    data = _read_json(path)
    pts = data.get("points") if isinstance(data, dict) else None
    if not isinstance(pts, list):
        raise CameraError(f"{path}: expected an object with a 'points' list")
    try:
        x = np.array([p["image"] for p in pts], dtype=float)
        X = np.array([p["mesh"] for p in pts], dtype=float)
    except (KeyError, TypeError, ValueError):
        raise CameraError(f"{path}: every point needs 'image' [x, y] and 'mesh' [x, y, z] numbers") from None
    return calibrate(x, X, width, height, source=str(path), focal_px=focal_px)


def load_camera(path: str | Path, width: int, height: int) -> Camera:
    """Read a projection-matrix file: JSON ``{"P": [[...4], [...4], [...4]]}`` (pixels, mesh units)."""
    data = _read_json(path)
    if not isinstance(data, dict) or "P" not in data:
        raise CameraError(f"{path}: expected an object with a 3×4 'P' projection matrix")
    try:
        P = np.asarray(data["P"], dtype=float)
    except (TypeError, ValueError):
        raise CameraError(f"{path}: 'P' must be a 3×4 matrix of numbers") from None
    try:
        return Camera.from_projection(P, width, height)
    except CameraError as exc:
        raise CameraError(f"{path}: {exc}") from None


def _read_json(path: str | Path) -> Any:
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise CameraError(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise CameraError(f"{path}: cannot read JSON: {exc}") from None
