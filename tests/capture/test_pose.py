"""The camera's rotation: how uncertain landmarks leave it, and its refinement on the specular lobe (issue 14).

:func:`capture.camera.pose_covariance` predicts how far 1 px of landmark noise turns the calibrated camera;
:func:`capture.pose.refine_rotation` turns a camera back towards the truth using the photograph's specular
lobe. The photographs here are drawn on the GPU by another renderer (bench/capture_truth.py), in scenes
that are not the validation's (tests/capture/test_out_of_sample.py, ``sheer bench capture``).
"""

from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from capture.camera import Camera, calibrate
from capture.phong import PhongParams
from capture.pose import Surface, refine_rotation
from capture.synthetic import validation_camera
from painting.head import load_head

if TYPE_CHECKING:
    import moderngl

    from capture.pipeline import CaptureResult


def _turn_deg(camera: Camera, truth: Camera) -> np.ndarray:
    """The camera's rotation error about its x and y axes, degrees."""
    return np.degrees(Rotation.from_matrix(camera.R @ truth.R.T).as_rotvec())[:2]


def test_the_covariance_predicts_how_far_noisy_landmarks_turn_the_camera() -> None:
    """40 draws of 1 px noise on the sample head's 22 landmarks, the validation's camera: the errors
    divided by the predicted standard deviations have an RMS near 1 about each axis (measured 1.24 and
    1.08; on the 32 tuning scenes of capture.pose, 1.01 and 1.14; a covariance off by 2× in σ would
    give 0.5 or 2)."""
    head = load_head()
    names = sorted(set(head.metadata.landmarks) - {"gnathion"})
    X = np.array([head.metadata.landmarks[n] for n in names])
    truth = validation_camera()
    x, _ = truth.project(X)
    rng = np.random.default_rng(11)
    z = []
    for _ in range(40):
        cam = calibrate(x + rng.normal(0.0, 1.0, x.shape), X, truth.width, truth.height)
        assert cam.rotation_covariance_deg2 is not None
        z.append(_turn_deg(cam, truth) / np.sqrt(np.diag(cam.rotation_covariance_deg2)))
    rms = np.sqrt(np.mean(np.square(z), axis=0))
    assert np.all((rms > 0.7) & (rms < 1.45)), rms


def test_a_camera_given_directly_is_not_refined() -> None:
    """No covariance (a projection matrix given, not calibrated): nothing to weigh the photograph against."""
    cam = validation_camera()
    p = np.zeros((10, 3))
    surface = Surface.from_pixels(np.arange(10), np.arange(10), p + [0.0, 0.0, 1.0], p)
    params = PhongParams(diffuse=np.full(3, 0.4), specular=0.2, exponent=20.0, ambient_scale=1.0)
    assert refine_rotation(np.zeros((10, 10, 3)), surface, cam, np.array([0.0, 0.0, -1.0]), params, np.arange(10),
                           np.arange(10)) is None


@cache
def _turned_capture(ctx: moderngl.Context) -> tuple[CaptureResult, Camera, Camera]:
    """A GPU photograph (s 30, the head turned 20°, the flash 5° above and 4° left, lobby sky) captured
    from its true camera turned by (−1.2°, +1.5°) with a 1° prior: (the result, the turned camera, the truth)."""
    from bench.capture_truth import Case, draw_case
    from capture.pipeline import capture
    from capture.probe import analyse_probe

    scene = draw_case(ctx, Case("sample", 30.0, environment="lobby", light_deg=(5.0, -4.0), ambient="irradiance",
                                yaw_deg=20.0))
    pivot = np.array(list(scene.head.metadata.landmarks.values())).mean(axis=0)
    turned = scene.camera.turned(np.radians([-1.2, 1.5, 0.0]), pivot)
    turned.rotation_covariance_deg2 = 9.0 * np.eye(2)
    result = capture(scene.head, scene.photo.linear, turned, probe=analyse_probe(scene.probe_linear),
                     texture_size=256)
    return result, turned, scene.camera


@pytest.mark.slow
@pytest.mark.gl
def test_the_lobe_turns_a_misaligned_camera_back(gl_ctx: moderngl.Context) -> None:
    """Turned by 1.92° (−1.2° about x, +1.5° about y), the refined camera is 1.15° off (measured), turned
    back along the way it was turned: one round keeps the first rasterisation's surface points, so it
    stops short of a turn this large (capture.pipeline.POSE_ROUNDS)."""
    result, turned, truth = _turned_capture(gl_ctx)
    assert result.pose is not None
    before = _turn_deg(turned, truth)
    after = _turn_deg(result.camera, truth)
    assert np.linalg.norm(before) == pytest.approx(1.92, abs=0.01)
    assert np.linalg.norm(after) < 1.3, (before, after, result.pose)
    correction = before - after
    assert correction @ before > 0.9 * np.linalg.norm(correction) * np.linalg.norm(before), (before, after)
