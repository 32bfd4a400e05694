"""capture/: camera calibration, probe analysis, Eq. 3, the rasteriser and the synthetic validation."""

from __future__ import annotations

import numpy as np
import pytest

from capture.camera import Camera, CameraError, calibrate
from capture.probe import analyse_probe, light_direction_from_highlight, synthetic_probe
from capture.reflectance import eq3_exponent


def test_eq3_small_angle_limit_and_monotone() -> None:
    for deg in (1.0, 2.0, 4.0):
        a = np.radians(deg)
        assert eq3_exponent(a) == pytest.approx(1 / (4 * a * a), rel=0.02)
    vals = [eq3_exponent(np.radians(d)) for d in (2, 5, 10, 20)]
    assert all(x > y for x, y in zip(vals, vals[1:]))


def test_calibrate_recovers_camera_from_noisy_points() -> None:
    cam = Camera.looking_at(np.array([0.5, 1.0, 30.0]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 1.0, 0.0]),
                            10.0, 640, 480)
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


def _probe_with(env: np.ndarray, light: np.ndarray, flash: np.ndarray, env_scale: float = 1.0) -> np.ndarray:
    """A synthetic probe (camera = world axes), 8-bit sRGB quantised like a photograph, linear again."""
    from bench.capture_synthetic import as_photographed

    img = synthetic_probe(env, np.eye(3), light / np.linalg.norm(light), flash, size=256, env_scale=env_scale)
    return as_photographed(img)


def test_probe_flash_hue_across_a_horizon_and_ambient_over_the_whole_ball() -> None:
    # The flash's halo straddles a bright orange sky over a dark ground: subtracting a ring's median
    # (the previous method) got the hue 5–7 % wrong on such probes; the per-ray regression does not.
    env = np.zeros((64, 128, 3))
    env[:32] = [0.5, 0.25, 0.08]   # sky
    env[32:] = [0.02, 0.02, 0.03]  # ground
    flash = np.array([1.0, 0.95, 0.85])
    flash = flash / float(flash @ [0.2126, 0.7152, 0.0722])
    res = analyse_probe(_probe_with(env, np.array([0.06, 0.0, -1.0]), flash))
    assert np.allclose(res.flash_rgb, flash, rtol=0.02)
    # Ambient: the mean radiance over all directions (half sky, half ground), not the ring's.
    assert np.allclose(res.ambient_rgb, 0.5 * (env[0, 0] + env[-1, 0]), rtol=0.08)


def test_probe_prefers_the_all_channel_clipped_flash_over_an_orange_lamp_beside_it() -> None:
    # A lamp behind the camera, clipping only red, touching the flash's reflection (the night
    # environment's horizon glow did this: the highlight was taken 12° off).
    env = np.full((128, 256, 3), 0.01)
    env[62:66, 129:133] = [40.0, 0.5, 0.1]  # longitude 2–8° (0 = −Z, behind the camera with R = I)
    light = np.array([0.0, -0.02, -1.0])
    flash = np.ones(3)
    img = _probe_with(env, light, flash)
    red_only = (img[..., 0] >= 0.98) & (img[..., 1] < 0.98)
    assert red_only.sum() > 20  # the lamp clips red right beside the flash
    res = analyse_probe(img)
    err = np.degrees(np.arccos(np.clip(res.light_dir_camera @ (light / np.linalg.norm(light)), -1, 1)))
    assert err < 1.0


@pytest.mark.parametrize("case", ["merged", "rival"])
def test_probe_reports_an_ambiguous_highlight(case: str) -> None:
    from capture.probe import ProbeError

    env = np.full((128, 256, 3), 0.01)
    if case == "merged":  # a white strip light running through the flash's reflection
        env[62:66, 100:160] = 50.0
        light = np.array([0.0, 0.0, -1.0])
    else:  # a white lamp as large as the flash's core, at about the same angle off the axis
        env[57:61, 121:125] = 50.0
        light = np.array([0.08, 0.0, -1.0])
    with pytest.raises(ProbeError, match="ambiguous"):
        analyse_probe(_probe_with(env, light, np.ones(3)), source="ball.png")


def test_camera_gbuffer_is_perspective_correct_on_paintings_rasteriser() -> None:
    # capture.raster adapts painting.raster (affine barycentrics) to a camera: the position interpolated
    # with its barycentrics must project back onto each pixel's centre (affine ones miss by up to 26 px
    # on a plane this oblique), and triangles behind the camera are left out.
    cam = Camera.looking_at(np.array([0.0, 0.0, 3.0]), np.zeros(3), np.array([0.0, 1.0, 0.0]), 60.0, 64, 48)
    verts = np.array([[-2.0, -1.0, 1.5], [2.0, -1.0, 1.5], [2.0, 1.0, -6.0], [-2.0, 1.0, -6.0],
                      [0.0, 0.0, 5.0], [0.5, 0.0, 5.0], [0.0, 0.5, 5.0]])  # an oblique quad; a triangle behind
    faces = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6]])
    gb = cam.gbuffer(verts, faces)
    assert gb.covered.sum() > 500 and set(np.unique(gb.tri)) <= {-1, 0, 1}
    rows, cols = np.nonzero(gb.covered)
    pos = gb.interpolate(faces, verts)[rows, cols]
    px, _ = cam.project(pos)
    assert np.abs(px - np.stack([cols + 0.5, rows + 0.5], axis=1)).max() < 1e-3


def test_specular_intensity_is_separated_from_albedo_brighter_under_the_lobe() -> None:
    # A sphere seen head-on (240² pixels), Phong with s 24 and i_s 0.18, its albedo 12 % brighter in a
    # broad patch around the highlight (σ 3× the specular core's radius) plus fine pore-like noise. The
    # paper's joint fit reads the brighter skin as specular; the refit on the high-passed photograph
    # (capture.lobe.specular_from_detail, s fitted too) does not. Measured: joint 0.219 (+22 %), separated
    # 0.185 (+2.9 %) with s 23.1 (−3.7 %; this sphere is sampled at pixel centres, the fit models a pixel's box).
    from capture.lobe import specular_from_detail
    from capture.phong import Geometry, PhongParams, fit_phong, shade

    n_px = 240
    yy, xx = np.mgrid[0:n_px, 0:n_px]
    x, y = (xx + 0.5) / n_px * 2 - 1, (yy + 0.5) / n_px * 2 - 1
    inside = x ** 2 + y ** 2 < 0.95 ** 2
    rows, cols = np.nonzero(inside)
    nrm = np.stack([x[inside], -y[inside], np.sqrt(1 - x[inside] ** 2 - y[inside] ** 2)], axis=1)
    view = np.tile([0.0, 0.0, 1.0], (len(rows), 1))
    light = np.array([0.08, 0.06, 1.0]) / np.linalg.norm([0.08, 0.06, 1.0])
    geo = Geometry.from_vectors(nrm, view, light)
    truth = PhongParams(diffuse=np.array([0.46, 0.31, 0.245]), specular=0.18, exponent=24.0, ambient_scale=1.0,
                        flash_rgb=np.ones(3), ambient_rgb=np.full(3, 0.04))
    lobe = np.clip(geo.r_dot_v, 0, None) ** 24
    core_r = np.sqrt((lobe >= 0.5).sum() / np.pi)
    peak = np.array([rows[lobe.argmax()], cols[lobe.argmax()]])
    d2 = (rows - peak[0]) ** 2 + (cols - peak[1]) ** 2
    albedo = (1 + 0.12 * np.exp(-d2 / (2 * (3 * core_r) ** 2))) * (1 + 0.05 * np.random.default_rng(0).standard_normal(len(rows)))
    body = PhongParams(**{**truth.__dict__, "specular": 0.0})
    photo = np.clip(shade(body, geo, clip=False) * albedo[:, None] + 0.18 * lobe[:, None], 0, 1)
    joint = fit_phong(photo, geo, 24.0, truth.flash_rgb, truth.ambient_rgb).params
    sep = specular_from_detail(photo, geo, joint, rows, cols, (n_px, n_px))
    assert joint.specular > 0.18 * 1.10  # the paper's joint fit: biased by the brighter albedo
    assert sep is not None and abs(sep.specular / 0.18 - 1) < 0.03
    assert abs(sep.exponent / 24 - 1) < 0.05


def test_equirect_conventions_agree_up_to_a_turn_and_neither_is_mirrored() -> None:
    # capture.probe.equirect_lookup (the synthetic probes and photographs) and render.lights'
    # equirect_directions (sheer render --env) read the same EXR: each texel's direction in one is the
    # other's turned 180° about +Y (a rotation, not a mirror: a lamp on the subject's left stays there).
    from capture.probe import equirect_lookup
    from render.lights import equirect_directions

    h, w = 16, 32
    d_render, _ = equirect_directions(h, w)
    turned = d_render * np.array([-1.0, 1.0, -1.0])
    for row, col in [(3, 5), (8, 16), (12, 24), (7, 30)]:
        env = np.zeros((h, w, 3))
        env[row, col] = 1.0
        assert equirect_lookup(env, turned[row, col][None])[0, 0] == pytest.approx(1.0, abs=1e-9), (row, col)
    up = np.array([0.0, 1.0, 0.0])

    def capture_direction(col: int) -> np.ndarray:  # the centre of column ``col`` on the horizon
        lon = ((col + 0.5) / w - 0.5) * 2 * np.pi
        return np.array([np.sin(lon), 0.0, -np.cos(lon)])

    env = np.zeros((h, w, 3))
    env[h // 2 - 1:h // 2 + 1, w // 2 + 1] = 1.0  # the horizon lies between rows h/2 - 1 and h/2
    assert equirect_lookup(env, capture_direction(w // 2 + 1)[None])[0, 0] == pytest.approx(1.0, abs=1e-9)
    # Facing the middle column, one column to the image's right is the viewer's right (forward × up).
    for forward, right in [(d_render[h // 2, w // 2], d_render[h // 2, w // 2 + 1]),
                           (capture_direction(w // 2), capture_direction(w // 2 + 1))]:
        assert np.cross(forward, up) @ right > 0


def test_probe_reflectance_divides_the_ambient_only() -> None:
    # A chrome ball reflects a fraction R of the room: the ambient is the ball's mean / R; the flash's
    # direction and hue are the same whatever R.
    from capture.probe import ProbeError

    env = np.full((64, 128, 3), 0.02)
    env[:32] = [0.03, 0.02, 0.01]
    img = _probe_with(env, np.array([0.05, -0.03, -1.0]), np.ones(3))
    mirror, chrome = analyse_probe(img), analyse_probe(img, reflectance=0.6)
    np.testing.assert_allclose(chrome.ambient_rgb, mirror.ambient_rgb / 0.6, rtol=1e-12)
    np.testing.assert_allclose(chrome.light_dir_camera, mirror.light_dir_camera)
    np.testing.assert_allclose(chrome.flash_rgb, mirror.flash_rgb)
    assert chrome.to_json()["reflectance"] == 0.6
    for bad in (0.0, 1.2, float("nan")):
        with pytest.raises(ProbeError, match="reflectance"):
            analyse_probe(img, reflectance=bad)
