"""The brush bar's region picker (app.studio.region_picker): lists the head's regions, greys out the missing ones,
gives the brush its region options and fills a region on request."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytestmark = [pytest.mark.qt]


def test_picker_lists_regions_and_drives_brush_and_fill(qtbot: Any) -> None:
    from app.studio.region_picker import NO_REGION, RegionPicker
    from painting import Brush, Document

    doc = Document.from_head(None, resolution=512)
    picker = RegionPicker(doc)
    qtbot.addWidget(picker)
    assert picker.region_combo.itemText(0) == NO_REGION and picker.region is None
    assert picker.brush_options() == {"region": None, "region_mode": "inside"}
    assert not picker.fill_button.isEnabled()
    picker.region_combo.setCurrentIndex(picker.region_combo.findData("lips"))
    picker.mode_combo.setCurrentText("avoid")
    assert picker.brush_options() == {"region": "lips", "region_mode": "avoid"}
    assert "albedo" in picker.region_combo.itemData(picker.region_combo.currentIndex(), 3)
    Brush(**picker.brush_options()).validate()
    lay = doc.add_layer("Lipstick Classic Red")
    picker.fill_requested.connect(lambda name: doc.fill_region(lay, name, 20.0))
    with qtbot.waitSignal(picker.fill_requested):
        picker.fill_button.click()
    lips = doc.region_values("lips", lay.resolution)
    assert np.allclose(np.asarray(lay.thickness)[lips == 1], 20.0)
    assert float(np.asarray(lay.thickness)[lips == 0].max()) == 0.0
