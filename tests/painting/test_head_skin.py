"""The head's skin colour (painting.head.Head.skin_rgb), read by the studio's Shade Finder and the kiosk."""

from __future__ import annotations

import dataclasses

import numpy as np

from km.srgb import srgb_decode
from painting.head import DEFAULT_SKIN_RGB, load_head


def test_skin_is_the_median_of_the_albedos_middle_third() -> None:
    head = load_head(None)
    albedo = np.zeros((90, 60, 3), np.uint8)  # black outside the middle third: it must not count
    rng = np.random.default_rng(3)
    middle = rng.integers(100, 220, (30, 20, 3), dtype=np.uint8)
    albedo[30:60, 20:40] = middle
    got = dataclasses.replace(head, albedo=albedo).skin_rgb()
    want = np.median(srgb_decode(middle.reshape(-1, 3) / 255.0), axis=0)
    assert got.dtype == np.float64 and got.shape == (3,)
    np.testing.assert_array_equal(got, want)


def test_a_head_without_albedo_has_the_default_skin() -> None:
    head = dataclasses.replace(load_head(None), albedo=None)
    np.testing.assert_array_equal(head.skin_rgb(), DEFAULT_SKIN_RGB)
