"""Lost or silently changed work, on a real studio window (xcb under Xvfb, Mesa GL) driven through its widgets:

- a Material Library edit (typed into the dock's fields) is worn by the layers: the renderer draws it, the
  title gets its ``*``, Save embeds it, ``sheer render --project`` shows it, and quitting asks — first
  about the project, then, once it is saved, about the library's own file;
- the Layers panel's fields follow the selection and never write a value the user did not change;
- moving the key light (saved in projects) marks the document modified, and quitting asks;
- ``sheer studio --project`` refuses a corrupt file in one line (status 2) before any window, and opens a
  valid one.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import zipfile
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt

from app.qt_compat import pin_singletons
from tests.app.studio.studio_input import RED, click_row, pick_material, type_into
from tests.app.studio_support import DialogDriver, driver_fixture, reset_studio, studio_fixture

if TYPE_CHECKING:
    from pathlib import Path

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]

studio = studio_fixture(wait_full_quality=False, check_gl_release=False)


@pytest.fixture
def window(studio: tuple[Any, DialogDriver], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Any:
    """The module's window on the red-lip look, untitled and unmodified; the user's library file in tmp_path."""
    monkeypatch.setattr("app.studio.library_dock.user_library_path", lambda: tmp_path / "user" / "library.json")
    reset_studio(studio[0], "red-lip")
    return studio[0]


driver = driver_fixture()


def quit_answering(window: Any, driver: DialogDriver, answer: str) -> str:
    """File → Quit (Ctrl+Q's action), answering its question with ``answer``; returns the question's title."""
    asked = len(driver.questions())
    driver.answer(answer)
    window.actions_by_id["file.quit"].trigger()
    assert len(driver.questions()) == asked + 1, "quitting did not ask"
    return driver.questions()[-1].title


def render_projects(tmp_path: Path, *projects: Path) -> list[np.ndarray]:
    """``sheer render --project P`` of each project, in a child process (its own EGL context)."""
    from PIL import Image

    outs = [tmp_path / f"{p.stem}.png" for p in projects]
    calls = " or ".join(f"main(['render', '--project', {str(p)!r}, '--size', '320x240', '--out', {str(o)!r}])"
                        for p, o in zip(projects, outs))
    proc = subprocess.run([sys.executable, "-c", f"import sys\nfrom app.cli import main\nsys.exit({calls})"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return [np.asarray(Image.open(o), dtype=np.int16) for o in outs]


def test_a_library_edit_is_drawn_saved_rendered_and_offered_on_quit(window: Any, qtbot: Any, driver: DialogDriver,
                                                                     tmp_path: Path) -> None:
    doc, vp, dock = window.doc, window.viewport, window.library_dock
    index = next(i for i, lay in enumerate(doc.layers) if lay.material == RED)
    lip = doc.layers[index]
    assert window.files.save_project(path=tmp_path / "before.sheer")
    k_before, rough_before = np.asarray(lip.material_object.K, float), lip.material_object.roughness

    pick_material(qtbot, dock, RED)
    type_into(qtbot, dock.spins["roughness"], "0.05")
    type_into(qtbot, dock.scales["K"], "0.2")
    edited = window.library.get(RED)
    assert edited.roughness == pytest.approx(0.05) and np.allclose(edited.K, k_before * 0.2)
    assert lip.material_object is edited, "the layer does not wear the library's edit"
    assert window.isWindowModified() and window.windowTitle().startswith("before[*]")
    qtbot.waitUntil(lambda: not vp.pending_changes, timeout=10000)
    vp.update()
    qtbot.waitUntil(lambda: vp.renderer.r.km.layers[index].material is edited, timeout=10000)

    assert quit_answering(window, driver, "Cancel") == "Unsaved changes"
    assert window.isVisible()
    assert window.files.save_project(path=tmp_path / "after.sheer")
    with zipfile.ZipFile(tmp_path / "after.sheer") as zf:
        saved = json.loads(zf.read("project.json"))["materials"][RED]
    assert saved["roughness"] == pytest.approx(0.05) and np.allclose(saved["K"], k_before * 0.2)
    before, after = render_projects(tmp_path, tmp_path / "before.sheer", tmp_path / "after.sheer")
    assert (np.abs(after - before).max(axis=-1) > 8).sum() > 20, "sheer render --project shows the old red"

    # the project is saved; the library's own file is not: quitting asks about it
    title = quit_answering(window, driver, "Cancel")
    assert title == "Unsaved library changes" and RED in driver.questions()[-1].text
    assert window.isVisible()
    window.undo()
    window.undo()  # both edits undone: the library is as its file has it, the layer wears it again
    assert not dock.modified and lip.material_object is window.library.get(RED)
    assert lip.material_object.roughness == rough_before and np.allclose(lip.material_object.K, k_before)


def test_the_layer_panel_shows_the_selected_layer_and_writes_only_what_the_user_changed(
        window: Any, qtbot: Any) -> None:
    doc, panel = window.doc, window.layers_panel
    foundation = next(i for i, lay in enumerate(doc.layers) if lay.material.startswith("Foundation"))
    lipstick = next(i for i, lay in enumerate(doc.layers) if lay.material == RED)
    doc.set_layer(foundation, max_thickness=80.0, opacity=0.9)
    doc.set_layer(lipstick, max_thickness=60.0)
    steps = len(doc.history)

    click_row(qtbot, panel.list, panel.list.count() - 1 - lipstick)
    assert panel.max_thickness.value() == pytest.approx(60.0) and panel.layer_material.currentText() == RED
    click_row(qtbot, panel.list, panel.list.count() - 1 - foundation)
    assert window.selected_layer == foundation
    assert panel.max_thickness.value() == pytest.approx(80.0)
    assert panel.layer_material.currentText() == doc.layers[foundation].material
    assert panel.opacity.value() == 90

    # Enter on (or tabbing through) the fields the user did not change writes nothing
    qtbot.keyClick(panel.max_thickness, Qt.Key.Key_Return)
    panel.max_thickness.editingFinished.emit()  # what leaving the field with Tab sends
    assert len(doc.history) == steps and doc.layers[foundation].max_thickness == 80.0

    type_into(qtbot, panel.max_thickness, "70")  # a value the user typed is written, once
    assert doc.layers[foundation].max_thickness == 70.0 and len(doc.history) == steps + 1
    assert doc.layers[lipstick].max_thickness == 60.0


def test_moving_the_key_light_marks_the_document_and_quitting_asks(window: Any, qtbot: Any, driver: DialogDriver,
                                                                  tmp_path: Path) -> None:
    from project.io import open_project

    vp = window.viewport
    assert not window.isWindowModified()
    az = vp.lighting.azimuth
    start = QPoint(vp.width() // 3, vp.height() // 2)
    ctrl = Qt.KeyboardModifier.ControlModifier
    qtbot.mousePress(vp, Qt.MouseButton.LeftButton, ctrl, start)
    for dx in range(10, 70, 10):
        qtbot.mouseMove(vp, QPoint(start.x() + dx, start.y()))
    qtbot.mouseRelease(vp, Qt.MouseButton.LeftButton, ctrl, QPoint(start.x() + 60, start.y()))
    assert vp.lighting.azimuth != pytest.approx(az), "the Ctrl+drag did not move the light"
    assert window.isWindowModified() and window.files.autosaver.dirty
    assert quit_answering(window, driver, "Cancel") == "Unsaved changes"
    assert window.isVisible()
    assert window.files.save_project(path=tmp_path / "lit.sheer")
    from app.project_io import key_light_angles

    saved = key_light_angles(open_project(tmp_path / "lit.sheer").lights)
    assert saved is not None and saved[0] == pytest.approx(vp.lighting.azimuth, abs=1e-6)
    # the light's preset and the environment are saved with it: choosing another is unsaved work too
    for combo in (window.light_combo, window.env_combo):
        assert window.files.save_project()
        combo.setCurrentIndex((combo.currentIndex() + 1) % combo.count())
        assert window.isWindowModified(), f"choosing {combo.currentText()!r} did not mark the document"


def test_studio_refuses_a_corrupt_project_in_one_line_before_any_window(tmp_path: Path,
                                                                         capsys: pytest.CaptureFixture[str],
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    from app.cli import main

    def no_window(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("the studio started before refusing the project")

    monkeypatch.setattr("app.studio.launch.open_session_with_progress", no_window)
    bad = tmp_path / "broken.sheer"
    bad.write_bytes(b"PK\x03\x04 this is not a project")
    assert main(["studio", "--project", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "broken.sheer" in err and "Traceback" not in err
    assert main(["studio", "--project", str(tmp_path / "missing.sheer")]) == 2
    assert "missing.sheer" in capsys.readouterr().err


OPEN_WITH_PROJECT = textwrap.dedent("""
    import sys
    import app.studio.launch as launch
    made = launch.make_application
    def make():  # the real start-up, with a watcher that reports the window once the project is open
        app = made()
        from PySide6.QtCore import QTimer
        from PySide6.QtWidgets import QApplication
        from app.studio.main_window import StudioWindow
        def check():
            for w in QApplication.topLevelWidgets():
                if isinstance(w, StudioWindow) and w.isVisible() and w.files.path is not None:
                    print("opened", w.files.path.name, w.doc.resolution, [lay.material for lay in w.doc.layers],
                          w.isWindowModified(), flush=True)
                    w.close()
                    app.quit()
        timer = QTimer(app)
        timer.timeout.connect(check)
        timer.start(100)
        return app
    launch.make_application = make
    from app.cli import main
    sys.exit(main(["studio", "--project", sys.argv[1]]))
""")


def test_studio_opens_a_project_given_on_the_command_line(window: Any, tmp_path: Path) -> None:
    """``sheer studio --project FILE``: the real start-up, at the project's resolution, with its layers."""
    from core.cache import cache_root

    path = tmp_path / "red.sheer"
    assert window.files.save_project(path=path)
    window.files.hold.release()  # as closing it would: another studio opening a held project asks first
    home = tmp_path / "home"
    env = dict(os.environ, HOME=str(home), XDG_CONFIG_HOME=str(home / "config"), XDG_DATA_HOME=str(home / "data"),
               SHEER_RECOVERY_DIR=str(tmp_path / "recovery"), SHEER_CACHE_DIR=str(cache_root()))
    proc = subprocess.run([sys.executable, "-c", OPEN_WITH_PROJECT, str(path)], capture_output=True, text=True,
                          timeout=300, env=env)
    assert proc.returncode == 0, proc.stderr[-2000:]
    materials = [lay.material for lay in window.doc.layers]
    assert f"opened red.sheer {window.doc.resolution} {materials} False" in proc.stdout, proc.stdout + proc.stderr
