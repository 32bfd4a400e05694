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
                "i_s_error_pct", "i_s_error_pct_max", "exponent_cases", "load_average"):
        assert key in result, key
    assert result["cases"] == 1 and result["probe_placements"] == 2
    case = result["exponent_cases"][0]
    assert {"case", "s", "s_error_pct", "i_s_error_pct", "light_deg", "reproduction_de2000"} <= set(case)


def test_bad_options_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert sheer(["bench", "capture", "--json", "--placements", "0"]) == 2
    assert "--placements and --cases must be" in capsys.readouterr().err
