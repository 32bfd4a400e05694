"""``sheer bench capture``'s automatic-capture section (issue #15): the fields the README quotes."""

from __future__ import annotations

import json

import pytest

from app.cli import main as sheer

pytestmark = [pytest.mark.slow]


def test_bench_capture_auto_fields(capsys: pytest.CaptureFixture[str]) -> None:
    from bench.capture import SECTIONS

    others = [a for name in ("exponent", "probe", *SECTIONS) if name != "auto" for a in ("--skip", name)]
    assert sheer(["bench", "capture", "--json", "--quick", *others]) == 0
    result = json.loads(capsys.readouterr().out)
    for key in ("landmarks_ms", "landmarks_ms_p90", "landmarks_ms_max", "landmarks_first_ms", "capture_auto_s",
                "capture_auto_s_p90", "capture_auto_s_max", "capture_auto_first_s", "capture_auto_cpu_s",
                "load_average"):
        assert key in result, key
    assert result["landmarks_runs"] == 9 and result["capture_auto_runs"] == 2
    assert 0 < result["landmarks_ms"] <= result["landmarks_ms_max"] and result["capture_auto_s"] > 0
    assert "probe_acceptance" not in result and "s_error_pct" not in result
    # the focal sweep (issue 14), quick: the two ends' lenses, the head frontal, with EXIF and without
    assert result["focal_lenses_mm"] == [26.0, 135.0] and result["focal_yaws_deg"] == [0.0]
    assert len(result["focal_cases"]) == 4 and set(result["focal_by_lens"]) == {"26", "135"}
    # the captured i_s and s against the drawn ones (i_s 0.18, s 24): relative errors in per cent, ≥ −100
    assert all(r["specular_error_pct"] >= -100.0 and r["exponent_error_pct"] > -100.0 for r in result["focal_cases"])
    assert "focal_specular_error_pct_exif" in result and "focal_exponent_error_pct_prior" in result
    assert result["focal_distance_error_pct_exif"] < 5.0 < 50.0 < result["focal_distance_error_pct_prior"]
    for lens in ("26", "135"):
        assert abs(result["focal_by_lens"][lens]["exif"]["focal_ratio"] - 1.0) < 0.1
        assert abs(result["focal_by_lens"][lens]["prior"]["focal_ratio"] - 1.0) > 0.5
