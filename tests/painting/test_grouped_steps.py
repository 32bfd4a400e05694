"""``Document.grouped``: every step made inside one ``with`` block is one undo step (the studio's Looks menu
adds a look's layers and strokes so, and one Ctrl+Z takes the whole look off)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.painting.helpers import sample_head, sample_layout


def make_doc() -> object:
    """A document on the sample head with the shipped library (the looks' materials)."""
    from km.library import default_library
    from painting import Document

    return Document(sample_head(), sample_layout(), library=default_library(), resolution=256)


def test_a_look_added_as_new_layers_is_one_step_to_undo_and_redo() -> None:
    from painting.looks import apply_look, load_look

    doc = make_doc()
    doc.add_layer("Foundation Ivory", name="Base")
    doc.fill(doc.layers[0], 10.0)
    base = np.array(doc.layers[0].thickness)
    steps = len(doc.history)
    with doc.grouped("look red-lip"):
        added = apply_look(doc, "red-lip", clear=False)
    assert len(added) == len(load_look("red-lip").layers) and len(doc.layers) == 1 + len(added)
    assert len(doc.history) == steps + 1 and doc.history.undo_label == "look red-lip"
    painted = [np.array(lay.thickness) for lay in doc.layers]
    assert any(p.max() > 0 for p in painted[1:])
    assert doc.undo()
    assert [lay.name for lay in doc.layers] == ["Base"] and np.array_equal(doc.layers[0].thickness, base)
    assert doc.history.redo_label == "look red-lip"
    assert doc.redo()
    assert all(np.array_equal(a, np.asarray(lay.thickness)) for a, lay in zip(painted, doc.layers, strict=True))
    assert doc.undo() and len(doc.layers) == 1


def test_a_failure_inside_still_leaves_one_step() -> None:
    doc = make_doc()
    with pytest.raises(RuntimeError), doc.grouped("two layers"):
        doc.add_layer("Foundation Ivory", name="A")
        doc.add_layer("Foundation Ivory", name="B")
        raise RuntimeError("stop")
    assert len(doc.history) == 1 and doc.history.undo_label == "two layers"
    assert doc.undo() and doc.layers == []
    with doc.grouped("nothing"):
        pass
    assert doc.history.undo_label is None  # an empty group is no step
