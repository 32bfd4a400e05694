"""GPU frame timing for the benchmarks: configurations' frames interleaved round-robin, each finished on the GPU."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from bench.stats import spread

if TYPE_CHECKING:
    from collections.abc import Callable

    import moderngl


def interleaved_times_ms(ctx: moderngl.Context, configs: dict[str, Callable[[], None]], frames: int,
                         warmup: int = 2) -> dict[str, list[float]]:
    """Each configuration's frame times (ms), ``frames`` of each after ``warmup`` untimed ones.

    One frame of each configuration per round, so a CPU shared with other work loads them alike; each
    frame is timed from a finished GPU (``ctx.finish()``) to its own finish.
    """
    times: dict[str, list[float]] = {k: [] for k in configs}
    for fn in configs.values():
        for _ in range(warmup):
            fn()
    for _ in range(frames):
        for key, fn in configs.items():
            ctx.finish()
            t = time.perf_counter()
            fn()
            ctx.finish()
            times[key].append((time.perf_counter() - t) * 1000.0)
    return times


def interleaved_ms(ctx: moderngl.Context, configs: dict[str, Callable[[], None]], frames: int,
                   warmup: int = 2) -> dict[str, float]:
    """Median, p90 and maximum (ms, see :func:`bench.stats.spread`) of each configuration's frames.

    The frames of :func:`interleaved_times_ms`, summarised to 3 decimals.
    """
    out: dict[str, float] = {}
    for k, v in interleaved_times_ms(ctx, configs, frames, warmup).items():
        out.update(spread(k, v, digits=3))
    return out
