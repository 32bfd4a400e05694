"""``sheer bench paint``'s floor and fixed-cost figures (bench.paint): the floor pass must visit exactly
the dab's texels and write each one, or the bound it reports on ``dab_ratio_4096_1024`` means nothing."""

from __future__ import annotations

import numpy as np
import pytest

from bench import paint as bench
from painting import kernels
from tests.painting.helpers import make_doc, texel_positions


@pytest.mark.skipif(not kernels.HAVE_NUMBA, reason="numba is not installed")
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
    assert out["fixed_ms"] > 0
    if kernels.HAVE_NUMBA:
        assert out["floor_ms"] > 0
    # Each tiny dab is its own undoable stroke; the floor pass never touches the layer.
    while doc.can_undo:
        doc.undo()
    assert not np.any(layer.thickness)
