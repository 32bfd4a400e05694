"""``sheer bench capture``: a smoke run through the ``sheer`` command (two probes, one exponent case):
one JSON object with the keys the README quotes."""

from __future__ import annotations

import json

import pytest

from app.cli import main as sheer

pytestmark = [pytest.mark.gl, pytest.mark.slow]


def test_sheer_bench_capture_prints_one_json_object(capsys: pytest.CaptureFixture[str]) -> None:
    assert sheer(["bench", "capture", "--json", "--placements", "2", "--cases", "1", "--skip", "auto", "--skip", "views",
                  "--skip", "tryon"]) == 0
    result = json.loads(capsys.readouterr().out)
    for key in ("probe_acceptance", "probe_error_deg_median", "probe_error_deg_max", "probe_refusals",
                "s_error_pct", "s_error_pct_p90", "s_error_pct_max", "s_within_10pct",
                "i_s_error_pct", "i_s_error_pct_max", "i_s_within_10pct", "light_deg", "light_deg_p90",
                "light_deg_max", "exponent_cases", "load_average"):
        assert key in result, key
    assert result["cases"] == 1 and result["probe_placements"] == 2
    assert result["truth"] == "photo"  # the default: shadows and a sensor
    assert result["focal"] == "exif"  # the default: the calibration knows the focal length, as EXIF gives it
    case = result["exponent_cases"][0]
    assert {"case", "s", "s_error_pct", "i_s_error_pct", "light_deg", "reproduction_de2000"} <= set(case)


def test_bad_options_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert sheer(["bench", "capture", "--json", "--placements", "0"]) == 2
    assert "--placements and --cases must be" in capsys.readouterr().err


def test_the_truth_option_draws_shadows_and_a_sensor_or_neither() -> None:
    """``--truth photo`` (the default) gives every scene the flash's shadows and a sensor seeded per scene;
    ``--truth plain`` neither (the figures before them)."""
    from bench.capture import exponent_cases

    photo = [case for _, case in exponent_cases(truth="photo")]
    plain = [case for _, case in exponent_cases(truth="plain")]
    assert len(photo) == len(plain) == 45
    assert all(c.shadows and c.sensor is not None and c.sensor.vignetting > 0 for c in photo)
    assert len({c.sensor.seed for c in photo if c.sensor is not None}) == 45
    assert not any(c.shadows or c.sensor is not None for c in plain)


def test_an_unknown_truth_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert sheer(["bench", "capture", "--json", "--truth", "rendered"]) == 2
    assert "--truth" in capsys.readouterr().err


def test_the_focal_option_gives_the_calibration_the_exif_focal_length_or_not(
        capsys: pytest.CaptureFixture[str]) -> None:
    """``--focal exif`` (the default): the noisy landmarks' calibration knows the true focal length rounded
    as EXIF stores it (274 mm in 35 mm terms for the bench's 4,579 px at 512²), the same noisy points;
    ``--focal none``: the portrait prior (the calibrated focal is then far off); a bad value exits 2."""
    import numpy as np

    from bench.capture import exponent_cases
    from bench.capture_truth import calibrated_camera, case_camera
    from painting.head import load_head

    exif = [case for _, case in exponent_cases(focal="exif")]
    none = [case for _, case in exponent_cases(focal="none")]
    assert all(c.focal == "exif" for c in exif) and all(c.focal == "none" for c in none)
    head = load_head()
    truth = case_camera(head, exif[0])
    with_focal = calibrated_camera(head, truth, exif[0])
    without = calibrated_camera(head, truth, none[0])
    assert round(float(truth.K[0, 0]) * np.hypot(36, 24) / np.hypot(truth.width, truth.height)) == 274
    ratios = (with_focal.K[0, 0] / truth.K[0, 0], without.K[0, 0] / truth.K[0, 0])
    assert abs(ratios[0] - 1) < 0.01 < 0.2 < abs(ratios[1] - 1), ratios
    assert sheer(["bench", "capture", "--json", "--focal", "true"]) == 2
    assert "--focal" in capsys.readouterr().err
