"""``sheer kiosk`` through the real command path (``app.cli.main``) with a configuration folder that holds an
administrator PIN: the kiosk comes up covering the screen, refuses Alt+F4 with its PIN pad, starts the attract
mode after the configured idle time, and exits with the PIN. Input is real X input (xdotool) on the Xvfb
server, with no window manager — how kiosks are started from ``xinit``."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from typing import TYPE_CHECKING, Any

import pytest

from app.qt_compat import pin_singletons

if TYPE_CHECKING:
    from pathlib import Path

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]

PIN = "2468"
IDLE_S = 5.0  # the shortest idle time the configuration accepts


def xdotool(*args: str) -> None:
    subprocess.run(["xdotool", *args], check=True, timeout=20)


def touch(widget: Any, qtbot: Any) -> None:
    """A real click (X pointer) in the middle of ``widget``."""
    centre = widget.mapToGlobal(widget.rect().center())
    xdotool("mousemove", "--sync", str(centre.x()), str(centre.y()), "click", "1")
    qtbot.wait(150)


def drive(kiosk: Any, qtbot: Any, seen: dict[str, Any]) -> None:
    """What a shopper and the administrator do, recorded in ``seen`` (asserted after the event loop)."""
    qtbot.waitUntil(lambda: kiosk.windowHandle() is not None and kiosk.windowHandle().isExposed(), timeout=60000)
    screen = kiosk.screen().geometry()
    seen["screen"] = (screen.x(), screen.y(), screen.width(), screen.height())
    seen["qt_geometry"] = kiosk.geometry().getRect()
    seen["full_screen"] = kiosk.isFullScreen()
    info = subprocess.run(["xdotool", "getwindowgeometry", str(int(kiosk.winId()))], capture_output=True,
                          text=True, timeout=20).stdout
    seen["x_geometry"] = info  # the X server's view of the window ("Position: 0,0 … Geometry: 1920x1080")

    # on launch: the attract mode (the face turning, looks cycling) under the invitation
    yaw0, look0 = kiosk.viewport.camera.yaw, kiosk.look
    qtbot.waitUntil(lambda: kiosk.viewport.camera.yaw != yaw0 and kiosk.look != look0, timeout=15000)
    seen["launch"] = (kiosk.screen_name, kiosk.attract, kiosk.invite.isVisible(), kiosk.start_button.isVisible())

    kiosk.activateWindow()
    qtbot.waitUntil(kiosk.isActiveWindow, timeout=5000)
    xdotool("key", "--clearmodifiers", "alt+F4")
    qtbot.waitUntil(lambda: kiosk.stack.currentWidget() is kiosk.pin_pad, timeout=5000)
    seen["alt_f4_pin_pad"] = kiosk.stack.currentWidget() is kiosk.pin_pad
    seen["alt_f4_visible"] = kiosk.isVisible()
    touch(kiosk.pin_pad.cancel_button, qtbot)
    seen["cancel_back_to_start"] = kiosk.screen_name == "start"

    touch(kiosk.start_button, qtbot)
    seen["started"] = kiosk.screen_name == "tryon"
    yaw, look = kiosk.viewport.camera.yaw, kiosk.look
    qtbot.wait(int(IDLE_S * 1000 * 0.6))
    seen["attract_too_early"] = kiosk.attract
    qtbot.waitUntil(lambda: kiosk.attract, timeout=int(IDLE_S * 1000 * 2))
    seen["idle_start_screen"] = kiosk.screen_name
    qtbot.waitUntil(lambda: kiosk.viewport.camera.yaw != yaw and kiosk.look != look, timeout=15000)
    seen["attract_turns_and_changes_looks"] = (kiosk.viewport.camera.yaw != yaw, look, kiosk.look)
    touch(kiosk.viewport, qtbot)
    seen["touch_ends_attract"] = (kiosk.attract, kiosk.screen_name)

    xdotool("key", "Escape")
    qtbot.waitUntil(lambda: kiosk.stack.currentWidget() is kiosk.pin_pad, timeout=5000)
    for key in [*PIN, "OK"]:
        touch(kiosk.pin_pad.buttons[key], qtbot)


def test_sheer_kiosk_with_a_pin_comes_up_full_screen_and_guards_its_way_out(
        qapp: Any, qtbot: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication

    from app.cli import main
    from app.kiosk.window import KioskWindow
    from tests.app.kiosk.kiosk_support import pin_hash

    assert shutil.which("xdotool"), "xdotool (Debian package) drives the X server in this test"
    config = tmp_path / "config" / "sheer" / "kiosk.json"
    config.parent.mkdir(parents=True)
    # 512² maps: the resolution is not what this test is about
    config.write_text(json.dumps({"pin_hash": pin_hash(PIN), "snapshot_dir": str(tmp_path / "photos"),
                                  "idle_seconds": IDLE_S, "look_seconds": 2.0, "resolution": 512}),
                      encoding="utf-8")
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    monkeypatch.setenv("SHEER_KIOSK_LOG", str(tmp_path / "kiosk.log"))
    monkeypatch.setattr(sys, "excepthook", sys.excepthook)  # the kiosk installs its own
    seen: dict[str, Any] = {}
    failures: list[BaseException] = []
    kiosks: list[Any] = []

    def run() -> None:
        kiosk = next(w for w in QApplication.topLevelWidgets() if isinstance(w, KioskWindow) and w.isVisible())
        kiosks.append(kiosk)
        try:
            drive(kiosk, qtbot, seen)
        except BaseException as exc:  # reported after the event loop; the kiosk must still close
            failures.append(exc)
            kiosk._allow_close = True
            kiosk.close()

    QTimer.singleShot(0, run)
    watchdog = QTimer()
    watchdog.setSingleShot(True)
    watchdog.timeout.connect(lambda: (failures.append(TimeoutError("the kiosk did not exit")), QApplication.quit()))
    watchdog.start(240_000)
    status = main(["kiosk"])
    watchdog.stop()
    if failures:
        raise failures[0]
    assert status == 0
    kiosk = kiosks[0]
    assert not kiosk.isVisible(), "the right PIN must close the kiosk"
    assert kiosk.viewport.gl_error_at_release in (None, "GL_NO_ERROR")
    # full screen: the window covers the screen's geometry, as Qt and as the X server see it
    x, y, w, h = seen["screen"]
    assert seen["full_screen"] and seen["qt_geometry"] == (x, y, w, h)
    assert f"Position: {x},{y}" in seen["x_geometry"] and f"Geometry: {w}x{h}" in seen["x_geometry"]
    # Alt+F4 is refused: the PIN pad instead of closing
    assert seen["alt_f4_pin_pad"] and seen["alt_f4_visible"] and seen["cancel_back_to_start"]
    # idle → attract after the configured idle time, not before; it turns the head and changes looks
    assert seen["started"] and not seen["attract_too_early"] and seen["idle_start_screen"] == "start"
    turned, first, then = seen["attract_turns_and_changes_looks"]
    assert turned and first != then
    assert seen["touch_ends_attract"] == (False, "tryon")  # the touch that wakes it starts the try-on
    assert seen["launch"] == ("start", True, True, True)
    kiosk.deleteLater()
