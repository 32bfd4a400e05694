"""The geometry under the mirror and relight views (no GL): the photograph's camera as a render camera
(:mod:`render.pinhole`), its turn about the neck, and the mirror's soft edge (:func:`render.mirror.edge_weights`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pytest

from render.mirror import edge_weights
from render.pinhole import pinhole_camera, turn_pivot

if TYPE_CHECKING:
    from capture.camera import Camera


def _camera() -> Camera:
    from capture.camera import Camera

    return Camera.looking_at(np.array([3.0, 2.0, 40.0]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 1.0, 0.0]),
                             25.0, 320, 240)


def _pixels(cam: object, points: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Window pixels (x right, y down, top-left corner 0) where the render camera draws ``points``."""
    clip = cam.view_projection(size[0] / size[1]) @ np.c_[points, np.ones(len(points))].T  # type: ignore[attr-defined]
    ndc = clip[:3] / clip[3]
    return np.stack([(ndc[0] + 1) / 2 * size[0], (1 - ndc[1]) / 2 * size[1]], axis=1)


def test_the_render_camera_draws_where_the_photographs_camera_projects() -> None:
    photo = _camera()
    w, h = photo.width, photo.height
    points = np.random.default_rng(1).uniform(-5, 5, (50, 3))
    truth, _ = photo.project(points)
    for size in ((w, h), (2 * w, 2 * h)):
        cam = pinhole_camera(photo, points)
        np.testing.assert_allclose(_pixels(cam, points, size), truth * size[0] / w, atol=1e-6)
    np.testing.assert_allclose(cam.eye(), -photo.R.T @ photo.t, atol=1e-9)


def test_the_camera_scales_with_its_photograph() -> None:
    """``Pinhole.scaled_to``: a point's pixel scales with the image (the capture's 713×836 copy of a 1024×1200
    photograph, each side rounded), the pose and the camera's kind kept; another aspect ratio is refused."""
    from capture.camera import Camera

    small = Camera.looking_at(np.array([3.0, 2.0, 40.0]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 1.0, 0.0]),
                              25.0, 713, 836)
    big = small.scaled_to(1024, 1200)
    assert isinstance(big, Camera) and (big.width, big.height) == (1024, 1200)
    assert np.array_equal(big.R, small.R) and np.array_equal(big.t, small.t)
    points = np.random.default_rng(2).uniform(-5, 5, (50, 3))
    np.testing.assert_allclose(big.project(points)[0], small.project(points)[0] * [1024 / 713, 1200 / 836],
                               rtol=1e-12)
    np.testing.assert_allclose(big.scaled_to(713, 836).K, small.K, rtol=1e-12)  # and back
    for size in ((1024, 1250), (1100, 1200), (0, 836)):
        with pytest.raises(ValueError, match="aspect ratio|positive"):
            small.scaled_to(*size)


def test_the_mirror_takes_the_photograph_its_capture_was_reduced_from() -> None:
    """:func:`render.mirror.photo_camera_at`: the capture's own size, or a larger one of its aspect ratio."""
    from render.errors import RenderError
    from render.mirror import photo_camera_at

    class Face:
        def camera(self) -> Camera:
            return _camera()

    face = Face()
    assert photo_camera_at(face, 320, 240) is not None  # type: ignore[arg-type]
    big = photo_camera_at(face, 1280, 960)  # type: ignore[arg-type]
    np.testing.assert_allclose(big.K[:2], _camera().K[:2] * 4)
    with pytest.raises(RenderError, match="160×120 but the face was captured from a 320×240 one \\(smaller"):
        photo_camera_at(face, 160, 120)  # type: ignore[arg-type]
    with pytest.raises(RenderError, match="of another aspect ratio"):
        photo_camera_at(face, 1280, 1000)  # type: ignore[arg-type]


def test_a_turn_orbits_the_camera_about_the_pivot() -> None:
    photo = _camera()
    w, h = photo.width, photo.height
    points = np.random.default_rng(2).uniform(-5, 5, (20, 3))
    pivot = np.array([0.0, 1.0, -9.0])
    front = pinhole_camera(photo, points, pivot=pivot)
    turned = pinhole_camera(photo, points, yaw=20.0, pitch=-10.0, pivot=pivot)
    # the camera keeps its distance to the pivot, and moves to the subject's left (+x) and down (−y)
    assert np.linalg.norm(turned.eye() - pivot) == pytest.approx(np.linalg.norm(front.eye() - pivot))
    d = turned.eye() - front.eye()
    assert d[0] > 0 and d[1] < 0
    # the pivot itself stays where it was in the image
    np.testing.assert_allclose(_pixels(turned, pivot[None], (w, h)), _pixels(front, pivot[None], (w, h)), atol=1e-6)


def test_the_turn_pivot_is_behind_the_nose() -> None:
    lm = {"nose_tip": (0.0, 0.0, 10.0), "chin": (0.0, -6.0, 8.0), "forehead": (0.0, 6.0, 8.0)}
    p = turn_pivot(np.zeros((3, 3)), lm, mm_per_unit=10.0)
    np.testing.assert_allclose(p, [0.0, 0.0, 10.0 - 9.0])


def test_edge_weights_fade_at_an_open_boundary_and_ignore_seams() -> None:
    # a 21×21 grid, 1 mm apart, split down the middle into two charts (duplicated vertices: a UV seam)
    n = 21
    xs, ys = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float))
    v = np.c_[xs.ravel(), ys.ravel(), np.zeros(n * n)]
    idx = np.arange(n * n).reshape(n, n)
    quads = [(idx[i, j], idx[i, j + 1], idx[i + 1, j + 1], idx[i + 1, j]) for i in range(n - 1) for j in range(n - 1)]
    faces = np.array([f for a, b, c, d in quads for f in ((a, b, c), (a, c, d))])
    seam = np.nonzero(xs.ravel() == 10)[0]
    v2 = np.r_[v, v[seam]]  # the right chart uses copies of the seam's vertices
    remap = np.arange(n * n)
    remap[seam] = n * n + np.arange(len(seam))
    right = (v[faces][:, :, 0].max(axis=1) > 10)
    faces2 = faces.copy()
    faces2[right] = remap[faces[right]]
    w = edge_weights(v2, faces2, mm_per_unit=1.0, feather_mm=4.0)
    grid = w[:n * n].reshape(n, n)
    assert np.all(grid[0] == 0) and np.all(grid[:, 0] == 0)  # the open boundary
    assert grid[10, 10] == 1.0 and np.all(w[n * n:] == grid[:, 10])  # the seam's middle is inside
    assert 0 < grid[10, 2] < 1 and grid[10, 2] < grid[10, 3]  # a smooth rise over 4 mm
    # a closed mesh (a tetrahedron): 1 everywhere
    tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    assert np.all(edge_weights(tet, np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]), 1.0) == 1.0)
