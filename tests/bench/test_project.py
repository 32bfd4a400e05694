"""``sheer bench project``: a smoke run through the ``sheer`` command (two 128² layers, three rounds).

No assertion on timing: only that every figure is there (each median with its p90 and maximum) and the
project measured is the one described.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import numpy as np
import pytest

from app.cli import main as sheer
from bench.project import smooth_thickness

if TYPE_CHECKING:
    from pathlib import Path


@pytest.mark.parametrize("encoding", ["exr-float32", "png16"])
def test_sheer_bench_project_prints_one_json_object(encoding: str, tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["bench", "project", "--json", "--side", "128", "--layers", "2", "--repeats", "3",
            "--encoding", encoding, "--folder", str(tmp_path)]
    assert sheer(argv) == 0
    result = json.loads(capsys.readouterr().out)
    assert set(result) == {"save_ms", "save_ms_p90", "save_ms_max", "open_ms", "open_ms_p90", "open_ms_max",
                           "file_mb", "layers", "side", "encoding", "repeats"}
    assert (result["layers"], result["side"], result["encoding"], result["repeats"]) == (2, 128, encoding, 3)
    for key in ("save_ms", "open_ms"):
        assert 0 < result[key] <= result[f"{key}_p90"] <= result[f"{key}_max"]
    assert 0 < result["file_mb"] < 2 * 128 * 128 * 4 / 1024**2  # two float32 maps, compressed
    assert list(tmp_path.iterdir()) == []  # the temporary folder is gone


def test_the_maps_are_smooth_bumps_over_about_half_the_texels() -> None:
    t = smooth_thickness(256, seed=0)
    assert t.dtype == np.float32 and t.shape == (256, 256)
    assert 0.4 < np.count_nonzero(t) / t.size < 0.6 and t.min() >= 0 and t.max() <= 60.0
    assert np.abs(np.diff(t, axis=1)).max() < 5.0  # smooth: no jump between neighbouring texels
