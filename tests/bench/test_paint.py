"""``sheer bench paint``: a smoke run in a small configuration through the ``sheer`` command (every key,
every median with its p90 and maximum), and its floor and fixed-cost figures (bench.paint): the floor
pass must visit exactly the dab's texels and write each one, or the bound it reports on
``dab_ratio_4096_1024`` means nothing."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import numpy as np

from app.cli import main as sheer
from bench import paint as bench
from tests.painting.helpers import make_doc, texel_positions

if TYPE_CHECKING:
    import pytest

#: the medians measured at each map size (``<name>_ms_<size>``), each with ``_p90`` and ``_max``
TIMED = ("dab", "dab_cpu", "dab_cold", "dab_stroke", "dab_fixed", "dab_fixed_cold", "dab_floor",
         "dab_floor_cold")


def test_sheer_bench_paint_prints_one_json_object(capsys: pytest.CaptureFixture[str]) -> None:
    assert sheer(["bench", "paint", "--json", "--sizes", "256,512", "--dabs", "5", "--evict-mb", "16"]) == 0
    result = json.loads(capsys.readouterr().out)
    stats = ("", "_p90", "_max")
    per_size = {f"{name}_ms_{res}{stat}" for name in TIMED for res in (256, 512) for stat in stats}
    per_size |= {f"dab_new_texels_{res}{stat}" for res in (256, 512) for stat in stats}
    per_size |= {f"{name}_{res}" for name in ("texels_in_1cm_dab", "dab_ns_per_texel") for res in (256, 512)}
    once = {"paint_path", "stroke_1000_ms", "stroke_1000_cpu_ms", "stroke_dabs", "undo_ms", "redo_ms",
            "redo_bit_exact", "undo_peak_mb", "undo_budget_mb", "stroke_tiles", "stroke_resolution",
            "targets"}
    assert set(result) == per_size | once
    assert result["paint_path"] in ("numba", "numpy")
    for name in TIMED:
        for res in (256, 512):
            key = f"{name}_ms_{res}"
            assert 0 <= result[key] <= result[f"{key}_p90"] <= result[f"{key}_max"], key
    assert 0 < result["dab_new_texels_512"] <= result["dab_new_texels_512_max"]
    assert result["stroke_resolution"] == 512 and result["stroke_dabs"] == 1000
    assert result["redo_bit_exact"] is True and result["stroke_tiles"] > 0
    assert result["targets"] == bench.TARGETS


def test_sheer_bench_paint_rejects_bad_sizes(capsys: pytest.CaptureFixture[str]) -> None:
    assert sheer(["bench", "paint", "--sizes", "100"]) == 2
    assert "multiples of 64" in capsys.readouterr().err


def test_floor_pass_writes_exactly_the_dab_texels() -> None:
    doc = make_doc(256)
    atlas = doc.atlas
    flat, pos, _ = texel_positions(atlas)
    centre = pos[len(pos) // 2]
    r = 10.0 / doc.mm_per_unit
    d2 = ((pos - centre) ** 2).sum(axis=1)
    inside = flat[d2 < r * r]
    kernel = bench._floor_kernel()
    out = np.zeros(atlas.resolution ** 2, dtype=np.float32)
    n = kernel(np.sort(inside), atlas.position.reshape(-1), centre.astype(np.float32), np.float32(r * r), out)
    assert n > 50
    written = np.flatnonzero(out)
    # float32 distances may drop a texel lying on the sphere to within rounding; none is added.
    assert set(written.tolist()) <= set(inside.tolist()) and len(inside) - n <= 2
    assert np.allclose(out[written], d2[np.isin(flat, written)], rtol=1e-5)


def test_floor_and_fixed_report_positive_times_and_leave_the_layer_painted_only_by_tiny_dabs() -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1")
    _, pos, _ = texel_positions(doc.atlas)
    pts = pos[:: max(1, len(pos) // 5)][:5]
    out = bench.floor_and_fixed(doc, layer, pts)
    assert len(out["fixed"]) == len(out["floor"]) == len(pts)
    assert min(out["fixed"]) > 0 and min(out["floor"]) > 0
    # Each tiny dab is its own undoable stroke; the floor pass never touches the layer.
    while doc.can_undo:
        doc.undo()
    assert not np.any(layer.thickness)
