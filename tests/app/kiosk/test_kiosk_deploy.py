"""Deploying the kiosk as an installer does: it fills the screen of an X server with a window manager
(openbox) as well as without one (``test_kiosk_command``: Xvfb alone, how ``xinit`` starts kiosks), and
``make run`` on a machine without a display says in one line what to do instead of Qt's abort."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest

from app.qt_compat import pin_singletons

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]

REPO = Path(__file__).resolve().parents[3]


def _wm_running() -> bool:
    """The root window names a window manager (EWMH ``_NET_SUPPORTING_WM_CHECK``)."""
    out = subprocess.run(["xprop", "-root", "_NET_SUPPORTING_WM_CHECK"], capture_output=True, text=True, timeout=10)
    return "window id" in out.stdout


def test_the_kiosk_fills_the_screen_under_a_window_manager(qapp: Any, qtbot: Any, tmp_path: Path) -> None:
    from app.kiosk.config import KioskConfig
    from app.kiosk.window import KioskWindow
    from tests.app.kiosk.kiosk_support import pin_hash

    assert shutil.which("openbox") and shutil.which("xprop"), "openbox and xprop (Debian packages) run this test"
    assert not _wm_running(), "another window manager is already running on this display"
    wm = subprocess.Popen(["openbox", "--sm-disable"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 20
        while not _wm_running() and time.time() < deadline:
            time.sleep(0.1)
        assert _wm_running(), "openbox did not start"
        cfg = KioskConfig(pin_hash=pin_hash("2468"), snapshot_dir=str(tmp_path / "photos"), resolution=512)
        kiosk = KioskWindow(cfg)
        try:
            kiosk.show_full_screen()
            qtbot.waitUntil(lambda: kiosk.windowHandle() is not None and kiosk.windowHandle().isExposed(),
                            timeout=30000)
            screen = kiosk.screen().geometry()
            want = (screen.x(), screen.y(), screen.width(), screen.height())
            qtbot.waitUntil(lambda: kiosk.geometry().getRect() == want, timeout=10000)
            info = subprocess.run(["xwininfo", "-id", str(int(kiosk.winId()))], capture_output=True, text=True,
                                  timeout=10).stdout
            assert kiosk.isFullScreen()
            assert f"Width: {want[2]}" in info and f"Height: {want[3]}" in info
            assert f"Absolute upper-left X:  {want[0]}" in info and f"Absolute upper-left Y:  {want[1]}" in info
        finally:
            kiosk._allow_close = True
            kiosk.close()
            kiosk.deleteLater()
    finally:
        wm.terminate()
        try:
            wm.wait(10)
        except subprocess.TimeoutExpired:
            wm.kill()
            wm.wait(10)


def test_make_run_without_a_display_says_what_to_do(tmp_path: Path) -> None:
    # without the display, and without the variables of a `make test` this suite may run under (MAKELEVEL
    # would make the inner make print "make[1]: …" lines)
    env = {k: v for k, v in os.environ.items()
           if k not in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM", "MAKELEVEL", "MAKEFLAGS", "MFLAGS")}
    for args in ([], ["ARGS=kiosk"]):
        # -o: the installed venv counts as up to date (the test is not about installing)
        done = subprocess.run(["make", "-s", "-o", ".venv/.sheer-installed", "run", *args], cwd=REPO, env=env,
                              capture_output=True, text=True, timeout=60)
        assert done.returncode != 0
        lines = [ln for ln in done.stderr.splitlines() if not re.match(r"make(\[\d+\])?: ", ln)]
        assert len(lines) == 1, done.stderr
        assert "DISPLAY" in lines[0] and "xvfb-run" in lines[0] and "sheer render" in lines[0]
        assert "Qt" not in done.stderr and "Aborted" not in done.stderr
    # a headless command runs without a display
    done = subprocess.run(["make", "-s", "-o", ".venv/.sheer-installed", "run", "ARGS=render --help"], cwd=REPO,
                          env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and "usage: sheer render" in done.stdout
