"""The studio's Shade Finder dock on a real window (xcb under Xvfb, Mesa GL): match a skin, see the ranked
shades and the spectra, apply the best shade to the foundation layer (undoable), run the coverage."""

from __future__ import annotations

import numpy as np
import pytest

from app.qt_compat import pin_singletons
from km.skin import fit_skin
from km.srgb import srgb_decode
from shade.match import ShadeBank, foundations, match_shades
from tests.app.studio_support import studio_fixture, window_fixture

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]


studio = studio_fixture()
window = window_fixture()


def test_the_dock_is_in_the_studio(window: object) -> None:
    from PySide6.QtWidgets import QDockWidget

    titles = [d.windowTitle() for d in window.findChildren(QDockWidget)]
    assert "Shade Finder" in titles and "Material Library" in titles


def test_typed_colour_is_matched_like_the_library_match(window: object) -> None:
    finder = window.shade_finder
    finder.rgb_edit.setText("150,100,75")
    finder.match_typed()
    assert finder.fit is not None and finder.table.rowCount() == len(foundations(window.library))
    expected = match_shades(fit_skin(linear_rgb=srgb_decode(np.array([150, 100, 75]) / 255.0)).reflectance,
                            finder.fit.reflectance, ShadeBank.from_materials(foundations(window.library)))
    assert [finder.table.item(r, 1).text() for r in range(finder.table.rowCount())] == [s.name for s in expected]
    assert finder.table.item(0, 0).background().color().name() == expected[0].swatch_hex
    assert finder.selected() is finder.results[0]
    assert finder.spectra_plot is not None and len(finder.spectra_plot.listDataItems()) == 2  # skin, made-up
    # a store light and a target change the ranking's columns and the target curve
    finder.target.setCurrentText("lighter")
    assert len(finder.spectra_plot.listDataItems()) == 3
    finder.rgb_edit.setText("1,2")
    finder.match_typed()
    assert "R,G,B" in finder.status.text()


def test_the_status_says_the_matchs_confidence_in_the_words_the_command_line_and_kiosk_use(window: object) -> None:
    """One reading of a skin: the dock says the confidence ``shade.match.confidence`` gives the same fit."""
    from shade.match import confidence

    finder = window.shade_finder
    for typed, level in (("150,100,75", "high"), ("60,160,60", "low")):  # a skin colour; a green no skin has
        finder.rgb_edit.setText(typed)
        finder.match_typed()
        sure = confidence(finder.fit)
        assert sure.level == level, (typed, sure)
        assert f"{level} confidence: {sure.words}" in finder.status.text()
        assert "gamut" not in finder.status.text()


def test_apply_gives_the_foundation_layer_the_shade_as_one_undo_step(window: object) -> None:
    finder = window.shade_finder
    finder.match_head()
    assert finder.results and "confidence:" in finder.status.text()
    doc = window.doc
    layers_before = [(lay.name, lay.material) for lay in doc.layers]
    finder.table.selectRow(1)
    shade = finder.selected()
    finder.apply_selected()
    lib = window.library
    found = [lay for lay in doc.layers if lib.get(lay.material).category == "foundation"]
    assert found and found[0].material == shade.name
    assert f"{shade.thickness_um:.1f} µm" in finder.status.text()
    window.undo()
    assert [(lay.name, lay.material) for lay in doc.layers] == layers_before


def test_coverage_is_plotted(window: object) -> None:
    finder = window.shade_finder
    cov = finder.compute_coverage(48)
    finder.show_coverage(cov)
    assert finder.coverage is cov
    assert len(finder.coverage_plot.listDataItems()) >= 1
    assert "48 skins" in finder.coverage_label.text()


def test_skin_picked_on_the_face_is_the_albedo_there(window: object, qtbot: object) -> None:
    """Pick the skin by clicking the face: the click picks (no stroke is painted), and the colour matched is
    the head's albedo around the clicked point."""
    from PySide6.QtCore import QPoint, QPointF, Qt

    from painting.hit import albedo_colour_at

    finder, vp = window.shade_finder, window.viewport
    steps = len(window.doc.history)
    finder.pick_button.click()
    assert vp.pick_next and "Click the skin" in finder.status.text()
    where = QPoint(int(vp.width() * 0.62), int(vp.height() * 0.62))  # a cheek
    point = vp.pick(QPointF(where))
    assert point is not None, "the click must land on the face"
    with qtbot.waitSignal(vp.surface_picked, timeout=5000):
        qtbot.mouseClick(vp, Qt.MouseButton.LeftButton, pos=where)
    assert not vp.pick_next
    assert len(window.doc.history) == steps, "the pick painted a stroke"
    from km.colour import linear_rgb_to_lab

    expected = albedo_colour_at(window.doc, window.doc.head, point)
    np.testing.assert_allclose(finder.fit.target_lab, linear_rgb_to_lab(expected), atol=1e-6)
    assert finder.status.text().startswith("the skin picked on the face") and finder.table.rowCount() > 0
    # the skin colour there is a skin colour (red above green above blue), not the head's median elsewhere
    assert expected[0] > expected[1] > expected[2] > 0.0
