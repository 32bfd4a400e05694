"""The probe accepts ordinary flashes and refuses only what is truly ambiguous (issue 14).

Random flashes 0.5–3° across within 15° of the lens, in mirror balls of 256, 512 and 1024 px, the
flash's core averaged over 4 × 4 points per pixel (its rim pixels partly covered, as a sensor sees
them): ``sheer bench capture`` runs 600 (the README's figure); this runs 24 of them. Before issue 14,
17–71 % of such placements were refused as an "ambiguous highlight".
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from bench.capture import probe_acceptance, spot_core_deg
from capture.probe import ProbeError, analyse_probe, flash_reflection, probe_environment

pytestmark = pytest.mark.slow


def test_random_small_flashes_are_accepted_and_found() -> None:
    """Measured: 24 of 24 accepted, the light within 0.43° (600 placements in the bench: see the README)."""
    figures = probe_acceptance(24, seed=1)
    assert figures["probe_acceptance"] == 1.0, figures["probe_refusals"]
    assert figures["probe_error_deg_max"] < 0.6


def test_two_spots_of_similar_size_are_refused_with_both_positions() -> None:
    # A dark room with a lamp behind the camera as large as the flash in the ball, 4.6° off the axis
    # where the flash is 2.9° off: which is the flash cannot be told.
    R = np.eye(3)
    size = 256
    env = np.full((128, 256, 3), 0.01)
    ball = probe_environment(env, R, size)
    flash_dir = np.array([0.05, 0.0, -1.0])
    lamp_dir = np.array([-0.07, 0.04, -1.0])
    lobe = sum(flash_reflection(size, R, d, core_deg=spot_core_deg(2.0), supersample=4) for d in (flash_dir, lamp_dir))
    image = np.clip(ball + lobe[..., None], 0.0, 1.0)
    with pytest.raises(ProbeError, match="two saturated spots") as err:
        analyse_probe(image, source="ball.png")
    named = [tuple(map(float, m)) for m in re.findall(r"\(([\d.]+), ([\d.]+)\) px", str(err.value))]
    assert len(named) == 2, str(err.value)

    def pixel(d: np.ndarray) -> tuple[float, float]:  # where the ball reflects direction d (camera coords)
        n = (d / np.linalg.norm(d) - np.array([0.0, 0.0, 1.0]))
        n /= np.linalg.norm(n)
        return size / 2 * (1 + n[0]), size / 2 * (1 + n[1])

    truth = [pixel(flash_dir), pixel(lamp_dir)]
    for spot in truth:
        assert min(np.hypot(spot[0] - x, spot[1] - y) for x, y in named) < 1.5, (truth, named)
