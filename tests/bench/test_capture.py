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
    ``--truth plain`` neither (the figures before them); ``--truth untextured`` neither, and a flat skin."""
    from bench.capture import exponent_cases

    photo = [case for _, case in exponent_cases(truth="photo")]
    plain = [case for _, case in exponent_cases(truth="plain")]
    assert len(photo) == len(plain) == 45
    assert all(c.shadows and c.sensor is not None and c.sensor.vignetting > 0 for c in photo)
    assert len({c.sensor.seed for c in photo if c.sensor is not None}) == 45
    assert not any(c.shadows or c.sensor is not None for c in plain)
    untextured = [case for _, case in exponent_cases(truth="untextured")]
    assert all(c.texture == "flat" and not c.shadows and c.sensor is None for c in untextured)
    assert all(c.texture == "skin" for c in photo + plain)


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


def test_the_pitch_option_spreads_s_by_pitch(capsys: pytest.CaptureFixture[str],
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """``--pitch``: the grid at −10°, 0 and +10° (135 scenes, the level ones the default run's 45), and
    ``s_error_pct_by_pitch`` per pitch, consistent with the cases and the overall figures. The capture is
    stood in for by an s error of 1.1 % per degree of pitch (−11, 0, +11 %: only the level ones within 10 %)."""
    import bench.capture_truth
    from bench.capture import PITCHES, exponent_cases
    from bench.capture_truth import Figures

    grid = exponent_cases(pitch=True)
    assert len(grid) == 135 and len({name for name, _ in grid}) == 135
    assert [c for _, c in grid if c.pitch_deg == 0.0] == [c for _, c in exponent_cases()]
    assert {c.pitch_deg for _, c in exponent_cases(quick=True, pitch=True)} == set(PITCHES)

    def fake(ctx: object, case: bench.capture_truth.Case) -> Figures:
        s = 0.011 * case.pitch_deg
        return Figures(0.1, s, 0.0, 0.5, 0.5, case.exponent * (1 + s), case.specular)

    monkeypatch.setattr(bench.capture_truth, "measure_case", fake)
    assert sheer(["bench", "capture", "--json", "--pitch", "--cases", "7", "--skip", "probe", "--skip", "auto",
                  "--skip", "views", "--skip", "tryon"]) == 0
    result = json.loads(capsys.readouterr().out)
    by_pitch = result["s_error_pct_by_pitch"]
    assert set(by_pitch) == {"-10", "+0", "+10"}
    assert sum(p["cases"] for p in by_pitch.values()) == result["cases"] == 7
    assert sum(p["s_within_10pct"] for p in by_pitch.values()) == result["s_within_10pct"]
    for key, figures in by_pitch.items():
        rows = [r for r in result["exponent_cases"] if r["pitch_deg"] == float(key)]
        assert figures["cases"] == len(rows) > 0
        assert figures["s_error_pct"] <= figures["s_error_pct_p90"] <= figures["s_error_pct_max"]
        assert figures["s_error_pct_max"] == max(abs(r["s_error_pct"]) for r in rows)
        assert figures["s_bias_pct"] == pytest.approx(1.1 * float(key))
        assert figures["s_within_10pct"] == (len(rows) if key == "+0" else 0)


def test_a_pitched_camera_is_above_the_eyes_looking_down() -> None:
    """``pitch_deg`` raises the camera about the face's centre at the same distance (positive: above,
    looking down); 0 is the validation's camera, as before the field."""
    import numpy as np

    from bench.capture_synthetic import validation_camera
    from bench.capture_truth import Case, case_camera
    from painting.head import load_head

    head = load_head()
    level = case_camera(head, Case("sample", 24.0))
    assert np.array_equal(level.K, validation_camera().K) and np.array_equal(level.R, validation_camera().R)
    for pitch in (-10.0, 10.0):
        cam = case_camera(head, Case("sample", 24.0, pitch_deg=pitch))
        offset = cam.centre - np.array([0.0, 1.3, 0.0])
        assert np.linalg.norm(offset) == pytest.approx(np.linalg.norm(level.centre - np.array([0.0, 1.3, 0.0])))
        assert np.degrees(np.arcsin(offset[1] / np.linalg.norm(offset))) == pytest.approx(pitch)
        forward = cam.R[2]  # the camera's viewing axis in world coordinates (+Z in camera space)
        assert np.sign(forward[1]) == -np.sign(pitch)  # raised: looking down
