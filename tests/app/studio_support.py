"""Shared set-up of the Qt tests: a studio window (a real window under Xvfb with Mesa GL) and a driver that
answers the real dialogs as a user would."""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from collections.abc import Iterator

    import pytest


@dataclass
class Shown:
    """A dialog the driver answered: its kind ("error", "warning", "info", "question" or "dialog"), title,
    text, button labels and the label it clicked."""

    kind: str
    title: str
    text: str
    buttons: list[str]
    clicked: str


class DialogDriver:
    """Answers the application's modal dialogs: every 20 ms a QTimer looks for a visible ``QMessageBox``
    (or a plain ``QDialog`` such as About) and clicks one of its buttons — for a question the next
    prepared answer (a button label, see :meth:`answer`) or, with none prepared, the button Esc would
    press; for a message its OK button. Each dialog answered is recorded in :attr:`shown`."""

    def __init__(self) -> None:
        from PySide6.QtCore import QTimer

        self.answers: list[str] = []
        self.shown: list[Shown] = []
        self.timer = QTimer()
        self.timer.setInterval(20)
        self.timer.timeout.connect(self._poll)
        self.timer.start()

    def answer(self, *labels: str) -> DialogDriver:
        """Prepare the answers (button labels) of the next questions, in order."""
        self.answers.extend(labels)
        return self

    def questions(self) -> list[Shown]:
        """The questions answered so far."""
        return [s for s in self.shown if s.kind == "question"]

    def stop(self) -> None:
        self.timer.stop()

    def _poll(self) -> None:
        from PySide6.QtWidgets import QApplication, QDialog, QDialogButtonBox, QMessageBox

        for w in QApplication.topLevelWidgets():
            try:
                if not w.isVisible():
                    continue
            except RuntimeError:  # a menu or popup whose C++ object Qt deleted since the list was made
                continue
            if isinstance(w, QMessageBox):
                self._answer_box(w)
            elif type(w) is QDialog and w.findChild(QDialogButtonBox) is not None:
                ok = w.findChild(QDialogButtonBox).button(QDialogButtonBox.StandardButton.Ok)
                self.shown.append(Shown("dialog", w.windowTitle(), "", ["OK"], "OK"))
                ok.click()

    def _answer_box(self, box: Any) -> None:
        from PySide6.QtWidgets import QMessageBox

        kinds = {QMessageBox.Icon.Critical: "error", QMessageBox.Icon.Warning: "warning",
                 QMessageBox.Icon.Question: "question"}
        kind = kinds.get(box.icon(), "info")
        buttons = {b.text().replace("&", ""): b for b in box.buttons()}
        if kind == "question":
            label = self.answers.pop(0) if self.answers else box.escapeButton().text().replace("&", "")
        else:
            label = "OK"
        self.shown.append(Shown(kind, box.windowTitle(), box.text(), list(buttons), label))
        buttons[label].click()


@contextlib.contextmanager
def open_studio_window(qapp: object, tmp_path_factory: pytest.TempPathFactory, *,
                       wait_full_quality: bool = True,
                       check_gl_release: bool = True) -> Iterator[tuple[Any, DialogDriver]]:
    """An 800×600 studio window with its own settings file and recovery folder, shown and drawn once, and
    the driver that answers its dialogs.

    On exit unsaved work and library edits are discarded (the real questions, answered "Discard"), the
    environment restored and, with ``check_gl_release``, the viewport must have released its GL objects
    without a GL error.
    """
    from PySide6.QtCore import QSettings
    from pytestqt.qtbot import QtBot

    from app.session import Session
    from app.studio.main_window import StudioWindow

    old_recovery = os.environ.get("SHEER_RECOVERY_DIR")
    os.environ["SHEER_RECOVERY_DIR"] = str(tmp_path_factory.mktemp("recovery"))
    ini = tmp_path_factory.mktemp("settings") / "studio.ini"
    driver = DialogDriver()
    # 512² maps: the behaviour under test does not depend on the resolution, and the default (2048²)
    # triples the module's run time; `sheer bench studio` measures the default
    win = StudioWindow(Session.open(resolution=512, look="natural"),
                       qsettings=QSettings(str(ini), QSettings.Format.IniFormat))
    win.resize(800, 600)
    win.show()
    if wait_full_quality:
        QtBot(qapp).waitUntil(lambda: win.viewport.frames > 0 and win.viewport.full_quality_ready, timeout=60000)
    else:
        QtBot(qapp).waitUntil(lambda: win.viewport.frames > 0, timeout=60000)
    try:
        yield win, driver
    finally:
        driver.answers[:] = ["Discard", "Discard"]  # unsaved work, then unsaved library edits (if asked)
        win.close()
        driver.stop()
        if old_recovery is None:
            os.environ.pop("SHEER_RECOVERY_DIR", None)
        else:
            os.environ["SHEER_RECOVERY_DIR"] = old_recovery
    assert not win.isVisible(), "the studio window did not close"
    if check_gl_release:
        assert win.viewport.gl_error_at_release == "GL_NO_ERROR"
    win.deleteLater()


def studio_fixture(**options: bool) -> Any:
    """A module-scoped pytest fixture named ``studio``: one window per test module, as the pair
    (window, driver) that :func:`open_studio_window` opens with ``options``.

    A test module takes it as ``studio = studio_fixture()``.
    """
    import pytest

    @pytest.fixture(scope="module")
    def studio(qapp: object, tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Any, DialogDriver]]:
        with open_studio_window(qapp, tmp_path_factory, **options) as pair:
            yield pair

    return studio


def window_fixture(look: str = "natural") -> Any:
    """A pytest fixture named ``window``: the module's studio window (the ``studio`` fixture's first item)
    brought back by :func:`reset_studio` on ``look`` before each test, whatever the tests before left in it.

    A test module takes it as ``window = window_fixture()``.
    """
    import pytest

    @pytest.fixture
    def window(studio: tuple[Any, DialogDriver]) -> Any:
        reset_studio(studio[0], look)
        return studio[0]

    return window


def driver_fixture() -> Any:
    """A pytest fixture named ``driver``: the module window's dialog driver with nothing answered yet; every
    answer a test prepares must be asked for by the end of the test.

    A test module takes it as ``driver = driver_fixture()``.
    """
    import pytest

    @pytest.fixture
    def driver(studio: tuple[Any, DialogDriver]) -> Iterator[DialogDriver]:
        d = studio[1]
        d.shown.clear()
        d.answers.clear()
        yield d
        assert not d.answers, f"prepared answers never asked for: {d.answers}"

    return driver


def reset_studio(win: Any, look: str = "natural") -> None:
    """Bring a module's shared studio window back to the state it opened in, for a test that must not see
    what the tests before it left: File → New on the built-in ``look`` (untitled, unmodified, no undo
    step), no captured face (the lightweight mode then asks for one), the fast mode and the head framed
    (the F key)."""
    # no menu item closes a captured face: the window is put back as it was before one was opened
    win.viewport.face = None
    win.face_path = None
    win.files.new_project(look)
    win.set_render_mode("fast")
    win.viewport.frame_head()


def write_test_face(folder: Any) -> Any:
    """A small captured-face folder (``face.json`` + ``detail.exr``, as ``sheer capture`` writes) for the
    sample head: fitted Phong parameters and a detail texture with a visible pattern."""
    import json
    from pathlib import Path

    import numpy as np
    import OpenEXR

    from capture.face import FACE_SCHEMA_VERSION
    from capture.phong import PhongParams

    d = Path(folder)
    d.mkdir(parents=True, exist_ok=True)
    p = PhongParams(diffuse=np.array([0.55, 0.38, 0.3]), specular=0.08, exponent=24.0, ambient_scale=1.0,
                    flash_rgb=np.ones(3), ambient_rgb=np.full(3, 0.05))
    (d / "face.json").write_text(json.dumps({"schema_version": FACE_SCHEMA_VERSION, "phong": p.to_json()}))
    yy, xx = np.mgrid[0:128, 0:128]
    detail = np.repeat((0.8 + 0.4 * (((xx // 16) + (yy // 16)) % 2))[..., None], 3, axis=2).astype(np.float32)
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(hdr, {"RGB": detail}).write(str(d / "detail.exr"))
    return d
