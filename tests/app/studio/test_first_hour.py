"""A designer's first hour, as one script on real studio windows (xcb under Xvfb, Mesa GL): launch, apply a
look, paint, edit a material, save, quit, reopen, export. Each step goes through the widgets, the mouse and
the menu actions a designer uses (the file choosers answer with the project's path; the questions are the
real message boxes, answered by clicking), and its result is checked before the next."""

from __future__ import annotations

import json
import zipfile
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest
from PySide6.QtCore import QPoint, QPointF, QSettings, Qt

from app.qt_compat import pin_singletons
from tests.app.studio.studio_input import RED, click_row, pick_material, type_into
from tests.app.studio_support import DialogDriver

if TYPE_CHECKING:
    from pathlib import Path

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]


def launch(qtbot: Any, ini: Path) -> Any:
    """The studio as ``sheer studio`` starts it: the shipped library with the user's saved file over it, the
    head wearing the natural look, at 512² (the behaviour does not depend on the resolution)."""
    import app.studio.library_dock as library_dock
    from app.session import Session, load_library
    from app.studio.main_window import StudioWindow

    library = load_library(library_dock.user_library_path())
    win = StudioWindow(Session.open(resolution=512, look="natural", library=library),
                       qsettings=QSettings(str(ini), QSettings.Format.IniFormat))
    win.resize(900, 650)
    win.show()
    qtbot.waitUntil(lambda: win.viewport.frames > 0 and win.viewport.full_quality_ready, timeout=60000)
    assert not win.isWindowModified() and win.windowTitle().startswith("Untitled[*]")
    return win


def apply_look(win: Any, name: str) -> None:
    """The Looks menu's action for ``name`` when the studio has one, else the session's apply_look."""
    action = next((a for key, a in win.actions_by_id.items() if key.startswith("look") and name in key), None)
    if action is not None:
        action.trigger()
    else:
        win.files.session.apply_look(name)  # painting.looks.apply_look, the undo history cleared


def renderer_materials(win: Any) -> list[Any]:
    """The materials the viewport's renderer holds, bottom layer first (after the queued changes are drawn)."""
    return [inp.material for inp in win.viewport.renderer.r.km.layers]


def settle(win: Any, qtbot: Any) -> None:
    vp = win.viewport
    vp.update()
    qtbot.waitUntil(lambda: not vp.pending_changes, timeout=20000)


def paint_across(win: Any, qtbot: Any, y_frac: float) -> None:
    """A left-button drag over the face, rightwards from the viewport's centre column at ``y_frac``."""
    vp = win.viewport
    start = QPoint(vp.width() // 2, int(vp.height() * y_frac))
    assert vp.pick(QPointF(start)) is not None, "the stroke must start on the face"
    qtbot.mousePress(vp, Qt.MouseButton.LeftButton, pos=start)
    for dx in range(4, 44, 4):
        qtbot.mouseMove(vp, QPoint(start.x() + dx, start.y()))
    qtbot.mouseRelease(vp, Qt.MouseButton.LeftButton, pos=QPoint(start.x() + 40, start.y()))


class FileChooser:
    """Stands in for ``QFileDialog``'s choosers: the designer picks ``path`` each time."""

    path: Path

    @classmethod
    def getSaveFileName(cls, *_args: object, **_kwargs: object) -> tuple[str, str]:  # noqa: N802
        return str(cls.path), ""

    @classmethod
    def getOpenFileName(cls, *_args: object, **_kwargs: object) -> tuple[str, str]:  # noqa: N802
        return str(cls.path), ""


def test_a_designers_first_hour(qapp: Any, qtbot: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Long: one story, step by step, each result checked before the next step."""
    from painting.looks import load_look
    from project.io import open_project

    user_library = tmp_path / "data" / "library.json"
    project = tmp_path / "first look.sheer"
    FileChooser.path = project
    monkeypatch.setattr("app.studio.library_dock.user_library_path", lambda: user_library)
    monkeypatch.setattr("app.studio.project_files.QFileDialog", FileChooser)
    monkeypatch.setenv("SHEER_RECOVERY_DIR", str(tmp_path / "recovery"))
    ini = tmp_path / "studio.ini"
    driver = DialogDriver()
    windows: list[Any] = []
    try:
        # -- launch
        win = launch(qtbot, ini)
        windows.append(win)
        doc, panel, dock = win.doc, win.layers_panel, win.library_dock

        # -- apply a look: its layers, in the panel and in the renderer
        apply_look(win, "red-lip")
        look = load_look("red-lip")
        assert [lay.material for lay in doc.layers] == [lay.material for lay in look.layers]
        assert panel.list.count() == len(doc.layers) and win.isWindowModified()
        settle(win, qtbot)
        assert renderer_materials(win) == [lay.material_object for lay in doc.layers]

        # -- paint: pick the foundation layer in the panel, drag over the cheek
        base = next(i for i, lay in enumerate(doc.layers) if lay.material.startswith("Foundation"))
        click_row(qtbot, panel.list, panel.list.count() - 1 - base)
        assert win.selected_layer == base
        before = [np.array(lay.thickness, copy=True) for lay in doc.layers]
        steps = len(doc.history)
        paint_across(win, qtbot, 0.55)
        assert len(doc.history) == steps + 1
        assert not np.array_equal(doc.layers[base].thickness, before[base]), "the stroke painted nothing"
        assert all(np.array_equal(lay.thickness, b) for i, (lay, b) in enumerate(zip(doc.layers, before))
                   if i != base), "the stroke painted another layer"

        # -- edit a material: the lipstick, in the Material Library
        lip = next(i for i, lay in enumerate(doc.layers) if lay.material == RED)
        k_shipped = np.asarray(doc.layers[lip].material_object.K, float)
        pick_material(qtbot, dock, RED)
        type_into(qtbot, dock.spins["roughness"], "0.05")
        type_into(qtbot, dock.scales["K"], "0.2")
        edited = doc.layers[lip].material_object
        assert edited is win.library.get(RED) and edited.roughness == pytest.approx(0.05)
        assert np.allclose(edited.K, k_shipped * 0.2)
        settle(win, qtbot)
        assert renderer_materials(win)[lip] is edited, "the viewport does not show the edit"

        # -- save (Ctrl+S on an untitled project: the file chooser names it)
        painted = [np.array(lay.thickness, copy=True) for lay in doc.layers]
        win.actions_by_id["file.save"].trigger()
        assert project.is_file() and not win.isWindowModified()
        assert win.windowTitle().startswith("first look[*]") and str(project) in win.settings.recent_files
        saved = open_project(project)
        assert [pl.material for pl in saved.layers] == [lay.material for lay in doc.layers]
        assert all(np.array_equal(pl.thickness, m) for pl, m in zip(saved.layers, painted, strict=True))
        with zipfile.ZipFile(project) as zf:
            embedded = json.loads(zf.read("project.json"))["materials"][RED]
        assert embedded["roughness"] == pytest.approx(0.05) and np.allclose(embedded["K"], k_shipped * 0.2)

        # -- quit (Ctrl+Q): the project is saved, the library's edit is not: asked once, "Save"
        driver.answer("Save")
        win.actions_by_id["file.quit"].trigger()
        qtbot.waitUntil(lambda: not win.isVisible(), timeout=20000)
        assert [q.title for q in driver.questions()] == ["Unsaved library changes"]
        assert RED in driver.questions()[0].text and str(user_library) in driver.questions()[0].text
        mine = json.loads(user_library.read_text(encoding="utf-8"))
        red = next(m for m in mine["materials"] if m["name"] == RED)
        assert red["roughness"] == pytest.approx(0.05)

        # -- reopen: a new studio (with the user's library), File → Open Project
        driver.shown.clear()
        win = launch(qtbot, ini)
        windows.append(win)
        doc = win.doc
        assert win.library.get(RED).roughness == pytest.approx(0.05), "the saved library did not come back"
        win.actions_by_id["file.open"].trigger()
        qtbot.waitUntil(lambda: win.files.path == project, timeout=60000)
        assert not driver.questions() and not win.isWindowModified()
        assert [lay.material for lay in doc.layers] == [pl.material for pl in saved.layers]
        assert all(np.array_equal(lay.thickness, m) for lay, m in zip(doc.layers, painted, strict=True))
        reopened = doc.layers[lip].material_object
        assert reopened.roughness == pytest.approx(0.05) and np.allclose(reopened.K, k_shipped * 0.2)
        settle(win, qtbot)
        assert renderer_materials(win)[lip] is reopened

        # -- export a rendered image of the reopened look
        results: list[object] = []
        win.exports.export_image(tmp_path / "first look.png", (320, 240), on_done=results.append)
        qtbot.waitUntil(lambda: len(results) == 1, timeout=120000)
        from PIL import Image

        img = np.asarray(Image.open(tmp_path / "first look.png"))
        assert img.shape == (240, 320, 3) and img.std() > 5

        # -- quit: nothing unsaved, nothing asked
        win.actions_by_id["file.quit"].trigger()
        qtbot.waitUntil(lambda: not win.isVisible(), timeout=20000)
        assert not driver.questions()
    finally:
        driver.answers[:] = ["Discard", "Discard"]
        for w in windows:
            if w.isVisible():
                w.close()
        driver.stop()
        for w in windows:
            w.deleteLater()
