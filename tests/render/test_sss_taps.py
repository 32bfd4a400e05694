"""The fast SSS kernel's tap count follows its width on screen (render.sss_passes.fast_taps)."""

from __future__ import annotations

from render.sss_passes import FEW_TAPS, FEW_TAPS_MAX_RANGE_PX, fast_taps


def test_few_taps_only_for_a_narrow_kernel() -> None:
    # the widest Gaussian's ±3σ is 8.17 mm: 20.5 px at the studio's framing (0.4 mm a pixel)
    assert fast_taps(17, 1.0, 0.4) == FEW_TAPS
    assert fast_taps(17, 1.0, 0.2) == 17  # twice the zoom: the setting's taps
    assert fast_taps(25, 1.0, 0.2) == 25
    assert fast_taps(11, 1.0, 0.01) == 11  # never more than the setting
    assert fast_taps(17, 2.0, 0.4) == 17  # a wider profile spans more pixels
    edge = 3.0 * 7.41 ** 0.5 / FEW_TAPS_MAX_RANGE_PX
    assert fast_taps(17, 1.0, edge * 1.001) == FEW_TAPS and fast_taps(17, 1.0, edge * 0.999) == 17
