"""bench.stats.spread: a median with its 90th percentile and maximum, rounded without losing a short time."""

from __future__ import annotations

from bench.stats import spread


def test_spread_rounds_to_its_digits_but_never_a_short_time_to_zero() -> None:
    assert spread("t", [1.234, 2.345, 9.876], 2) == {"t": 2.35, "t_p90": 8.37, "t_max": 9.88}
    # a frame interval of a few microseconds is small, not nothing: three significant digits
    short = spread("frame_ms", [0.00412, 0.00431, 0.00468], 2)
    assert short == {"frame_ms": 0.00431, "frame_ms_p90": 0.00461, "frame_ms_max": 0.00468}
    assert 0 < short["frame_ms"] <= short["frame_ms_p90"] <= short["frame_ms_max"]
    assert spread("idle_ms", [0.0, 0.0], 1) == {"idle_ms": 0.0, "idle_ms_p90": 0.0, "idle_ms_max": 0.0}
