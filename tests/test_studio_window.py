"""The studio on a real window (xcb under Xvfb, Mesa GL): viewport, painting, undo/redo, layers, materials,
measurement import, exports, tear-down. One window for the module keeps the suite fast."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from app.qt_compat import pin_singletons

pin_singletons()

pytest.importorskip("pytestqt")
pytestmark = [pytest.mark.qt, pytest.mark.gl]


@pytest.fixture(scope="module")
def window(qapp: object, tmp_path_factory: pytest.TempPathFactory) -> Iterator[object]:
    from PySide6.QtCore import QSettings

    from app import dialogs
    from app.main_window import StudioWindow

    dialogs.AUTO_DISMISS_MS = 30
    ini = tmp_path_factory.mktemp("settings") / "studio.ini"
    win = StudioWindow(qsettings=QSettings(str(ini), QSettings.Format.IniFormat))
    win.resize(800, 600)
    win.show()
    from pytestqt.qtbot import QtBot

    QtBot(qapp).waitUntil(lambda: win.viewport.frames > 0 and win.viewport.full_quality_ready, timeout=60000)
    yield win
    win.close()
    assert win.viewport.gl_error_at_release == "GL_NO_ERROR"
    win.deleteLater()


def grab(win: object) -> np.ndarray:
    from app.qt_compat import qimage_to_rgb

    return qimage_to_rgb(win.viewport.grabFramebuffer())


def test_viewport_shows_the_head(window: object) -> None:
    img = grab(window)
    h, w = img.shape[:2]
    centre = img[h // 3: 2 * h // 3, w // 3: 2 * w // 3].reshape(-1, 3).astype(int)
    skin = (centre[:, 0] > 90) & (centre[:, 0] > centre[:, 1]) & (centre[:, 1] > centre[:, 2] - 10)
    assert skin.mean() > 0.6, f"only {skin.mean():.0%} skin-coloured pixels in the middle"
    assert img.std() > 10, "the frame is blank"


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
    qtbot.waitUntil(lambda: vp._pending_layers is None, timeout=5000)


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
    lip = next(lay for lay in window.doc.layers if lay.name == "Lipstick")
    window.layers_panel.list.setCurrentRow(0)
    dock = window.library_dock
    dock.select(lip.material)
    qtbot.waitUntil(lambda: window.viewport._pending_layers is None, timeout=5000)
    before = grab(window).astype(int)
    k_before = np.array(window.library.get(lip.material).K)
    dock.scale_spectrum("K", 6.0)
    assert np.allclose(window.library.get(lip.material).K, k_before * 6.0)
    qtbot.waitUntil(lambda: window.viewport._pending_layers is None, timeout=5000)
    after = grab(window).astype(int)
    changed = (np.abs(after - before).max(axis=-1) > 8).mean()
    assert changed > 0.001, "editing the lipstick material did not change the viewport"
    dock.undo_stack.undo()
    assert np.allclose(window.library.get(lip.material).K, k_before)



def test_malformed_measurement_import_leaves_the_library_unchanged(window: object, tmp_path: Path) -> None:
    from app import dialogs

    bad = tmp_path / "bad.csv"
    bad.write_text("wavelength,R_inf,R,Rg\n400,abc,0.2\n410,2.5,-1,0.1\nnot,a,number,row\n", encoding="utf-8")
    names = list(window.library.names())
    dialogs.HISTORY.clear()
    assert window.library_dock.import_measurement(bad) is False
    assert dialogs.HISTORY and dialogs.HISTORY[-1][0] == "error"
    assert list(window.library.names()) == names


def test_export_maps_and_gltf(window: object, qtbot: object, tmp_path: Path) -> None:
    import trimesh
    from PIL import Image

    results: list[object] = []
    window.export_maps(tmp_path / "maps", on_done=results.append)
    qtbot.waitUntil(lambda: len(results) == 1, timeout=20000)
    manifest = json.loads((tmp_path / "maps" / "manifest.json").read_text())
    assert len(manifest["layers"]) == len(window.doc.layers)
    first = Image.open(tmp_path / "maps" / manifest["layers"][0]["file"])
    assert first.mode.startswith("I;16") or first.mode == "I"
    window.export_gltf(tmp_path / "face.glb", on_done=results.append)
    qtbot.waitUntil(lambda: len(results) == 2, timeout=60000)
    scene = trimesh.load(tmp_path / "face.glb")
    geom = list(scene.geometry.values())[0]
    assert len(geom.faces) == len(window.doc.head.faces)
    tex = geom.visual.material.baseColorTexture
    assert tex is not None and tex.size[0] >= 512


def test_about_and_shortcut_sheet(window: object) -> None:
    from app.actions import shortcut_sheet

    window.show_about()
    window.show_shortcuts()
    keys = {row[2] for row in shortcut_sheet()}
    assert {"[", "]", "Shift+[", "Shift+]", "E", "S", "X", "Ctrl+Z", "Ctrl+Shift+Z", "F"} <= keys
