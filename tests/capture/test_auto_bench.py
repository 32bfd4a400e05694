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
