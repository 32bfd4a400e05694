"""Synthetic ground truth (issue 7): the sample head rendered with known Phong parameters under a known
flash near the camera, a mirror-ball probe from an HDR environment plus that flash; the capture must
recover the light direction within 2°, the diffuse colour within ΔE2000 1.0, s within 10 %, the
specular intensity i_s within 5 % (ours: the skin's albedo is brighter under the lobe, which the paper's
joint fit reads as specular), and reproduce the photograph on skin with a mean ΔE2000 under 2 — for
EVERY environment shipped in ``environments/``. Also the probe's ambiguity checks, the face folder round trip and the CLI."""

from __future__ import annotations

import json
from functools import cache
from typing import TYPE_CHECKING

import numpy as np
import pytest

from capture.phong import delta_e2000

if TYPE_CHECKING:
    from pathlib import Path

pytestmark = pytest.mark.slow


def _environments() -> list[str]:
    from core.assets import find_asset

    return sorted(p.stem for p in find_asset("environments").glob("*.exr"))


ENVIRONMENTS = _environments()


@cache
def _captured(env: str, starts: int = 0) -> tuple[object, object, object]:
    """(head, scene, capture result) for the synthetic photograph and probe made from ``env``."""
    from bench.capture_synthetic import make_scene, read_env
    from capture.pipeline import capture
    from capture.probe import analyse_probe
    from core.assets import find_asset
    from painting.head import load_head

    head = load_head()
    scene = make_scene(head, read_env(str(find_asset(f"environments/{env}.exr"))))
    probe = analyse_probe(scene.probe_lin, source=f"{env} probe")
    result = capture(head, scene.photo_lin, scene.camera, probe=probe, texture_size=512,
                     robustness_starts=starts)
    return head, scene, result


@pytest.fixture(scope="module")
def synthetic() -> tuple[object, object, object]:
    return _captured("warehouse", 8)


def test_every_environment_is_covered() -> None:
    # The six shipped with the assets; a new one is picked up by the parametrisation below.
    assert {"city", "lobby", "night", "studio", "sunset", "warehouse"} <= set(ENVIRONMENTS)


@pytest.mark.parametrize("env", ENVIRONMENTS)
def test_recovers_the_truth_in_every_environment(env: str) -> None:
    """Measured (light angle, s error, i_s error, diffuse ΔE2000, reproduction ΔE2000): city 0.14° +5.9 %
    +1.7 % 0.02 0.49; lobby 0.14° +6.0 % +2.2 % 0.49 0.49; night 0.17° +5.9 % +1.2 % 0.08 0.49; studio
    0.14° +5.8 % +1.7 % 0.69 0.49; sunset 0.14° +5.9 % +1.5 % 0.41 0.49; warehouse 0.14° +5.7 % +1.6 %
    0.51 0.49 (the reproduction was 1.55–1.59 before issue 15, while the detail texture was the
    photograph ÷ the reflectance map; it is the photograph ÷ the fitted model now). s is 6 % high because this photograph samples each pixel's centre and the fit models a
    sensor's pixel integration (capture.lobe.specular_from_detail). i_s from the joint fit alone (the
    paper's) is +28 to +32 % (0.231-0.238): the skin is brighter under the lobe. The diffuse colour's
    remaining error is mostly the probe's clipped lamps (studio: the ambient measured is 37 % of the truth)."""
    _, scene, result = _captured(env, 8 if env == "warehouse" else 0)
    angle = np.degrees(np.arccos(np.clip(result.light_dir_world @ scene.light_dir_world, -1, 1)))
    s_err = result.exponent.s / scene.params.exponent - 1
    de_d = float(delta_e2000(result.params.diffuse, scene.params.diffuse))
    is_err = result.params.specular / scene.params.specular - 1
    figures = (f"{env}: light {angle:.2f}°, s {result.exponent.s:.1f} for {scene.params.exponent:g}, "
               f"i_s {result.params.specular:.4f} for {scene.params.specular:g} (joint fit "
               f"{result.specular_joint:.4f}), diffuse ΔE2000 {de_d:.2f}, "
               f"reproduction {result.reproduction_de2000_skin:.2f}")
    assert angle < 2.0, figures
    assert abs(s_err) < 0.10, figures
    assert abs(is_err) < 0.05, figures
    assert de_d < 1.0, figures
    assert result.reproduction_de2000_skin < 2.0, figures


def test_light_direction_within_2_degrees(synthetic: tuple) -> None:
    _, scene, result = synthetic
    err = np.degrees(np.arccos(np.clip(result.light_dir_world @ scene.light_dir_world, -1, 1)))
    assert err < 2.0


def test_diffuse_colour_within_de2000_1(synthetic: tuple) -> None:
    _, scene, result = synthetic
    assert float(delta_e2000(result.params.diffuse, scene.params.diffuse)) < 1.0


def test_probe_ambient_is_the_environments_mean_radiance(synthetic: tuple) -> None:
    # The whole ball (an equal-area map of the directions), not a ring behind the camera: in the
    # lobby the ring had a tenth of the level and another hue. Here only the clipped lamps are missing.
    from capture.probe import analyse_probe

    for env in ("city", "lobby"):
        _, scene, _ = _captured(env, 0)
        a = analyse_probe(scene.probe_lin).ambient_rgb
        truth = scene.params.ambient_rgb
        assert np.allclose(a / a.sum(), truth / truth.sum(), atol=0.01), env
        assert 0.8 < float(a.sum() / truth.sum()) < 1.1, env


def test_exponent(synthetic: tuple) -> None:
    # Issue target: within 10 %. The saturation-curve estimate alone gives 28.5 for 24 (+19 %; the skin
    # texture's regional chroma shifts the profile); the fit on the photograph high-passed at 2 px gives
    # 25.4 (+5.7 %: this photograph samples pixel centres, the fit models a pixel's integration). Other
    # exponents (the README's): 12 studio 11.83, 40 city 42.81 (tests/capture/test_out_of_sample.py).
    _, scene, result = synthetic
    assert abs(result.exponent.s / scene.params.exponent - 1) < 0.10
    assert result.exponent.s_saturation is not None


def test_exponent_estimator_on_untextured_skin(synthetic: tuple) -> None:
    from capture.phong import Geometry, shade
    from capture.pipeline import pixel_data
    from capture.reflectance import estimate_exponent

    head, scene, result = synthetic
    pix = pixel_data(head, scene.camera)
    sel = result.skin_mask[pix.rows, pix.cols]
    n, v = pix.normals[sel], pix.view[sel]
    colours = shade(scene.params, Geometry.from_vectors(n, v, scene.light_dir_world))
    est = estimate_exponent(n, v, scene.light_dir_world, colours, scene.camera.R[0])
    assert abs(est.s / scene.params.exponent - 1) < 0.10
    assert est.s_eq3 < est.s  # Eq. 3 alone underestimates at this specular/diffuse ratio


def test_reproduction_and_robustness(synthetic: tuple) -> None:
    # Issue target: mean ΔE2000 < 2 on skin (measured 0.49 at a 512² detail texture; 1.6 before issue 15).
    _, _, result = synthetic
    assert result.reproduction_de2000_skin < 2.0
    assert result.robustness is not None and result.robustness["max_relative_std"] < 0.025


def test_face_folder_round_trip(synthetic: tuple, tmp_path: Path) -> None:
    from capture.face import load_face, write_face

    _, _, result = synthetic
    out = write_face(result, tmp_path / "face")
    face = load_face(out)
    assert face.detail.dtype == np.float32 and face.detail.shape == (512, 512, 3)
    assert np.allclose(face.params.diffuse, result.params.diffuse)
    assert float(face.detail.min()) >= 0.0 and float(face.detail.max()) <= 8.0
    data = json.loads((out / "face.json").read_text())
    assert data["residual"]["rms_luv_per_pixel"] > 0
    assert (out / "report.png").is_file()


def test_unseen_texels_are_filled_smoothly_from_their_3d_neighbours(synthetic: tuple) -> None:
    # Texels the photograph does not see: the seen detail low-passed at the nearest seen texel in 3D,
    # faded to 1 (measured: texel-to-texel change 0.18× the seen skin's, median |detail − 1| 0.01).
    # The nearest-in-UV copy it replaces smeared pores into streaks (0.51×) and carried values from
    # across seams (median |detail − 1| 0.71).
    from capture.raster import rasterize_uv

    head, _, result = synthetic
    size = result.detail.shape[0]
    covered = rasterize_uv(head.uv, head.faces, (size, size)).covered
    y = result.detail @ np.array([0.2126, 0.7152, 0.0722])
    seen = result.detail_valid
    unseen = covered & ~seen

    def mean_step(m: np.ndarray) -> float:
        gx = np.abs(np.diff(y, axis=1))[m[:, 1:] & m[:, :-1]]
        gy = np.abs(np.diff(y, axis=0))[m[1:] & m[:-1]]
        return float(np.r_[gx, gy].mean())

    assert unseen.sum() > 1000
    assert mean_step(unseen) < 0.3 * mean_step(seen)
    assert float(np.median(np.abs(y[unseen] - 1.0))) < 0.1


@pytest.mark.parametrize(("level", "worst_deg"), [(1.0, 1.0), (3.0, 2.8), (10.0, None)])
def test_night_probe_finds_the_flash_or_says_it_is_ambiguous(level: float, worst_deg: float | None) -> None:
    # The night's horizon glow lies behind the camera, beside the flash's reflection. At the validation's
    # level it clips only red and the flash (every channel clipped) is found; at 3× it clips white and
    # merges with the flash into a round 53-pixel spot that no shape test tells from a flash's own
    # (1.00× its inscribed disc; a digitised disc of that size measures up to 1.45): taken as is, the
    # light is 2.76° off — the probe's limit, measured here (issue 14 asks to refuse only what is
    # truly ambiguous: the flash on the lens's axis was refused as merged). At 10× the clipped region
    # is centred 30° off the axis: a ProbeError, not a guess.
    from bench.capture_synthetic import (
        DIM_ROOM,
        as_photographed,
        env_mean_radiance,
        light_from_camera,
        read_env,
        validation_camera,
    )
    from capture.probe import ProbeError, analyse_probe, synthetic_probe
    from core.assets import find_asset

    env = read_env(str(find_asset("environments/night.exr")))
    cam = validation_camera()
    light = light_from_camera(cam, 4.0, 3.0)
    img = synthetic_probe(env, cam.R, light, np.ones(3), size=256,
                          env_scale=level * DIM_ROOM / float(env_mean_radiance(env).mean()))
    img = as_photographed(img)
    if worst_deg is not None:
        probe = analyse_probe(img)
        assert np.degrees(np.arccos(np.clip(cam.R.T @ probe.light_dir_camera @ light, -1, 1))) < worst_deg
    else:
        with pytest.raises(ProbeError, match="ambiguous"):
            analyse_probe(img, source="night.png")
