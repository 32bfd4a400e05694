"""Regions and masks in the studio (issue #16), on a real window (xcb under Xvfb, Mesa GL): the Regions
overlay outlines ticked regions on the face; the layers panel's mask editor builds a layer's mask from
regions (add, subtract, invert, feather, remove, clear; each one undo step); "Paint mask" makes strokes
paint the mask's channel; the thickness view shows the masked thickness."""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import QPoint, QPointF, Qt

from app.qt_compat import pin_singletons
from render.view import debug_views
from tests.app.studio_support import DialogDriver, reset_studio, studio_fixture

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]


studio = studio_fixture()


@pytest.fixture
def window(studio: tuple[object, DialogDriver]) -> object:
    reset_studio(studio[0], look="bare")
    studio[1].shown.clear()
    return studio[0]


def draw(vp: object, qtbot: object) -> None:
    before = vp.frames
    vp.update()
    qtbot.waitUntil(lambda: vp.frames > before and not vp.pending_changes, timeout=20000)


def grab(win: object) -> np.ndarray:
    from app.qt_compat import qimage_to_rgb

    return qimage_to_rgb(win.viewport.grabFramebuffer()).astype(int)


def screen_of(win: object, point: np.ndarray) -> tuple[int, int]:
    """Widget pixel (x, y) of a mesh point in the viewport's current view."""
    vp = win.viewport
    w, h = vp.pixel_size()
    c = vp.camera.view_projection(w / h) @ np.append(np.asarray(point, float), 1.0)
    ndc = c[:2] / c[3]
    r = vp.devicePixelRatioF()
    return int((ndc[0] * 0.5 + 0.5) * w / r), int((0.5 - ndc[1] * 0.5) * h / r)


def test_regions_overlay_outlines_the_ticked_regions(window: object, qtbot: object) -> None:
    vp, picker = window.viewport, window.region_picker
    vp.brush_ring = None
    draw(vp, qtbot)
    bare = grab(window)
    assert "lips" in picker.overlay_actions and "lash_line" in picker.overlay_actions
    assert vp.after_frame is None
    picker.overlay_actions["lips"].setChecked(True)
    assert picker.shown_regions() == ["lips"] and vp.after_frame is not None
    assert picker.overlay_button.text() == "Regions (1)"
    draw(vp, qtbot)
    shown = grab(window)
    changed = np.abs(shown - bare).max(axis=-1) > 24
    assert changed.sum() > 30
    ys, xs = np.nonzero(changed)
    mx, my = screen_of(window, window.doc.head.metadata.landmarks["lip_centre"])
    # the outline is around the mouth
    assert np.all(np.abs(xs - mx) < 90) and np.all(np.abs(ys - my) < 40), (mx, my, xs.min(), xs.max(), ys.min(), ys.max())
    picker.hide_overlay()
    assert vp.after_frame is None and picker.shown_regions() == []
    draw(vp, qtbot)
    assert np.abs(grab(window) - bare).max() <= 2


def test_mask_editor_builds_a_layer_mask_from_regions(window: object, qtbot: object) -> None:
    from painting import LayerMask

    doc, editor = window.doc, window.layers_panel.mask_editor
    assert editor is not None
    window.add_layer("Lipstick Classic Red")
    lay = doc.layers[-1]
    assert window.layers_panel.current_index() == len(doc.layers) - 1
    assert not editor.clear_button.isEnabled() and editor.entries.count() == 0
    steps = len(doc.history)
    editor.region_combo.setCurrentIndex(editor.region_combo.findData("lips"))
    editor.add_button.click()
    assert lay.mask == LayerMask((("union", "lips"),))
    assert editor.entries.item(0).text() == "∪ lips" and editor.clear_button.isEnabled()
    editor.region_combo.setCurrentIndex(editor.region_combo.findData("upper_lip"))
    editor.subtract_button.click()
    assert lay.mask.regions == (("union", "lips"), ("subtract", "upper_lip"))
    editor.invert_check.setChecked(True)
    assert lay.mask.invert
    m = doc.mask_values(lay)
    lower = doc.region_values("lower_lip", lay.resolution) > 0.99
    assert m is not None and float(m[lower].max()) < 0.05 and float(m[~lower].min()) >= 0.0  # inverted
    assert float(np.median(m)) == 1.0  # the rest of the face shows the layer
    editor.feather_spin.setValue(2.0)
    editor.feather_spin.editingFinished.emit()
    assert lay.mask.feather_mm == 2.0
    assert len(doc.history) == steps + 4  # one undo step per edit
    feathered = doc.mask_values(lay)
    assert feathered is not None and 0.0 < float(np.median(feathered[lower])) < 0.5  # softened edge
    window.undo()
    assert lay.mask.feather_mm == 0.0 and editor.feather_spin.value() == 0.0
    editor.entries.setCurrentRow(1)
    editor.remove_button.click()
    assert lay.mask.regions == (("union", "lips"),) and lay.mask.invert
    editor.clear_button.click()
    assert not lay.has_mask and editor.entries.count() == 0
    window.undo()
    assert lay.mask.regions == (("union", "lips"),)


def test_paint_mask_strokes_paint_the_channel_not_the_thickness(window: object, qtbot: object) -> None:
    doc, editor, vp = window.doc, window.layers_panel.mask_editor, window.viewport
    window.add_layer("Blush Peach")
    lay = doc.layers[-1]
    doc.fill(lay, 10.0)
    thickness = np.array(lay.thickness)
    editor.paint_check.setChecked(True)
    assert window.layers_panel.paint_mask
    window.mode_combo.setCurrentText("erase")
    try:
        start = QPoint(vp.width() // 2, int(vp.height() * 0.45))
        assert vp.pick(QPointF(start)) is not None
        qtbot.mousePress(vp, Qt.MouseButton.LeftButton, pos=start)
        for dx in range(3, 30, 3):
            qtbot.mouseMove(vp, QPoint(start.x() + dx, start.y()))
        qtbot.mouseRelease(vp, Qt.MouseButton.LeftButton, pos=QPoint(start.x() + 27, start.y()))
    finally:
        window.mode_combo.setCurrentText("add")
        editor.paint_check.setChecked(False)
    assert np.array_equal(np.asarray(lay.thickness), thickness)  # the thickness is untouched
    assert lay.mask_channel is not None and float(lay.mask_channel.min()) < 0.5  # the mask hides there
    m = doc.mask_values(lay)
    assert m is not None and (m < 0.5).sum() > 50 and float(m.max()) == 1.0
    assert editor.clear_button.isEnabled()  # the panel shows the layer has a mask now
    window.undo()  # the stroke
    assert float(lay.mask_channel.min()) == 1.0


def test_thickness_view_shows_the_masked_thickness(window: object, qtbot: object) -> None:
    """A layer filled everywhere under a lips mask: the thickness view shows it on the lips only."""
    from painting import LayerMask

    doc, vp = window.doc, window.viewport
    window.add_layer("Lipstick Classic Red")
    lay = doc.layers[-1]
    doc.fill(lay, 20.0)
    thickness_view = debug_views().index("thickness")
    lm = doc.head.metadata.landmarks
    lip = screen_of(window, lm["lower_lip"])
    cheek = screen_of(window, lm["chin"])  # (the test window's viewport is narrow: the chin is in view)
    vp.brush_ring = None
    try:
        window.change_settings(debug_view=thickness_view)
        draw(vp, qtbot)
        unmasked = grab(window)
        doc.set_layer_mask(lay, LayerMask((("union", "lips"),)))
        draw(vp, qtbot)
        masked = grab(window)
    finally:
        window.change_settings(debug_view=0)
        draw(vp, qtbot)

    def at(img: np.ndarray, xy: tuple[int, int]) -> np.ndarray:
        r = vp.devicePixelRatioF()
        x, y = int(xy[0] * r), int(xy[1] * r)
        return img[y - 1:y + 2, x - 1:x + 2].reshape(-1, 3).mean(axis=0)

    dark = np.array([0.02, 0.02, 0.02]) ** (1 / 2.2) * 255  # the view's "no thickness" colour (sRGB)
    assert np.abs(at(unmasked, cheek) - at(unmasked, lip)).max() < 12  # 20 µm everywhere: one heat colour
    assert at(unmasked, cheek).max() > 60
    assert np.abs(at(masked, lip) - at(unmasked, lip)).max() < 12  # the lips keep their 20 µm
    assert np.abs(at(masked, cheek) - dark).max() < 40  # the cheek shows no thickness
