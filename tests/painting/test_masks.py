"""Layer masks in the document (painting.mask, painting.document_masks): the recipe's algebra, the paint
channel, undo, events and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from painting import Brush, ChangeEvent, Document, DocumentError, LayerMask


@pytest.fixture(scope="module")
def doc() -> Document:
    return Document.from_head(None, resolution=256)


def test_recipe_union_subtract_invert_feather(doc: Document) -> None:
    lay = doc.add_layer("Lipstick Classic Red")
    r = lay.resolution
    lips, upper = doc.region_values("lips", r), doc.region_values("upper_lip", r)
    doc.set_layer_mask(lay, LayerMask((("union", "lips"), ("subtract", "upper_lip"))))
    np.testing.assert_array_equal(doc.mask_values(lay), np.minimum(lips, 1.0 - upper))
    doc.set_layer_mask(lay, LayerMask((("union", "lips"),), invert=True))
    np.testing.assert_array_equal(doc.mask_values(lay), 1.0 - lips)
    doc.set_layer_mask(lay, LayerMask((("subtract", "lips"),)))  # a leading subtraction starts full
    np.testing.assert_array_equal(doc.mask_values(lay), 1.0 - lips)
    doc.set_layer_mask(lay, LayerMask((("union", "lips"),), feather_mm=4.0))
    soft = doc.mask_values(lay)
    assert np.count_nonzero(soft > 0.01) > np.count_nonzero(lips > 0.01)  # the blur widens the edge
    assert abs(float(soft.sum()) - float(lips.sum())) < 0.05 * float(lips.sum())  # and keeps its area
    doc.set_layer_mask(lay, None)
    assert doc.mask_values(lay) is None and not lay.has_mask
    doc.remove_layer(lay)


def test_mask_edits_emit_events_and_the_channel_paints_by_tiles(doc: Document) -> None:
    lay = doc.add_layer("Lipstick Classic Red")
    events: list[ChangeEvent] = []
    off = doc.subscribe(events.append)
    doc.set_layer_mask(lay, LayerMask((("union", "lips"),)))
    assert ChangeEvent("layers", lay.id, detail="mask") in events
    events.clear()
    with doc.mask_stroke(lay, Brush(radius_mm=5.0, mode="add", amount_um=2.0)) as s:
        s.dab(doc.head.metadata.landmarks["chin"])  # reveal a spot outside the lips
    paint = [e for e in events if e.kind == "paint"]
    assert paint and all(e.layer == lay.id and e.detail == "mask" and e.tiles for e in paint)
    m = doc.mask_values(lay)
    assert m.max() == 1.0 and np.count_nonzero(m > 0.5) > np.count_nonzero(doc.region_values("lips", 256) > 0.5)
    assert not np.any(lay.thickness)  # painting the mask never touches the thickness
    off()
    doc.remove_layer(lay)


def test_bad_masks_are_refused_by_name(doc: Document) -> None:
    lay = doc.add_layer("Lipstick Classic Red")
    with pytest.raises(DocumentError, match="unknown region 'nose'"):
        doc.set_layer_mask(lay, LayerMask((("union", "nose"),)))
    with pytest.raises(DocumentError, match="mask op must be one of union, subtract"):
        doc.set_layer_mask(lay, LayerMask((("xor", "lips"),)))
    with pytest.raises(DocumentError, match=r"mask channel of layer 'Lipstick Classic Red' is 128×128, the layer is 256×256"):
        doc.set_layer_mask(lay, None, np.ones((128, 128), np.float32))
    with pytest.raises(DocumentError, match=r"must be finite values in \[0, 2\]"):
        doc.set_layer_mask(lay, None, np.full((256, 256), 3.0, np.float32))
    with pytest.raises(DocumentError, match="feather_mm must be in"):
        doc.set_layer_mask(lay, LayerMask((("union", "lips"),), feather_mm=-1))
    assert not lay.has_mask and doc.history.undo_label == "add layer Lipstick Classic Red"  # unchanged
    doc.remove_layer(lay)
