"""``sheer bench shade``: a smoke run through the ``sheer`` command (one skin, a 4-foundation large library,
32 skins of coverage). No assertion on timing: only that every figure is there with its p90 and maximum."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

from app.cli import main as sheer

if TYPE_CHECKING:
    import pytest


def test_sheer_bench_shade_prints_one_json_object(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["bench", "shade", "--json", "--skins", "1", "--large", "4", "--population", "32", "--repeats", "1"]
    assert sheer(argv) == 0
    result = json.loads(capsys.readouterr().out)
    for key in ("match_ms", "fit_ms", "match_ms_large", "coverage_s"):
        assert {key, f"{key}_p90", f"{key}_max"} <= set(result)
        assert result[key] > 0
    assert result["foundations"] == 6 and result["large_foundations"] == 4 and result["population"] == 32


def test_bad_options_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert sheer(["bench", "shade", "--skins", "0"]) == 2
    assert "--skins must be" in capsys.readouterr().err
