"""capture/: camera calibration, probe analysis, Eq. 3, the rasteriser and the synthetic validation."""

from __future__ import annotations

import numpy as np
import pytest

from capture.camera import Camera, CameraError, calibrate, look_at
from capture.probe import analyse_probe, light_direction_from_highlight, synthetic_probe
from capture.reflectance import eq3_exponent


def test_eq3_small_angle_limit_and_monotone() -> None:
    for deg in (1.0, 2.0, 4.0):
        a = np.radians(deg)
        assert eq3_exponent(a) == pytest.approx(1 / (4 * a * a), rel=0.02)
    vals = [eq3_exponent(np.radians(d)) for d in (2, 5, 10, 20)]
    assert all(x > y for x, y in zip(vals, vals[1:]))


def test_calibrate_recovers_camera_from_noisy_points() -> None:
    cam = look_at(np.array([0.5, 1.0, 30.0]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 1.0, 0.0]), 10.0, 640, 480)
    rng = np.random.default_rng(0)
    X = rng.uniform([-1.5, -1.0, 0.0], [1.5, 3.0, 2.5], size=(12, 3))
    x, _ = cam.project(X)
    x = x + rng.normal(0, 0.3, x.shape)
    est = calibrate(x, X, 640, 480)
    assert est.reprojection_error_px is not None and est.reprojection_error_px < 0.6
    assert np.linalg.norm(est.centre - cam.centre) < 0.05 * np.linalg.norm(cam.centre)
    # A projection matrix given directly (any scale, either sign) decomposes back to the same camera.
    back = Camera.from_projection(-2.5 * cam.P, 640, 480)
    assert np.allclose(back.K, cam.K) and np.allclose(back.R, cam.R) and np.allclose(back.t, cam.t)


@pytest.mark.parametrize("bad", ["few", "nan", "planar"])
def test_calibrate_rejects_bad_input(bad: str) -> None:
    rng = np.random.default_rng(1)
    X = rng.uniform(-1, 1, (8, 3))
    x = rng.uniform(0, 100, (8, 2))
    if bad == "few":
        X, x = X[:5], x[:5]
    elif bad == "nan":
        x[2, 0] = np.nan
    else:
        X[:, 2] = 0.0
    with pytest.raises(CameraError):
        calibrate(x, X, 100, 100, source="pts.json")


def test_probe_light_direction_and_hue() -> None:
    env = np.full((64, 128, 3), 0.2)
    env[:, :, 2] = 0.3
    R = np.eye(3)
    light = np.array([0.2, -0.1, -1.0])
    light /= np.linalg.norm(light)
    flash = np.array([1.0, 0.9, 0.7])
    img = synthetic_probe(env, R, light, flash, size=256, env_scale=0.1)
    res = analyse_probe(img)
    err = np.degrees(np.arccos(np.clip(res.light_dir_camera @ light, -1, 1)))
    assert err < 1.0
    assert np.allclose(res.flash_rgb / res.flash_rgb.max(), flash / flash.max(), atol=0.03)
    assert np.allclose(res.ambient_rgb, [0.02, 0.02, 0.03], atol=0.004)
    d, theta, _ = light_direction_from_highlight(0.0, 0.0)
    assert theta == 0.0 and np.allclose(d, [0, 0, -1])
