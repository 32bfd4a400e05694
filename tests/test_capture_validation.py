"""Synthetic ground truth (issue 7): the sample head rendered with known Phong parameters under a known
flash near the camera, a mirror-ball probe from an HDR environment plus that flash; the capture must
recover the light direction within 2°, the diffuse colour within ΔE2000 1.0, s within 10 %, and
reproduce the photograph on skin. Also the face folder round trip and the CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from capture.phong import delta_e2000

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def synthetic() -> tuple[object, object, object]:
    from capture.pipeline import capture
    from capture.probe import analyse_probe
    from capture.synthetic import make_scene, read_env
    from painting.head import load_head
    from resources import find_asset

    head = load_head()
    scene = make_scene(head, read_env(str(find_asset("environments/warehouse.exr"))))
    probe = analyse_probe(scene.probe_lin)
    result = capture(head, scene.photo_lin, scene.camera, probe=probe, texture_size=512, robustness_starts=8)
    return head, scene, result


def test_light_direction_within_2_degrees(synthetic: tuple) -> None:
    _, scene, result = synthetic
    err = np.degrees(np.arccos(np.clip(result.light_dir_world @ scene.light_dir_world, -1, 1)))
    assert err < 2.0


def test_diffuse_colour_within_de2000_1(synthetic: tuple) -> None:
    _, scene, result = synthetic
    assert float(delta_e2000(result.params.diffuse, scene.params.diffuse)) < 1.0


def test_exponent(synthetic: tuple) -> None:
    # Issue target: within 10 %. The saturation-curve estimate alone gives 28.5 for 24 (+19 %; the skin
    # texture's regional chroma shifts the profile); the robust Luv refinement over the lobe gives 24.0.
    # Measured elsewhere (true s, environment): 12 studio 12.2, 12 warehouse 13.0, 40 city 38.4,
    # 40 sunset 38.6.
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
    # Issue target: mean ΔE2000 < 2 on skin (measured 1.6 at a 512² detail texture... see the report).
    _, _, result = synthetic
    assert result.reproduction_de2000_skin < 2.0
    assert result.robustness is not None and result.robustness["max_relative_std"] < 0.025


def test_face_folder_round_trip(synthetic: tuple, tmp_path: Path) -> None:
    from capture.pipeline import load_face, write_face

    _, _, result = synthetic
    out = write_face(result, tmp_path / "face")
    face = load_face(out)
    assert face.detail.dtype == np.float32 and face.detail.shape == (512, 512, 3)
    assert np.allclose(face.params.diffuse, result.params.diffuse)
    assert float(face.detail.min()) >= 0.0 and float(face.detail.max()) <= 8.0
    data = json.loads((out / "face.json").read_text())
    assert data["residual"]["rms_luv_per_pixel"] > 0
    assert (out / "report.png").is_file()
