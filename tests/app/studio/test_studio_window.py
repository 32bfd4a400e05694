"""The studio on a real window (xcb under Xvfb, Mesa GL): viewport, painting, undo/redo, layers, materials,
measurement import, exports, tear-down. One window for the module keeps the suite fast."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import numpy as np
import pytest
from PySide6.QtCore import Qt

from app.qt_compat import pin_singletons
from render.view import debug_views
from tests.app.studio_support import DialogDriver, studio_fixture, window_fixture

if TYPE_CHECKING:
    from pathlib import Path

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]


studio = studio_fixture()
window = window_fixture()


@pytest.fixture
def driver(studio: tuple[object, DialogDriver]) -> DialogDriver:
    """The module window's dialog driver, with what it answered so far forgotten."""
    studio[1].shown.clear()
    return studio[1]


def draw(vp: object, qtbot: object) -> None:
    """Ask for a frame and wait until the viewport has drawn it (a ``repaint`` of a window that is not
    exposed yet does nothing)."""
    before = vp.frames
    vp.update()
    qtbot.waitUntil(lambda: vp.frames > before, timeout=20000)


def grab(win: object) -> np.ndarray:
    from app.qt_compat import qimage_to_rgb

    return qimage_to_rgb(win.viewport.grabFramebuffer())


def stroke_across(win: object, qtbot: object, y_frac: float) -> None:
    """A 30-pixel drag of the left mouse button rightwards from the viewport's centre column at ``y_frac``
    of its height (on the face: a stroke, one undo step)."""
    from PySide6.QtCore import QPoint, QPointF

    vp = win.viewport
    start = QPoint(vp.width() // 2, int(vp.height() * y_frac))
    assert vp.pick(QPointF(start)) is not None, "the stroke must start on the face"
    steps = len(win.doc.history)
    qtbot.mousePress(vp, Qt.MouseButton.LeftButton, pos=start)
    for dx in range(3, 30, 3):
        qtbot.mouseMove(vp, QPoint(start.x() + dx, start.y()))
    qtbot.mouseRelease(vp, Qt.MouseButton.LeftButton, pos=QPoint(start.x() + 27, start.y()))
    assert len(win.doc.history) == steps + 1, "the drag was not one stroke"


def test_viewport_shows_the_head(window: object) -> None:
    img = grab(window)
    h, w = img.shape[:2]
    centre = img[h // 3: 2 * h // 3, w // 3: 2 * w // 3].reshape(-1, 3).astype(int)
    skin = (centre[:, 0] > 90) & (centre[:, 0] > centre[:, 1]) & (centre[:, 1] > centre[:, 2] - 10)
    assert skin.mean() > 0.6, f"only {skin.mean():.0%} skin-coloured pixels in the middle"
    assert img.std() > 10, "the frame is blank"


def test_viewport_runs_the_real_renderer_at_full_size(window: object, qtbot: object) -> None:
    from render import Renderer

    vp = window.viewport
    assert isinstance(vp.renderer.r, Renderer)
    vp.orbit_by(3.0)
    drawn = vp.renderer_frames
    draw(vp, qtbot)
    assert vp.renderer_frames > drawn, "an orbit step must draw a new frame"
    # while the view moves the frame is interactive (reduced internal size); once input stops it
    # settles to the full-size frame
    assert vp.last_frame_interactive
    w, h = vp.pixel_size()
    assert tuple(vp.renderer.r.last.size) < (w, h), "an interactive frame runs at a reduced size"
    qtbot.waitUntil(lambda: vp.settled, timeout=5000)
    assert tuple(vp.renderer.r.last.size) == vp.pixel_size()
    vp.orbit_by(-3.0)
    qtbot.waitUntil(lambda: vp.settled, timeout=5000)


def test_swatches_are_kms_colours(window: object) -> None:
    """Swatches come from km (no colour maths of the app's own); the placeholders drawn while km's colour
    module loads are replaced once the renderer is up."""
    from app.studio.layers_panel import material_rgb

    m = window.library.get(window.doc.layers[0].material)
    hex_rgb = m.swatch_hex("opaque")
    assert material_rgb(m) == tuple(int(hex_rgb[i:i + 2], 16) for i in (1, 3, 5))
    black = m.swatch_rgb("black", 20.0)
    assert material_rgb(m, 20.0) == tuple(int(round(float(c) * 255)) for c in black)
    item = window.layers_panel.list.item(window.layers_panel.list.count() - 1)  # the bottom layer
    colour = item.icon().pixmap(8, 8).toImage().pixelColor(4, 4)
    # the layer list shows the material as applied (on the reference skin, at its default thickness)
    from app.studio.layers_panel import applied_rgb
    from km.srgb import srgb_encode

    applied = tuple(int(round(float(c) * 255)) for c in srgb_encode(np.clip(m.applied_rgb("reference"), 0, 1)))
    assert (colour.red(), colour.green(), colour.blue()) == applied_rgb(m) == applied


def test_title_and_actions(window: object) -> None:
    assert "Untitled" in window.windowTitle()
    assert window.actions_by_id["edit.undo"].shortcut().toString() == "Ctrl+Z"
    assert window.actions_by_id["edit.redo"].shortcut().toString() == "Ctrl+Shift+Z"
    assert not window.actions_by_id["edit.undo"].isEnabled()  # the look is not an undo step


def test_paint_stroke_changes_the_map_then_undo_redo(window: object, qtbot: object) -> None:
    from PySide6.QtCore import QPoint, Qt

    window.add_layer("Blush Peach")
    idx = len(window.doc.layers) - 1
    assert window.selected_layer == idx
    layer = window.doc.layers[idx]
    before = layer.thickness.copy()
    vp = window.viewport
    c = QPoint(vp.width() // 2, vp.height() // 2)
    qtbot.mousePress(vp, Qt.MouseButton.LeftButton, pos=c)
    for dx in range(0, 40, 4):
        qtbot.mouseMove(vp, QPoint(c.x() + dx, c.y() - dx // 2))
    qtbot.mouseRelease(vp, Qt.MouseButton.LeftButton, pos=QPoint(c.x() + 40, c.y() - 20))
    painted = layer.thickness.copy()
    assert (painted > before).sum() > 50, "the stroke did not change the layer's map"
    assert window.isWindowModified()
    window.actions_by_id["edit.undo"].trigger()
    assert np.array_equal(layer.thickness, before)
    window.actions_by_id["edit.redo"].trigger()
    assert np.array_equal(layer.thickness, painted)
    qtbot.waitUntil(lambda: not vp.pending_changes, timeout=5000)


def test_painting_changes_the_rendered_face(window: object, qtbot: object) -> None:
    """A stroke reaches the screen: dirty tiles → the renderer's texture-space KM → a new frame."""

    window.add_layer("Lipstick Classic Red")
    vp = window.viewport
    vp.brush_ring = None
    qtbot.waitUntil(lambda: not vp.pending_changes, timeout=5000)
    before = grab(window).astype(int)
    stroke_across(window, qtbot, 0.55)
    assert vp.pending_changes
    vp.brush_ring = None
    after = grab(window).astype(int)
    assert not vp.pending_changes
    assert (np.abs(after - before).max(axis=-1) > 10).sum() > 100, "the stroke did not show in the viewport"
    window.undo()


def test_thickness_view_shows_the_selected_layer_with_a_hidden_layer_below(window: object, qtbot: object) -> None:
    """``settings.debug_layer`` indexes the renderer's active layers: hide layer 0 and select layer 2,
    the renderer must show its active slot 1, not slot 2 (which would be clamped to another layer)."""
    from render.view import debug_slot

    assert debug_slot([1, 2], 2) == 1 and debug_slot([0, 2], 1) is None and debug_slot([0, 1, 2], 2) == 2
    vp = window.viewport
    n = len(window.doc.layers)
    assert n >= 3
    thickness = debug_views().index("thickness")
    try:
        window.doc.set_layer(0, visible=False)
        window._select_layer(2)
        window.change_settings(debug_view=thickness)
        draw(vp, qtbot)
        r = vp.renderer.r
        assert 0 not in r.km.active and r.settings.debug_view == "thickness"
        assert r.km.active[r.settings.debug_layer] == 2
        assert not vp.notice.isVisible()
        window._select_layer(0)  # the hidden layer: nothing to show, and the viewport says so
        draw(vp, qtbot)
        assert vp.renderer.debug_hidden and r.settings.debug_view == "none"
        assert vp.notice.isVisible() and "hidden" in vp.notice.text()
    finally:
        window.change_settings(debug_view=0)
        window.doc.set_layer(0, visible=True)
        window._select_layer(0)
        draw(vp, qtbot)
    assert not vp.notice.isVisible()


def test_lightweight_mode_with_a_captured_face(window: object, qtbot: object, tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """File → Open Captured Face…, then the lightweight engine draws the view (picking and painting work)."""
    from PySide6.QtCore import QPointF
    from PySide6.QtWidgets import QFileDialog

    from render.lightweight import LightweightRenderer
    from tests.app.studio_support import write_test_face

    vp = window.viewport
    vp.brush_ring = None
    # without a face, choosing the mode asks for one; cancelling leaves the mode as it was
    monkeypatch.setattr(QFileDialog, "getExistingDirectory", staticmethod(lambda *a, **k: ""))
    window.render_combo.setCurrentText("lightweight")
    assert window.settings.render_mode == "fast" and window.render_combo.currentText() == "fast"
    draw(vp, qtbot)
    physical = grab(window).astype(int)
    centre = QPointF(vp.width() / 2, vp.height() * 0.5)
    p_phys = vp.pick(centre)
    opened: list[object] = []
    window.open_face(write_test_face(tmp_path / "face"), on_done=opened.append)
    qtbot.waitUntil(lambda: len(opened) == 1, timeout=30000)
    try:
        assert window.settings.render_mode == "lightweight" and window.actions_by_id["view.mode_lightweight"].isChecked()
        draw(vp, qtbot)
        assert isinstance(vp.renderer._lw, LightweightRenderer) and vp.renderer.drawn_by == "lightweight"
        light = grab(window).astype(int)
        h, w = light.shape[:2]
        mid = light[h // 3: 2 * h // 3, w // 3: 2 * w // 3]
        assert mid.std() > 5 and mid.mean() > 40, "the lightweight frame is blank"
        assert (np.abs(light - physical).max(axis=-1) > 12).mean() > 0.05, "still the physical renderer"
        p_light = vp.pick(centre)
        assert p_phys is not None and p_light is not None
        assert np.linalg.norm(p_light - p_phys) < 0.05, "picking the lightweight frame missed the surface"
        # File → Export Rendered Image in this mode renders with the lightweight engine too
        from PIL import Image

        done: list[object] = []
        window.exports.export_image(tmp_path / "lw.png", (200, 150), on_done=done.append)
        window.set_render_mode("fast")
        window.exports.export_image(tmp_path / "fast.png", (200, 150), on_done=done.append)
        window.set_render_mode("lightweight")
        qtbot.waitUntil(lambda: len(done) == 2, timeout=120000)
        lw_img = np.asarray(Image.open(tmp_path / "lw.png")).astype(int)
        fast_img = np.asarray(Image.open(tmp_path / "fast.png")).astype(int)
        assert lw_img.shape == fast_img.shape == (150, 200, 3) and lw_img.std() > 5
        assert (np.abs(lw_img - fast_img).max(axis=-1) > 12).mean() > 0.05
        # File → Close Captured Face: back to the physical renderer, the action disabled until a face opens
        assert window.actions_by_id["file.close_face"].isEnabled()
        window.actions_by_id["file.close_face"].trigger()
        assert vp.face is None and window.face_path is None and window.settings.render_mode == "fast"
        assert not window.actions_by_id["file.close_face"].isEnabled()
    finally:
        window.set_render_mode("fast")
    draw(vp, qtbot)
    assert vp.renderer.drawn_by == "fast"


def test_lightweight_mode_shows_the_makeup(window: object, qtbot: object, tmp_path: Path) -> None:
    """A stroke in the lightweight mode shows through the physical renderer's texture-space KM outputs."""
    from tests.app.studio_support import write_test_face

    vp = window.viewport
    vp.brush_ring = None
    opened: list[object] = []
    window.open_face(write_test_face(tmp_path / "face"), on_done=opened.append)
    qtbot.waitUntil(lambda: len(opened) == 1, timeout=30000)
    try:
        window.add_layer("Lipstick Classic Red")
        draw(vp, qtbot)
        before = grab(window).astype(int)
        stroke_across(window, qtbot, 0.5)
        after = grab(window).astype(int)
        window.undo()
        assert (np.abs(after - before).max(axis=-1) > 10).sum() > 100, "the stroke did not show"
    finally:
        window.set_render_mode("fast")


def test_a_failing_frame_is_a_message_not_a_traceback(window: object, qtbot: object, driver: DialogDriver,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    vp = window.viewport
    real = vp.renderer.render

    def broken(*args: object, **kwargs: object) -> bool:
        raise RuntimeError("simulated GL failure")

    monkeypatch.setattr(vp.renderer, "render", broken)
    vp.orbit_by(1.0)
    qtbot.waitUntil(lambda: vp.renderer_error is not None, timeout=20000)
    qtbot.waitUntil(lambda: any("simulated GL failure" in d.text for d in driver.shown), timeout=5000)
    assert driver.shown[-1].kind == "error" and driver.shown[-1].title == "Viewport"
    monkeypatch.setattr(vp.renderer, "render", real)
    vp.renderer_error = None
    vp.orbit_by(-1.0)
    vp.refresh()
    drawn = vp.renderer_frames
    draw(vp, qtbot)
    assert vp.renderer_frames > drawn


def test_layer_opacity_visibility_rename(window: object) -> None:
    panel = window.layers_panel
    panel.list.setCurrentRow(0)  # the top layer
    top = len(window.doc.layers) - 1
    panel.opacity.setValue(40)
    assert window.doc.layers[top].opacity == pytest.approx(0.4)
    item = panel.list.item(0)
    item.setText("Lips")
    assert window.doc.layers[top].name == "Lips"
    panel.list.item(0).setCheckState(Qt.CheckState.Unchecked)
    assert not window.doc.layers[top].visible
    for _ in range(3):
        window.undo()
    lay = window.doc.layers[top]
    assert lay.visible and lay.name != "Lips" and lay.opacity == pytest.approx(1.0)


def test_reorder_layers(window: object) -> None:
    names = [lay.name for lay in window.doc.layers]
    window.layers_panel.move_requested.emit(0, len(names) - 1)
    after = [lay.name for lay in window.doc.layers]
    assert after == [*names[1:], names[0]]
    panel_top = window.layers_panel.list.item(0).text()
    assert panel_top == names[0]
    window.undo()
    assert [lay.name for lay in window.doc.layers] == names


def test_edit_material_updates_the_viewport(window: object, qtbot: object) -> None:
    from PySide6.QtWidgets import QApplication

    lip = next(lay for lay in window.doc.layers if lay.name == "Lipstick")
    window.layers_panel.list.setCurrentRow(0)
    dock = window.library_dock
    dock.select(lip.material)
    # the material's editor, shown the first time a material is selected, grows the window (and the
    # viewport): the layout settles before the first grab, so that both grabs have the same size
    QApplication.processEvents()
    qtbot.waitUntil(lambda: not window.viewport.pending_changes, timeout=5000)
    before = grab(window).astype(int)
    k_before = np.array(window.library.get(lip.material).K)
    dock.scale_spectrum("K", 6.0)
    assert np.allclose(window.library.get(lip.material).K, k_before * 6.0)
    qtbot.waitUntil(lambda: not window.viewport.pending_changes, timeout=5000)
    after = grab(window).astype(int)
    changed = (np.abs(after - before).max(axis=-1) > 8).mean()
    assert changed > 0.001, "editing the lipstick material did not change the viewport"
    window.undo()  # a library edit is a step of the document's history
    assert np.allclose(window.library.get(lip.material).K, k_before)



def test_malformed_measurement_import_leaves_the_library_unchanged(window: object, driver: DialogDriver,
                                                                   tmp_path: Path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("wavelength,R_inf,R,Rg\n400,abc,0.2\n410,2.5,-1,0.1\nnot,a,number,row\n", encoding="utf-8")
    names = list(window.library.names())
    assert window.library_dock.import_measurement(bad) is False
    assert driver.shown and driver.shown[-1].kind == "error"
    assert list(window.library.names()) == names


def test_export_maps_and_gltf(window: object, qtbot: object, driver: DialogDriver, tmp_path: Path) -> None:
    import trimesh
    from PIL import Image

    results: list[object] = []
    window.exports.export_maps(tmp_path / "maps", on_done=results.append)
    qtbot.waitUntil(lambda: len(results) == 1, timeout=20000)
    manifest = json.loads((tmp_path / "maps" / "manifest.json").read_text())
    assert len(manifest["layers"]) == len(window.doc.layers)
    first = Image.open(tmp_path / "maps" / manifest["layers"][0]["file"])
    assert first.mode.startswith("I;16") or first.mode == "I"
    window.exports.export_maps(tmp_path / "exr", on_done=results.append, fmt="exr")
    qtbot.waitUntil(lambda: len(results) == 2, timeout=20000)
    assert len(list((tmp_path / "exr").glob("*.exr"))) == len(window.doc.layers)
    results.clear()
    # a layer's map back in: identical within the 16-bit quantisation; a bad file: an error, no change
    lay0 = np.array(window.doc.layers[0].thickness)
    assert window.exports.import_map(0, tmp_path / "maps" / manifest["layers"][0]["file"])
    assert np.allclose(window.doc.layers[0].thickness, lay0, atol=manifest["layers"][0]["scale_um"] / 30000)
    bad = tmp_path / "bad.png"
    bad.write_text("not an image")
    assert not window.exports.import_map(0, bad)
    assert driver.shown[-1].kind == "error" and driver.shown[-1].title == "Import map"
    window.undo()
    window.exports.export_gltf(tmp_path / "face.glb", on_done=results.append)
    qtbot.waitUntil(lambda: len(results) == 1, timeout=60000)
    scene = trimesh.load(tmp_path / "face.glb")
    geom = list(scene.geometry.values())[0]
    assert len(geom.faces) == len(window.doc.head.faces)
    tex = geom.visual.material.baseColorTexture
    assert tex is not None and tex.size[0] >= 512
    # the makeup is baked in: where the lipstick layer is thick the colour differs from the bare skin,
    # where no layer has paint it is the skin's own (the renderer's KM outputs, as its "unlit" view)
    baked = np.asarray(tex.convert("RGB")).astype(int)
    skin = np.asarray(window.doc.head.albedo)[..., :3].astype(int)
    assert baked.shape == skin.shape
    lip = next(lay for lay in window.doc.layers if lay.name == "Lipstick")
    thick = np.asarray(Image.fromarray(np.asarray(lip.thickness, np.float32), mode="F")
                       .resize((skin.shape[1], skin.shape[0]))) > 0.5 * float(np.max(lip.thickness))
    bare = np.asarray(Image.fromarray(np.asarray(sum(np.asarray(lay.thickness) for lay in window.doc.layers),
                                                 np.float32), mode="F").resize((skin.shape[1], skin.shape[0]))) == 0
    assert thick.sum() > 50 and bare.sum() > 50
    assert np.abs(baked[thick] - skin[thick]).max(axis=-1).mean() > 20
    assert np.abs(baked[bare] - skin[bare]).max(axis=-1).mean() < 3


def test_about_and_shortcut_sheet(window: object, driver: DialogDriver) -> None:
    from app.actions import shortcut_sheet

    window.show_about()
    window.show_shortcuts()
    assert [(d.kind, d.title) for d in driver.shown] == [("dialog", "About Sheer"), ("dialog", "Keyboard Shortcuts")]
    keys = {row[2] for row in shortcut_sheet()}
    assert {"[", "]", "Shift+[", "Shift+]", "E", "S", "X", "Ctrl+Z", "Ctrl+Shift+Z", "F"} <= keys
    window.apply()
    assert "Lee Perry-Smith" in window.credit_label.text()  # CC BY: credited while the head is shown


def test_brush_shortcuts(window: object, qtbot: object) -> None:
    from PySide6.QtCore import Qt

    window.activateWindow()
    window.raise_()
    qtbot.waitUntil(window.isActiveWindow, timeout=5000)
    window.viewport.setFocus()
    r0, s0 = window.settings.brush_radius_mm, window.settings.brush_strength
    qtbot.keyClick(window.viewport, Qt.Key.Key_BracketRight)
    assert window.settings.brush_radius_mm == pytest.approx(r0 * 1.2)
    qtbot.keyClick(window.viewport, Qt.Key.Key_BracketLeft)
    assert window.settings.brush_radius_mm == pytest.approx(r0)
    window.actions_by_id["brush.weaker"].trigger()
    assert window.settings.brush_strength == pytest.approx(s0 - 0.1)
    window.actions_by_id["brush.stronger"].trigger()
    qtbot.keyClick(window.viewport, Qt.Key.Key_E)
    assert window.settings.brush_mode == "erase"
    qtbot.keyClick(window.viewport, Qt.Key.Key_S)
    assert window.settings.brush_mode == "smooth"
    qtbot.keyClick(window.viewport, Qt.Key.Key_S)
    assert window.settings.brush_mode == "add"
    qtbot.keyClick(window.viewport, Qt.Key.Key_X)
    assert window.settings.brush_mirror
    qtbot.keyClick(window.viewport, Qt.Key.Key_X)
    assert not window.settings.brush_mirror


def test_project_save_open_and_autosave(window: object, qtbot: object, driver: DialogDriver,
                                        tmp_path: Path) -> None:
    from app import project_io

    path = tmp_path / "look.sheer"
    names = [lay.name for lay in window.doc.layers]
    maps = [np.array(lay.thickness) for lay in window.doc.layers]
    assert window.files.save_project(path=path)
    assert path.is_file() and not window.isWindowModified()
    assert "look" in window.windowTitle()
    window.add_layer("Blush Peach")
    assert window.files.open_project(path)
    assert [lay.name for lay in window.doc.layers] == names
    for lay, m in zip(window.doc.layers, maps):
        assert np.allclose(lay.thickness, m, atol=1e-3)
    window.add_layer("Blush Peach")
    window.files.open_project(path, background=True)
    qtbot.waitUntil(lambda: [lay.name for lay in window.doc.layers] == names, timeout=20000)
    broken = tmp_path / "broken.sheer"
    broken.write_bytes(b"not a zip")
    assert not window.files.open_project(broken)
    assert driver.shown[-1].kind == "error" and [lay.name for lay in window.doc.layers] == names
    saver = project_io.make_autosaver(window.files.snapshot, path, 0.01)
    written = saver.autosave_now()
    assert written.is_file()
    saver.close()
    assert not written.exists()


def test_export_rendered_image(window: object, qtbot: object, tmp_path: Path) -> None:
    from PIL import Image

    results: list[object] = []
    window.exports.export_image(tmp_path / "render.png", (320, 240), on_done=results.append)
    qtbot.waitUntil(lambda: len(results) == 1, timeout=120000)
    img = np.asarray(Image.open(tmp_path / "render.png"))
    assert img.shape == (240, 320, 3) and img.std() > 5


def test_library_duplicate_delete_mix_undo(window: object) -> None:
    dock = window.library_dock
    names = list(window.library.names())
    used = window.doc.layers[0].material
    dock.select(used)
    dock.duplicate_current()
    assert len(window.library.names()) == len(names) + 1
    copy_name = dock.current
    dock.delete_current()
    assert copy_name not in window.library
    dock.select(used)
    dock.delete_current()  # in use by a layer: refused
    assert used in window.library
    dock.mix_amount.setValue(30)
    dock.create_variant()
    assert len(window.library.names()) == len(names) + 1
    for _ in range(3):
        window.undo()
    assert list(window.library.names()) == names


def test_brush_ring_follows_the_surface(window: object, qtbot: object) -> None:
    from PySide6.QtCore import QPoint, QPointF

    vp = window.viewport
    vp.brush_ring = None
    plain = grab(window).astype(int)
    drawn = vp.renderer_frames
    where = QPoint(vp.width() // 2, int(vp.height() * 0.45))
    qtbot.mouseMove(vp, where)
    qtbot.waitUntil(lambda: vp.brush_ring is not None, timeout=3000)
    hit = vp.pick(QPointF(where))
    assert hit is not None and np.allclose(vp.brush_ring, hit, atol=0.05)
    with_ring = grab(window).astype(int)
    assert (np.abs(with_ring - plain).max(axis=-1) > 25).sum() > 30
    assert vp.renderer_frames == drawn, "moving the brush ring alone must reuse the renderer's last frame"


def test_measurement_import_in_background_reports_rejected_rows(window: object, qtbot: object,
                                                                 driver: DialogDriver, tmp_path: Path) -> None:
    rows = ["# name: Test Rouge", "# category: lipstick", "# D_mm: 0.02", "wavelength,R_inf,R,Rg"]
    for wl in range(400, 701, 10):
        r_inf = 0.1 + 0.6 * (wl - 400) / 300
        rows.append(f"{wl},{r_inf:.4f},{0.6 * r_inf:.4f},0.04")
    rows.insert(10, "555,abc,0.3,0.04")
    good = tmp_path / "rouge.csv"
    good.write_text("\n".join(rows) + "\n", encoding="utf-8")
    n = len(window.library.names())
    window.library_dock.import_measurement(good, background=True)
    qtbot.waitUntil(lambda: len(window.library.names()) == n + 1, timeout=20000)
    assert any("Test Rouge" in name for name in window.library.names())
    qtbot.waitUntil(lambda: bool(driver.shown), timeout=5000)
    assert "rejected" in driver.shown[-1].text
    window.undo()
    assert len(window.library.names()) == n


@pytest.mark.parametrize("mode", ["fast", "reference"])
def test_the_view_settles_once_after_input_stops(window: object, qtbot: object, mode: str) -> None:
    """Progressive refinement: interactive frames while input goes on and no full frame among them; when it
    stops, exactly one full-resolution frame (fast), then in reference mode the reference frame."""
    from app.view.viewport import SETTLE_MS

    vp = window.viewport
    window.change_settings(render_mode=mode)
    try:
        qtbot.waitUntil(lambda: vp.settled, timeout=10000)
        settled_before = vp.settled_frames
        drawn = vp.renderer_frames
        for _ in range(10):
            vp.orbit_by(0.5)
            qtbot.wait(SETTLE_MS // 6)
            assert vp.settled_frames == settled_before, "a full frame was drawn while input continued"
        assert vp.renderer_frames > drawn and vp.last_frame_interactive
        assert vp.renderer.r.last.size < vp.pixel_size()
        qtbot.waitUntil(lambda: vp.settled, timeout=10000)
        qtbot.wait(SETTLE_MS * 3)  # nothing more follows
        assert vp.settled_frames == settled_before + (2 if mode == "reference" else 1)
        assert tuple(vp.renderer.r.last.size) == vp.pixel_size()
        assert vp.renderer.drawn_by == mode and not vp.renderer.interactive
    finally:
        window.change_settings(render_mode="fast")
        qtbot.waitUntil(lambda: vp.settled, timeout=10000)


def test_overlay_shows_interactive_and_settled_frames(window: object, qtbot: object) -> None:
    vp = window.viewport
    window.change_settings(overlay=True)
    try:
        vp.orbit_by(0.5)
        qtbot.waitUntil(lambda: vp.last_frame_interactive, timeout=10000)
        text = vp.overlay.text()
        assert "interactive" in text and "budget" in text and "scale cap" in text, text
        qtbot.waitUntil(lambda: vp.settled, timeout=10000)
        assert "settled 1.00×" in vp.overlay.text()
    finally:
        window.change_settings(overlay=False)


def test_interactive_scale_cap_setting(window: object, qtbot: object) -> None:
    vp = window.viewport
    try:
        window.actions_by_id["view.scale_100"].trigger()
        assert window.settings.interactive_scale_cap == 1.0 and vp.refine.max_scale == 1.0
        assert window.actions_by_id["view.scale_100"].isChecked()
        assert not window.actions_by_id["view.scale_75"].isChecked()
        window.actions_by_id["view.scale_50"].trigger()
        assert vp.refine.max_scale == 0.5 and vp.refine.scale <= 0.5
        vp.orbit_by(0.5)
        qtbot.waitUntil(lambda: vp.last_frame_interactive, timeout=10000)
        assert vp.renderer.scale <= 0.5 + 1e-6
    finally:
        window.actions_by_id["view.scale_75"].trigger()
        qtbot.waitUntil(lambda: vp.settled, timeout=10000)
