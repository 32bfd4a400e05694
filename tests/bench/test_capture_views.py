"""``bench.capture_views`` (issue 15): the mirror and relight views' frame times, as ``sheer bench capture``
prints them (quick: three frames of each, interleaved with the baseline)."""

from __future__ import annotations

import pytest

pytestmark = [pytest.mark.gl, pytest.mark.slow]


def test_measure_gives_the_frame_times_against_the_baseline() -> None:
    from bench.capture import SECTIONS
    from bench.capture_views import measure

    assert SECTIONS["views"] == "bench.capture_views:measure"
    out = measure(quick=True)
    for key in ("views_baseline_ms", "mirror_frame_ms", "relight_frame_ms", "views_swap_ms"):
        assert out[key] > 0 and out[f"{key}_p90"] >= out[key] and out[f"{key}_max"] >= out[f"{key}_p90"], key
    assert out["mirror_over_baseline"] == pytest.approx(out["mirror_frame_ms"] / out["views_baseline_ms"])
    assert out["views_size"] == [512, 512] and out["views_frames"] == 3
