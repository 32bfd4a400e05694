"""Help → About in the real studio window (Xvfb): the GL line of the viewport's own context, and "Copy
diagnostics" putting the doctor's report on the clipboard: the quick level built in a worker's headless
context while the GUI stays responsive, the GL lines from the studio's live context."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import pytest

from tests.app.studio_support import studio_fixture

if TYPE_CHECKING:
    from tests.app.studio_support import DialogDriver

pytestmark = [pytest.mark.qt, pytest.mark.gl]

studio = studio_fixture()


def _about_box() -> Any:
    from PySide6.QtWidgets import QApplication, QDialog

    return next((w for w in QApplication.topLevelWidgets()
                 if type(w) is QDialog and w.isVisible() and w.windowTitle() == "About Sheer"), None)


def test_about_shows_gl_and_copies_diagnostics(studio: tuple[Any, DialogDriver], qtbot: Any) -> None:
    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication, QDialogButtonBox, QLabel, QPushButton

    win, driver = studio
    info = win.viewport.ctx.info
    seen: dict[str, Any] = {}

    def press_copy_then_ok() -> None:
        box = _about_box()
        if box is None:
            QTimer.singleShot(20, press_copy_then_ok)
            return
        seen["about"] = box.findChild(QLabel, "about_text").text()
        QApplication.clipboard().setText("")
        copy = box.findChild(QPushButton, "copy_diagnostics")
        t0 = time.perf_counter()
        copy.click()
        seen["click_s"] = time.perf_counter() - t0  # the GUI's wait: the report is made in a worker
        seen["while"] = copy.text()

        def when_copied() -> None:
            if copy.text() != "Copied" and time.perf_counter() - t0 < 120:
                QTimer.singleShot(20, when_copied)
                return
            seen["ready_s"] = time.perf_counter() - t0
            seen["clipboard"] = QApplication.clipboard().text()
            seen["button"] = copy.text()
            box.findChild(QDialogButtonBox).button(QDialogButtonBox.StandardButton.Ok).click()

        when_copied()

    driver.stop()  # this test answers the About box itself: the driver would press OK at once
    try:
        QTimer.singleShot(0, press_copy_then_ok)
        win.actions_by_id["help.about"].trigger()  # returns when the modal box is closed
    finally:
        driver.timer.start()
    assert _about_box() is None

    gl = f"{info['GL_VENDOR']} / {info['GL_RENDERER']} / {info['GL_VERSION']}, EGL"
    assert f"<b>OpenGL:</b> {gl}" in seen["about"]
    text = seen["clipboard"]
    lines = text.splitlines()
    assert lines[0] == f"ok    GL: {gl}", text
    for name in ("max texture", "shaders", "assets", "cache", "dependencies", "Python", "OS"):
        assert any(line.startswith("ok") and line[6:].startswith(f"{name}: ") for line in lines), (name, text)
    shaders = next(line for line in lines if line[6:].startswith("shaders: "))
    assert "programs built (quick:" in shaders
    assert lines[-1] == "sheer doctor (quick): all is well"
    assert "built in a headless EGL context" in shaders
    assert seen["while"] == "Collecting…" and seen["button"] == "Copied"
    assert seen["click_s"] < 0.5, "the GUI waited for the diagnostics"
    print(f"Copy diagnostics: the click returned in {seen['click_s'] * 1000:.0f} ms, the clipboard was "
          f"filled after {seen['ready_s']:.2f} s; {shaders}")
    win.viewport.makeCurrent()
    try:
        assert win.viewport.ctx.error == "GL_NO_ERROR"
    finally:
        win.viewport.doneCurrent()
