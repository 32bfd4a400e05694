"""``sheer bench lightweight``: a smoke run in a small configuration through the ``sheer`` command: every
key, every median frame time with its p90 and maximum beside it, and the eight-light figure saying that it
compares shadows per vertex."""

from __future__ import annotations

import json

import pytest

from app.cli import main as sheer

pytestmark = [pytest.mark.gl, pytest.mark.slow]

#: the median frame times (ms), each with ``_p90`` and ``_max``
MEDIANS = ("baseline_ms", "one_light_ms", "eight_lights_shadows_ms", "eight_lights_shadows_moving_ms")
OTHERS = {"size", "frames", "triangles", "eight_lights_shadow_mode", "one_light_over_baseline",
          "eight_lights_shadows_over_baseline", "capture_s", "robustness", "validation", "note"}


def test_sheer_bench_lightweight_prints_one_json_object(capsys: pytest.CaptureFixture[str]) -> None:
    # a 256² detail texture (the capture's own is 1024²): the keys and invariants are tested, not the figures
    assert sheer(["bench", "lightweight", "--json", "--size", "64x48", "--frames", "3", "--starts", "0",
                  "--texture-size", "256"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert set(result) == {f"{k}{s}" for k in MEDIANS for s in ("", "_p90", "_max")} | OTHERS
    for key in MEDIANS:
        assert 0 < result[key] <= result[f"{key}_p90"] <= result[f"{key}_max"], key
    assert result["eight_lights_shadow_mode"] == "vertex"  # eight shadowed lights: compared per vertex
    assert result["size"] == [64, 48] and result["frames"] == 3 and result["triangles"] > 1000
    assert result["eight_lights_shadows_over_baseline"] == pytest.approx(
        result["eight_lights_shadows_ms"] / result["baseline_ms"])
    assert result["capture_s"] > 0 and result["robustness"] == {}  # --starts 0 skips the robustness run
    assert "256² detail texture" in result["note"]
    assert set(result["validation"]) == {"reproduction_mean_de2000_skin", "exponent", "exponent_true",
                                         "residual_rms_luv"}
