"""A layer mask's recipe values come from the disk cache when nothing they depend on changed (issue #13's
start-up: the natural look's blush mask took 0.5–1.8 s to resample and feather), bit for bit as computed."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
import pytest

from painting import Document, LayerMask
from painting.mask import _recipe_values, recipe_values

if TYPE_CHECKING:
    from pathlib import Path


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("SHEER_CACHE_DIR", str(tmp_path))
    return tmp_path / "looks"


@pytest.fixture(scope="module")
def doc() -> Document:
    return Document.from_head(None, resolution=256)


def _entries(folder: Path) -> list[Path]:
    return sorted(folder.glob("mask-*.cache")) if folder.is_dir() else []


def test_cached_recipe_is_the_computed_one_bit_for_bit(doc: Document, cache: Path) -> None:
    mask = LayerMask((("union", "cheek_apple"), ("subtract", "lips")), feather_mm=4.0)
    texel_mm = doc.atlas_at(256).texel_mm
    first = recipe_values(mask, doc.regions, 256, texel_mm)
    assert len(_entries(cache)) == 1, "the values were not cached"
    again = recipe_values(mask, doc.regions, 256, texel_mm)
    np.testing.assert_array_equal(again, _recipe_values(mask, doc.regions, 256, texel_mm))
    np.testing.assert_array_equal(again, first)
    assert again.dtype == np.float32 and len(_entries(cache)) == 1


def test_anything_the_values_depend_on_is_a_new_entry(doc: Document, cache: Path) -> None:
    mask = LayerMask((("union", "lips"),), feather_mm=2.0)
    texel_mm = doc.atlas_at(256).texel_mm
    recipe_values(mask, doc.regions, 256, texel_mm)
    recipe_values(replace(mask, feather_mm=3.0), doc.regions, 256, texel_mm)  # the recipe
    recipe_values(mask, doc.regions, 128, texel_mm * 2)  # the resolution
    recipe_values(mask, doc.regions, 256, texel_mm * 1.5)  # the texel size
    regions = replace(doc.regions, regions=dict(doc.regions.regions), _resampled={})
    lips = regions.regions["lips"]
    moved = np.roll(lips.mask, 7, axis=1)  # the region's own mask (e.g. a rebuilt region file)
    regions.regions["lips"] = replace(lips, mask=moved)
    got = recipe_values(mask, regions, 256, texel_mm)
    assert len(_entries(cache)) == 5
    np.testing.assert_array_equal(got, _recipe_values(mask, regions, 256, texel_mm))
    assert not np.array_equal(got, recipe_values(mask, doc.regions, 256, texel_mm))


def test_a_damaged_or_wrong_entry_is_computed_again(doc: Document, cache: Path) -> None:
    mask = LayerMask((("union", "lips"),))
    texel_mm = doc.atlas_at(256).texel_mm
    good = recipe_values(mask, doc.regions, 256, texel_mm)
    (entry,) = _entries(cache)
    entry.write_bytes(entry.read_bytes()[:-100])  # truncated
    np.testing.assert_array_equal(recipe_values(mask, doc.regions, 256, texel_mm), good)
    from core.cache import save_array

    save_array(entry, np.full((256, 256), 3.0, np.float32), 1)  # out of range: never shown
    np.testing.assert_array_equal(recipe_values(mask, doc.regions, 256, texel_mm), good)
