"""Thickness maps are cleaned the same way whole and by tiles: NaN, ±inf and negatives evaluate as no
layer there (render.km_pass.clean_thickness, the start-up's cheaper cleaning, issue #13)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pytest

import km
from render.km_pass import KMTextureSpace, LayerInput, clean_thickness
from render.shaders import ShaderLibrary

if TYPE_CHECKING:
    from collections.abc import Iterator

pytestmark = pytest.mark.gl


def _bad(shape: tuple[int, int]) -> np.ndarray:
    a = np.full(shape, 12.0, np.float32)
    a[3, 5], a[70, 9], a[9, 100], a[100, 100] = np.nan, np.inf, -np.inf, -4.0
    return a


def test_clean_thickness_is_nan_to_num_then_non_negative() -> None:
    a = _bad((128, 128))
    for src in (a, a.astype(np.float64), a.T, a[::2, 1::2]):
        want = np.maximum(np.nan_to_num(np.asarray(src, np.float32), nan=0.0, posinf=0.0, neginf=0.0), 0.0)
        got = clean_thickness(src)
        np.testing.assert_array_equal(got, want)
        assert got.dtype == np.float32 and got.flags.c_contiguous and not np.shares_memory(got, src)
    assert clean_thickness(np.zeros((0, 4), np.float32)).shape == (0, 4)


@pytest.fixture
def km_pass(gl_ctx: object) -> Iterator[KMTextureSpace]:
    p = KMTextureSpace(gl_ctx, ShaderLibrary(), dtype="f4")
    yield p
    p.release()


def test_bad_texels_evaluate_as_bare_whole_and_by_tiles(km_pass: KMTextureSpace) -> None:
    mat = km.default_library().get("Lipstick Classic Red")
    bad = _bad((128, 128))
    clean = clean_thickness(bad)
    km_pass.set_layers([LayerInput(mat, clean)])
    want = km_pass.read()
    km_pass.set_layers([LayerInput(mat, bad)])
    # exactly determined: cleaned on the CPU, the same texels are uploaded, and one program evaluates them
    # (GL 4.5 appendix A, rule 4); by tiles, the same program (texelFetch at pixel + offset) in the scratch
    # target, whose float texels are copied as they are
    for got, ref in zip(km_pass.read(), want):
        np.testing.assert_array_equal(got, ref)
    km_pass.set_layers([LayerInput(mat, np.full((128, 128), 12.0, np.float32))])
    km_pass.update_tiles(0, bad, [(0, 0), (0, 1), (1, 0), (1, 1)])
    for got, ref in zip(km_pass.read(), want):
        np.testing.assert_array_equal(got, ref)
