"""``sheer bench km``: a smoke run on a tiny texture through the ``sheer`` command, and its pipeline
checked against nested ``over``.

No assertion on timing: only that the numbers are there (every median with its p90 and maximum) and the
pipeline computes the right thing.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import numpy as np

from app.cli import main as sheer
from bench import km as bench
from km.colour import spectrum_to_rgb
from km.optics import layer_rt, over
from km.spectra import DEFAULT_GRID

if TYPE_CHECKING:
    import pytest


def test_sheer_bench_km_prints_one_json_object(capsys: pytest.CaptureFixture[str]) -> None:
    assert sheer(["bench", "km", "--json", "--size", "8", "--repeats", "3", "--chunk", "24"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert set(result) == {"benchmark", "what", "texels", "size", "wavelengths", "layers", "repeats",
                           "chunk_texels", "texels_per_s", "seconds_median", "seconds_p90", "seconds_max",
                           "seconds_all", "stages_s", "stages_s_p90", "stages_s_max", "mean_rgb", "machine"}
    assert result["benchmark"] == "km"
    assert result["texels"] == 64 and result["wavelengths"] == 81 and result["layers"] == 4
    assert result["repeats"] == 3 and len(result["seconds_all"]) == 3
    assert result["texels_per_s"] > 0
    runs = sorted(result["seconds_all"])
    assert result["seconds_median"] == runs[1] and result["seconds_max"] == runs[2]
    assert runs[1] <= result["seconds_p90"] <= runs[2]
    for key in ("stages_s", "stages_s_p90", "stages_s_max"):
        assert set(result[key]) == {"layer_rt", "stack", "over", "spectrum_to_rgb"}
        assert all(v >= 0 for v in result[key].values())
    assert all(result["stages_s"][k] <= result["stages_s_p90"][k] <= result["stages_s_max"][k]
               for k in result["stages_s"])
    assert result["machine"]["cpu_count"] >= 1
    assert all(0.0 < c < 1.0 for c in result["mean_rgb"])


def test_bench_rejects_bad_options(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench.main(["--size", "0"]) == 2
    assert "positive integer" in capsys.readouterr().err


def test_bench_pipeline_matches_layer_by_layer_reference() -> None:
    size = 5
    _, stages, rgb = bench.run(size, chunk=7)  # chunks that do not divide the texel count
    assert all(v >= 0 for v in stages.values())
    wl = DEFAULT_GRID.wavelengths
    mats = bench._materials(wl)
    thick, albedo = bench._inputs(size * size)
    skin = bench._skin(wl)
    for texel in (0, 7, 13, 24):
        R = skin * albedo[texel]
        for i in reversed(range(4)):  # nest over() from the skin up
            R0, T = layer_rt(*mats[i], thick[i, texel])
            R = over(R0, T, R)
        np.testing.assert_allclose(rgb[texel], spectrum_to_rgb(R, DEFAULT_GRID), rtol=1e-12)
