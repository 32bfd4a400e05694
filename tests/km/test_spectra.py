"""WavelengthGrid: construction, immutability, hashing, validation, resampling."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import km
from km.optics import KMDomainError
from km.spectra import DEFAULT_GRID, WavelengthGrid


def test_default_grid_is_the_papers() -> None:
    assert len(DEFAULT_GRID) == 81
    assert DEFAULT_GRID.start == 380.0 and DEFAULT_GRID.stop == 780.0 and DEFAULT_GRID.step == 5.0
    np.testing.assert_array_equal(DEFAULT_GRID.wavelengths, np.arange(380, 781, 5))
    assert WavelengthGrid() == DEFAULT_GRID
    assert km.DEFAULT_GRID is DEFAULT_GRID and km.WavelengthGrid is WavelengthGrid


def test_explicit_and_irregular_grids() -> None:
    g = WavelengthGrid.from_wavelengths(np.arange(380, 781, 5))
    assert g == DEFAULT_GRID and hash(g) == hash(DEFAULT_GRID) and g.is_uniform
    irregular = WavelengthGrid.from_wavelengths([400, 410, 425, 450])
    assert irregular.step is None and not irregular.is_uniform and len(irregular) == 4
    assert irregular != DEFAULT_GRID
    assert WavelengthGrid.from_wavelengths(irregular) is irregular
    assert WavelengthGrid(400, 700, 10) == WavelengthGrid.from_wavelengths(np.linspace(400, 700, 31))
    assert "step=5" in repr(DEFAULT_GRID) and "425" in repr(irregular)
    np.testing.assert_array_equal(np.asarray(irregular), [400, 410, 425, 450])


def test_immutable_and_hashable() -> None:
    with pytest.raises(AttributeError):
        DEFAULT_GRID.start = 1.0  # type: ignore[misc]
    with pytest.raises(AttributeError):
        DEFAULT_GRID._wl = np.zeros(3)  # type: ignore[misc]
    with pytest.raises(ValueError):
        DEFAULT_GRID.wavelengths[0] = 1.0
    cache = {DEFAULT_GRID: "a", WavelengthGrid(400, 700, 10): "b"}
    assert cache[WavelengthGrid()] == "a"
    assert pickle.loads(pickle.dumps(DEFAULT_GRID)) == DEFAULT_GRID


@pytest.mark.parametrize(("args", "match"), [
    ((380, 780, 0), "step > 0"),
    ((380, 780, -5), "step > 0"),
    ((380, 780, 7), "not start"),
    ((780, 380, 5), "below start"),
    ((np.nan, 780, 5), "finite"),
    (("a", 780, 5), "numbers"),
])
def test_bad_uniform_grids(args: tuple, match: str) -> None:
    with pytest.raises(KMDomainError, match=match):
        WavelengthGrid(*args)


@pytest.mark.parametrize(("wl", "match"), [
    ([], "no wavelengths"),
    ([400, 400, 410], "strictly increasing; index 1"),
    ([400, 390], "strictly increasing"),
    ([400, np.nan], "finite and positive"),
    ([-5, 400], "finite and positive"),
    ([[400, 410]], "1-D"),
])
def test_bad_explicit_grids(wl: list, match: str) -> None:
    with pytest.raises(KMDomainError, match=match):
        WavelengthGrid.from_wavelengths(wl)


def test_resample_is_exact_for_linear_data_and_n_dimensional() -> None:
    src = np.array([370.0, 400.0, 455.0, 600.0, 700.0, 790.0])
    rng = np.random.default_rng(5)
    slope, offset = rng.normal(size=(2, 3, 1)), rng.normal(size=(2, 3, 1))
    values = slope * src + offset
    out = DEFAULT_GRID.resample(values, src)
    assert out.shape == (2, 3, 81)
    np.testing.assert_allclose(out, slope * DEFAULT_GRID.wavelengths + offset, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(out[1, 2], DEFAULT_GRID.resample(values[1, 2], src))


def test_resample_values_and_locality_of_nan() -> None:
    grid = WavelengthGrid.from_wavelengths([400, 405, 410, 420])
    src = [400.0, 410.0, 420.0]
    out = grid.resample([0.2, 0.6, np.nan], src)
    np.testing.assert_array_equal(out[:3], [0.2, 0.4, 0.6])  # exact nodes and the midpoint
    assert np.isnan(out[3])
    np.testing.assert_array_equal(grid.resample([0.1, 0.2, 0.3, 0.4], grid), [0.1, 0.2, 0.3, 0.4])


def test_resample_never_overshoots() -> None:
    src = np.arange(380, 781, 20.0)
    values = (np.arange(src.size) % 2).astype(float)  # a square wave in [0, 1]
    out = DEFAULT_GRID.resample(values, src)
    assert out.min() >= 0.0 and out.max() <= 1.0


def test_resample_validation_and_extrapolation() -> None:
    with pytest.raises(KMDomainError, match="380–780 nm is not covered by the data \\(400–700 nm\\)"):
        DEFAULT_GRID.resample(np.ones(31), np.arange(400, 701, 10.0))
    out = DEFAULT_GRID.resample(np.linspace(0, 1, 31), np.arange(400, 701, 10.0), extrapolate=True)
    assert out[0] == 0.0 and out[-1] == 1.0 and out[3] == 0.0 and out[4] == 0.0 and out[5] > 0.0
    with pytest.raises(KMDomainError, match="30 samples on the last axis but 31"):
        DEFAULT_GRID.resample(np.ones(30), np.arange(400, 701, 10.0), extrapolate=True)
    with pytest.raises(KMDomainError, match="strictly increasing"):
        DEFAULT_GRID.resample(np.ones(3), [400, 500, 450])
    single = WavelengthGrid.from_wavelengths([550.0])
    np.testing.assert_array_equal(DEFAULT_GRID.resample([0.3], single, extrapolate=True), np.full(81, 0.3))
