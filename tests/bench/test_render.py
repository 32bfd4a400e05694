"""``sheer bench render``: a smoke run in a small configuration through the ``sheer`` command: every key
(the names the README and earlier runs use), every median with its p90 and maximum beside it, and the
headline figures first."""

from __future__ import annotations

import json

import pytest

from app.cli import main as sheer

pytestmark = pytest.mark.gl

#: the medians (ms), each with ``_p90`` and ``_max``
MEDIANS = ("baseline_ms", "fast_ms", "reference_ms", "no_sss_ms", "fast_11_taps_ms", "fast_25_taps_ms",
           "fast_relight_ms", "fast_lit_pass_ms", "fast_sss_ms", "fast_composite_ms", "fast_floor_ms",
           "km_full_2048_ms", "km_tile_64_ms", "km_full_2048_dense_ms", "km_tile_64_dense_ms", "fast_direct_ms",
           "fast_cached_ms", "reference_lit_pass_ms", "reference_sss_ms", "reference_composite_ms",
           "baseline_64x64_ms", "fast_64x64_ms", "reference_64x64_ms")
OTHERS = {"size", "frames", "gl_renderer", "km_layers", "fast_over_baseline", "reference_over_baseline",
          "fast_floor_over_baseline", "fast_vs_reference_de2000", "skin_pixels", "reference_over_fast",
          "cached_over_direct", "cached_vs_direct_de2000", "load_average_1min"}
HEADLINE = ("baseline_ms", "fast_ms", "reference_ms", "fast_64x64_ms", "reference_64x64_ms", "fast_over_baseline",
            "reference_over_baseline", "fast_vs_reference_de2000", "km_full_2048_ms", "km_tile_64_ms")


def test_sheer_bench_render_prints_one_json_object(capsys: pytest.CaptureFixture[str]) -> None:
    assert sheer(["bench", "render", "--json", "--size", "64x48", "--frames", "3", "--km-resolution", "256"]) == 0
    result = json.loads(capsys.readouterr().out)
    spread = {f"{k}{s}" for k in MEDIANS for s in ("", "_p90", "_max")}
    assert set(result) == spread | OTHERS
    for key in MEDIANS:
        assert 0 < result[key] <= result[f"{key}_p90"] <= result[f"{key}_max"], key
    headline = [k for key in HEADLINE for k in ((key, f"{key}_p90", f"{key}_max") if key in MEDIANS else (key,))]
    assert list(result)[:len(headline)] == headline  # the headline figures first, each spread beside its median
    from painting import Document
    from painting.looks import apply_look

    evening = Document.from_head(resolution=256)
    apply_look(evening, "evening")  # the bench's look (its layer count follows the look file)
    assert result["size"] == "64x48" and result["frames"] == 3 and result["km_layers"] == len(evening.layers)
    assert result["fast_over_baseline"] == pytest.approx(result["fast_ms"] / result["baseline_ms"], rel=2e-3)
    assert 0 <= result["fast_vs_reference_de2000"] < 5 and result["skin_pixels"] > 0
    assert isinstance(result["gl_renderer"], str) and result["gl_renderer"]
    assert result["fast_cached_ms"] == result["fast_ms"]  # the studio's frame is the cached one
    assert result["reference_over_fast"] == pytest.approx(result["reference_ms"] / result["fast_ms"], rel=2e-3)
    assert 0 <= result["cached_vs_direct_de2000"] < 1.0
