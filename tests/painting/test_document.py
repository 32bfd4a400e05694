"""The document: layers, undo/redo (bit-exact, tile deltas, budget), events, bad input."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import pytest

from core.errors import SheerError
from painting import Brush, ChangeEvent, Document, DocumentError
from tests.painting.helpers import make_doc

if TYPE_CHECKING:
    from pathlib import Path


def _pts(doc, n: int, seed: int = 0) -> np.ndarray:
    """Random covered texel positions on the front of the face."""
    idx = doc.atlas.index
    rng = np.random.default_rng(seed)
    front = np.flatnonzero((idx.z > 1.7) & (np.abs(idx.y - 1.2) < 1.0) & (np.abs(idx.x + 0.1) < 0.9))
    pick = rng.choice(front, n, replace=False)
    return np.stack([idx.x[pick], idx.y[pick], idx.z[pick]], axis=1).astype(np.float64)


def _snapshot(doc: Document) -> tuple:
    return (tuple((lay.id, lay.name, lay.material, lay.visible, lay.opacity, lay.max_thickness)
                  for lay in doc.layers),
            tuple(lay.thickness.tobytes() for lay in doc.layers), len(doc.history), doc.history.can_redo)


def test_public_api_quick_start() -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1", resolution=256)
    assert layer.thickness.dtype == np.float32 and layer.thickness.shape == (256, 256)
    assert doc.atlas.position.dtype == np.float32 and doc.atlas.position.shape == (256, 256, 3)
    assert doc.atlas.coverage.dtype == bool
    assert doc.head.mm_per_unit == pytest.approx(52.5)
    x, y, z = doc.head.landmark("left_cheek")
    with doc.stroke(layer, Brush(radius_mm=8.0, hardness=0.5, strength=1.0, mode="add")) as s:
        s.dab((x, y, z))
    painted = layer.thickness.copy()
    assert painted.max() > 0
    doc.undo()
    assert not layer.thickness.any()
    doc.redo()
    assert np.array_equal(layer.thickness, painted)
    with pytest.raises(ValueError):
        layer.thickness[0, 0] = 1.0  # read-only view


def test_undo_redo_bit_exact_over_many_strokes_and_layer_edits() -> None:
    doc = make_doc(256)
    a = doc.add_layer("Foundation 1")
    b = doc.add_layer("Blush 1")
    doc.clear_history()
    states = [_snapshot(doc)]
    pts = _pts(doc, 12)
    rng = np.random.default_rng(3)
    modes = ["add", "add", "erase", "smooth", "set"]
    for i, p in enumerate(pts):
        lay = a if i % 2 else b
        brush = Brush(radius_mm=float(rng.uniform(3, 15)), hardness=float(rng.uniform(0, 1)),
                      strength=float(rng.uniform(0.2, 1)), mode=modes[i % len(modes)], amount_um=7.5)
        with doc.stroke(lay, brush) as s:
            s.dab(p, pressure=float(rng.uniform(0.3, 1)))
            s.dab(pts[(i + 1) % len(pts)])
        states.append(_snapshot(doc))
        if i == 4:
            doc.set_layer(a, opacity=0.5, name="Base")
            states.append(_snapshot(doc))
            doc.move_layer(a, 1)
            states.append(_snapshot(doc))
            doc.set_layer_material(b, "Lipstick 1")
            states.append(_snapshot(doc))
    final = states[-1]
    for expected in reversed(states[:-1]):
        assert doc.undo()
        assert _snapshot(doc)[:2] == expected[:2]
    assert not doc.undo()
    while doc.redo():
        pass
    assert _snapshot(doc)[:2] == final[:2]


def test_redo_cleared_by_new_edit_and_steps_store_tiles_only() -> None:
    doc = make_doc(512)
    layer = doc.add_layer("Foundation 1")
    p, q = _pts(doc, 2)
    with doc.stroke(layer, Brush(radius_mm=5.0)) as s:
        s.dab(p)
    step = doc.history._undo[-1]
    assert step.deltas and step.deltas[0].data.shape[1:] == (64, 64)
    assert step.deltas[0].data.nbytes < layer.thickness.nbytes / 4  # a few tiles, not a layer copy
    doc.undo()
    assert doc.can_redo
    with doc.stroke(layer, Brush(radius_mm=5.0)) as s:
        s.dab(q)
    assert not doc.can_redo


def test_memory_budget_drops_oldest_steps() -> None:
    budget = 300_000
    doc = make_doc(512, history_budget=budget)
    layer = doc.add_layer("Foundation 1")  # 1 MB layer: larger than the budget, so not undoable
    assert doc.history.nbytes <= budget
    for p in _pts(doc, 15, seed=5):
        with doc.stroke(layer, Brush(radius_mm=12.0)) as s:
            s.dab(p)
        assert doc.history.nbytes <= budget
    assert doc.history.peak_bytes <= budget
    assert doc.history.dropped > 0
    assert 0 < len(doc.history) < 15
    kept = len(doc.history)
    for _ in range(kept):
        assert doc.undo()
    assert not doc.undo()


def test_events_carry_the_touched_tiles() -> None:
    doc = make_doc(256)
    events: list[ChangeEvent] = []
    unsubscribe = doc.subscribe(events.append)
    layer = doc.add_layer("Foundation 1")
    assert any(e.kind == "layers" and e.detail == "added" and e.layer == layer.id for e in events)
    events.clear()
    before = layer.thickness.copy()
    with doc.stroke(layer, Brush(radius_mm=10.0)) as s:
        s.dab(_pts(doc, 1)[0])
    paint = [e for e in events if e.kind == "paint"]
    assert paint and all(e.layer == layer.id and e.detail == "stroke" for e in paint)
    tiles = {t for e in paint for t in e.tiles}
    rows, cols = np.nonzero(layer.thickness != before)
    assert {(int(r) // 64, int(c) // 64) for r, c in zip(rows, cols)} <= tiles
    assert any(e.kind == "history" for e in events)
    events.clear()
    doc.undo()
    assert [e for e in events if e.kind == "paint"][0].detail == "undo"
    doc.set_layer(layer, visible=False)
    assert events[-2:][0].kind == "layers" or any(e.detail == "visible" for e in events)
    doc.set_layer_material(layer, "Blush 1")
    assert any(e.kind == "material" and e.layer == layer.id for e in events)
    unsubscribe()
    n = len(events)
    doc.set_layer(layer, name="x")
    assert len(events) == n


def test_layer_ids_stable_and_order_operations() -> None:
    doc = make_doc(256)
    a = doc.add_layer("Foundation 1")
    b = doc.add_layer("Blush 1", name="Cheeks")
    c = doc.add_layer("Lipstick 1", index=0)
    assert [lay.id for lay in doc.layers] == [c.id, a.id, b.id]
    doc.move_layer(c, 2)
    assert doc.layers == [a, b, c]
    doc.remove_layer(1)
    assert doc.layers == [a, c]
    doc.undo()
    assert doc.layers == [a, b, c] and doc.layer_by_id(b.id) is b
    doc.rename_layer(b, "Blush")
    assert b.name == "Blush"
    doc.set_layer(b, opacity=0.25, visible=True, max_thickness=12.0)
    assert b.effective_thickness().dtype == np.float32
    doc.undo()
    assert (b.opacity, b.max_thickness) == (1.0, 30.0)


BAD_BRUSHES = [
    {"radius_mm": math.nan}, {"radius_mm": -1.0}, {"radius_mm": 0.0}, {"hardness": 2.0},
    {"strength": math.inf}, {"mode": "scribble"}, {"flow": 0.0}, {"falloff_curve": (1.0,)},
]


@pytest.mark.parametrize("kwargs", BAD_BRUSHES)
def test_bad_brush_is_a_clear_error_and_changes_nothing(kwargs: dict) -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1")
    before = _snapshot(doc)
    with pytest.raises(SheerError, match="brush"), doc.stroke(layer, Brush(**kwargs)) as s:
        s.dab(_pts(doc, 1)[0])
    assert _snapshot(doc) == before


def test_bad_input_is_a_clear_error_and_changes_nothing() -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1")
    p = _pts(doc, 1)[0]
    with doc.stroke(layer, Brush(radius_mm=5.0)) as s:
        s.dab(p)
    before = _snapshot(doc)
    with pytest.raises(DocumentError, match="material"):
        doc.add_layer("No Such Material")
    with pytest.raises(DocumentError, match="layer"):
        doc.remove_layer(7)
    other = make_doc(256).add_layer("Foundation 1")
    with pytest.raises(DocumentError, match="not in this document"):
        doc.stroke(other, Brush())
    with pytest.raises(DocumentError, match="resolution"):
        doc.add_layer("Foundation 1", resolution=300)
    with pytest.raises(DocumentError, match="opacity"):
        doc.set_layer(layer, opacity=1.5)
    with pytest.raises(DocumentError, match="unknown layer field"):
        doc.set_layer(layer, colour="red")
    # A point far off the surface, a NaN point, a bad pressure: the stroke is rolled back whole.
    for bad in ((p + np.array([0.0, 0.0, 1.0]), 1.0), ((math.nan, 0.0, 0.0), 1.0), (p, -0.5), (p, math.nan)):
        with pytest.raises(DocumentError, match="surface|finite|pressure"), \
                doc.stroke(layer, Brush(radius_mm=5.0)) as s:
            s.dab(_pts(doc, 2, seed=9)[1])
            s.dab(bad[0], pressure=bad[1])
        assert _snapshot(doc) == before
    with pytest.raises(DocumentError, match="map"):
        doc.set_thickness(layer, np.zeros((128, 128), np.float32))
    bad_map = np.zeros((256, 256), np.float32)
    bad_map[3, 3] = -1.0
    with pytest.raises(DocumentError, match="finite"):
        doc.set_thickness(layer, bad_map)
    assert _snapshot(doc) == before


def test_exception_inside_a_stroke_rolls_it_back() -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1")
    before = _snapshot(doc)
    with pytest.raises(RuntimeError), doc.stroke(layer, Brush(radius_mm=8.0)) as s:
        s.dab(_pts(doc, 1)[0])
        assert layer.thickness.any()
        raise RuntimeError("pen lifted badly")
    assert _snapshot(doc) == before
    # The scratch maps were reset: the next stroke behaves as on a fresh document.
    with doc.stroke(layer, Brush(radius_mm=8.0, hardness=1.0)) as s:
        s.dab(_pts(doc, 1)[0])
    assert layer.thickness.max() == pytest.approx(20.0)


def test_set_thickness_is_undoable() -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1")
    values = np.where(doc.atlas.coverage, 4.0, 0.0).astype(np.float32)
    doc.set_thickness(layer, values)
    assert np.array_equal(layer.thickness, values)
    doc.undo()
    assert not layer.thickness.any()


def test_with_the_default_material_library() -> None:
    import km
    from tests.painting.helpers import sample_atlas, sample_head, sample_layout

    library = km.default_library()
    doc = Document(sample_head(), sample_layout(), library=library, resolution=256)
    doc._atlases[256] = sample_atlas(256)
    material = next(iter(library))
    layer = doc.add_layer(material.name)
    assert layer.material == material.name and layer.material_object is material
    assert layer.max_thickness == material.max_thickness_um
    with doc.stroke(layer, Brush(radius_mm=10.0, hardness=1.0)) as s:
        s.dab(doc.head.landmark("left_cheek"))
    assert layer.thickness.max() == pytest.approx(min(material.thickness_um, material.max_thickness_um))
    with pytest.raises(DocumentError, match="no material named"):
        doc.add_layer("Definitely Not A Material")


def test_a_look_from_the_cache_equals_a_look_painted(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Applying a look caches its painted maps; applying it again (a new document on the same layout) sets
    the same maps to the bit. A damaged cache file is painted again."""
    from painting.looks import apply_look

    monkeypatch.setenv("SHEER_CACHE_DIR", str(tmp_path))
    first = Document.from_head(resolution=256)
    apply_look(first, "evening")
    files = list((tmp_path / "looks").glob("maps-*.cache"))
    assert len(files) == 1
    second = Document.from_head(resolution=256)
    apply_look(second, "evening")
    assert [lay.name for lay in second.layers] == [lay.name for lay in first.layers]
    for a, b in zip(first.layers, second.layers):
        assert a.material == b.material
        np.testing.assert_array_equal(a.thickness, b.thickness)
    assert any(lay.thickness.max() > 0 for lay in second.layers)
    top = len(second.layers) - 1
    second.undo()  # from the cache, a layer's map is one undo step
    assert second.layers[top].thickness.max() == 0
    files[0].write_bytes(b"broken")
    third = Document.from_head(resolution=256)
    apply_look(third, "evening")
    for a, b in zip(first.layers, third.layers):
        np.testing.assert_array_equal(a.thickness, b.thickness)
