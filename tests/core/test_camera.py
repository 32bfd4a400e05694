"""The one camera (core/camera.py): the conversions between OpenCV's and OpenGL's conventions round-trip, and
a point lands on the same pixel through the GL clip matrices as through the OpenCV pinhole."""

from __future__ import annotations

import numpy as np
import pytest

from core.camera import (
    GL_FROM_CV,
    Pinhole,
    clip_from_camera,
    intrinsics,
    look_at,
    orthographic,
    perspective,
    pose_from_view,
    view_from_pose,
)

W, H = 320, 240


def _camera() -> Pinhole:
    return Pinhole.looking_at((3.0, 2.0, 40.0), (0.0, 1.0, 0.0), (0.0, 1.0, 0.0), 25.0, W, H)


def _window_pixels(clip: np.ndarray, points: np.ndarray, width: float, height: float) -> np.ndarray:
    """Pixel positions (x right, y down, top-left corner 0) where ``clip`` draws ``points``, and NDC z."""
    c = clip @ np.c_[points, np.ones(len(points))].T
    ndc = c[:3] / c[3]
    return np.stack([(ndc[0] + 1) / 2 * width, (1 - ndc[1]) / 2 * height, ndc[2]], axis=1)


def test_the_flip_is_its_own_inverse_and_read_only() -> None:
    np.testing.assert_array_equal(GL_FROM_CV @ GL_FROM_CV, np.eye(4))
    with pytest.raises(ValueError):
        GL_FROM_CV[1, 1] = 1.0


def test_pose_and_view_round_trip() -> None:
    rng = np.random.default_rng(0)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    R = q * np.sign(np.linalg.det(q))  # a rotation
    t = rng.normal(size=3)
    R2, t2 = pose_from_view(view_from_pose(R, t))
    np.testing.assert_array_equal(R2, R)
    np.testing.assert_array_equal(t2, t)
    view = look_at((1.0, 2.0, 3.0), (0.0, 0.5, -1.0))
    np.testing.assert_array_equal(view_from_pose(*pose_from_view(view)), view)


def test_look_at_is_opengl_and_its_pose_is_opencv() -> None:
    eye, target = np.array([1.0, 2.0, 10.0]), np.array([0.5, 1.0, 0.0])
    view = look_at(eye, target, (0.0, 1.0, 0.0))
    np.testing.assert_allclose(view[:3, :3] @ view[:3, :3].T, np.eye(3), atol=1e-12)  # rigid
    np.testing.assert_allclose((view @ np.r_[eye, 1.0])[:3], 0.0, atol=1e-12)  # the eye at the origin
    ahead = (view @ np.r_[target, 1.0])[:3]
    assert ahead[2] < 0 and np.hypot(ahead[0], ahead[1]) < 1e-12  # GL: looking down −z
    above = (view @ np.r_[eye + (target - eye) + np.array([0.0, 1.0, 0.0]), 1.0])[:3]
    assert above[1] > 0  # GL: +y up
    R, t = pose_from_view(view)
    x_cam = R @ target + t
    assert x_cam[2] > 0 and np.hypot(x_cam[0], x_cam[1]) < 1e-12  # OpenCV: z forward
    assert (R @ (target + np.array([0.0, 1.0, 0.0])) + t)[1] < 0  # OpenCV: y down
    # straight down along ``up``: still a rigid view
    down = look_at((0.0, 5.0, 0.0), (0.0, 0.0, 0.0))
    np.testing.assert_allclose(down[:3, :3] @ down[:3, :3].T, np.eye(3), atol=1e-12)


def test_looking_at_is_the_opencv_look_at_it_replaces() -> None:
    """Pinhole.looking_at's pose equals, bit for bit, the OpenCV look_at capture/camera.py had."""
    eye, target, up = np.array([3.0, 2.0, 40.0]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 1.0, 0.0])
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    cam = _camera()
    np.testing.assert_array_equal(cam.R, R)
    np.testing.assert_array_equal(cam.t, -R @ eye)
    f = 0.5 * H / np.tan(np.radians(25.0) / 2)
    np.testing.assert_array_equal(cam.K, [[f, 0, W / 2], [0, f, H / 2], [0, 0, 1.0]])
    assert cam.fov_y == pytest.approx(25.0, abs=1e-12)


def test_a_point_projects_to_the_same_pixel_through_gl_and_the_pinhole() -> None:
    cam = _camera()
    points = np.random.default_rng(1).uniform(-5, 5, (50, 3))
    pixels, depth = cam.project(points)
    near, far = 10.0, 80.0
    gl = cam.clip_from_eye(near, far) @ cam.view()
    np.testing.assert_allclose(cam.clip_from_world(near, far), gl, rtol=1e-12, atol=1e-12)
    for scale in (1.0, 2.0, 0.5):  # any image size of the camera's aspect
        drawn = _window_pixels(cam.clip_from_world(near, far, scale), points, W * scale, H * scale)
        np.testing.assert_allclose(drawn[:, :2], pixels * scale, atol=1e-9)
    np.testing.assert_allclose(_window_pixels(gl, points, W, H)[:, :2], pixels, atol=1e-9)
    # depth: w_clip is the camera's z, the near plane at NDC −1 and the far plane at +1
    np.testing.assert_allclose((gl @ np.c_[points, np.ones(len(points))].T)[3], depth, rtol=1e-12)
    on_planes = cam.centre + np.outer([near, far], np.linalg.inv(cam.R)[:, 2])
    np.testing.assert_allclose(_window_pixels(gl, on_planes, W, H)[:, 2], [-1.0, 1.0], atol=1e-12)


def test_pixel_centres() -> None:
    """Pixel (column j, row i) covers [j, j + 1) × [i, i + 1): the top-left pixel's centre is (0.5, 0.5)."""
    K = intrinsics(40.0, W, H)
    clip = clip_from_camera(K, W, H, 1.0, 10.0)
    for px in ((0.5, 0.5), (W - 0.5, H - 0.5), (W / 2, H / 2)):
        ray = np.linalg.solve(K, [px[0], px[1], 1.0]) * 3.0  # the camera-space point seen at that pixel
        c = clip @ np.r_[ray, 1.0]
        ndc = c[:2] / c[3]
        np.testing.assert_allclose(ndc, [2 * px[0] / W - 1, 1 - 2 * px[1] / H], atol=1e-12)
    ndc = clip @ np.r_[np.linalg.solve(K, [0.5, 0.5, 1.0]), 1.0]
    assert ndc[0] / ndc[3] == pytest.approx(-1 + 1 / W) and ndc[1] / ndc[3] == pytest.approx(1 - 1 / H)


def test_a_centred_pinhole_is_the_opengl_perspective() -> None:
    cam = _camera()
    np.testing.assert_allclose(cam.clip_from_eye(2.0, 90.0), perspective(25.0, W / H, 2.0, 90.0), atol=1e-12)
    np.testing.assert_allclose(cam.view(), look_at((3.0, 2.0, 40.0), (0.0, 1.0, 0.0)), atol=0)


def test_orthographic_maps_its_box_to_the_cube() -> None:
    m = orthographic(2.0, 1.0, 0.5, 4.5)
    corners = np.array([[-2.0, -1.0, -0.5, 1.0], [2.0, 1.0, -4.5, 1.0]])
    np.testing.assert_allclose((m @ corners.T).T[:, :3], [[-1, -1, -1], [1, 1, 1]], atol=1e-12)
