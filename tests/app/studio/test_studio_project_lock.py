"""One Sheer at a time writes a project: the studio holds the lock of the project it has open, asks "Open a
copy / Take over / Cancel" (a real message box) when another Sheer holds it, lets go when it closes, starts
a new project or is taken over, and a lock whose holder was killed blocks nothing."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from typing import TYPE_CHECKING, Any

import pytest

from app.qt_compat import pin_singletons
from core.locks import Holder, holder_of, takeover_request
from tests.app.studio_support import driver_fixture, studio_fixture, window_fixture
from tests.cli_support import checkout_env

if TYPE_CHECKING:
    from pathlib import Path

    from tests.app.studio_support import DialogDriver

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]

studio = studio_fixture(wait_full_quality=False, check_gl_release=False)
window = window_fixture()
driver = driver_fixture()

CHOICES = ["Open a copy", "Take over", "Cancel"]

#: Another Sheer that has ``argv[1]`` open; with ``argv[2] == "yields"`` it lets go when asked to.
OTHER = (
    "import sys, time\n"
    "from core.locks import FileLock, takeover_request\n"
    "lock = FileLock(sys.argv[1], 'open')\n"
    "assert lock.try_acquire() is None\n"
    "print('held', flush=True)\n"
    "while sys.argv[2] != 'yields' or takeover_request(sys.argv[1]) is None:\n"
    "    time.sleep(0.02)\n"
    "lock.release()\n"
    "time.sleep(120)\n"
)


def _other(path: Path, yields: bool = False) -> subprocess.Popen[str]:
    env = checkout_env()
    proc = subprocess.Popen([sys.executable, "-c", OTHER, str(path), "yields" if yields else "holds"], env=env,
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "held"
    return proc


def _saved(window: Any, path: Path) -> Path:
    """The window's document saved to ``path``, then File → New (the project is let go of)."""
    assert window.files.save_project(path=path)
    assert holder_of(path) == Holder(socket.gethostname(), os.getpid(), "open")  # held while open
    window.files.new_project("natural")
    assert holder_of(path) is None  # File → New lets go
    return path


def test_a_project_another_sheer_holds_asks_and_cancel_opens_nothing(window: Any, driver: DialogDriver,
                                                                     tmp_path: Path) -> None:
    path = _saved(window, tmp_path / "held.sheer")
    other = _other(path)
    try:
        driver.answer("Cancel")
        assert not window.files.open_project(path)
        (asked,) = driver.questions()
        assert asked.title == "Project in use" and asked.buttons == CHOICES
        assert asked.text == f"held.sheer is open in another Sheer ({socket.gethostname()}, pid {other.pid})."
        assert window.files.path is None and holder_of(path).pid == other.pid

        driver.answer("Open a copy")
        assert window.files.open_project(path)
        assert window.files.path is None and window.files.name == "held (copy)"
        assert holder_of(path).pid == other.pid  # still theirs
    finally:
        other.send_signal(signal.SIGKILL)
        other.wait()
    driver.shown.clear()
    assert window.files.open_project(path)  # the killed Sheer's lock died with it: no question
    assert driver.questions() == [] and window.files.path == path
    assert holder_of(path).pid == os.getpid()


def test_take_over_gets_the_project_from_the_other_sheer(window: Any, driver: DialogDriver,
                                                         tmp_path: Path) -> None:
    path = _saved(window, tmp_path / "theirs.sheer")
    other = _other(path, yields=True)
    try:
        driver.answer("Take over")
        assert window.files.open_project(path)
        assert [q.clicked for q in driver.questions()] == ["Take over"]
        assert window.files.path == path and holder_of(path).pid == os.getpid()
        assert takeover_request(path) is None
    finally:
        other.kill()
        other.wait()


def test_another_sheer_taking_over_leaves_the_work_here_as_an_untitled_copy(window: Any, driver: DialogDriver,
                                                                            qtbot: Any, tmp_path: Path) -> None:
    path = _saved(window, tmp_path / "mine.sheer")
    assert window.files.open_project(path) and window.files.path == path
    script = ("import sys\nfrom core.locks import take_over\nlock = take_over(sys.argv[1], timeout_s=30)\n"
              "print('took', flush=True)\nsys.stdin.read()\n")
    env = checkout_env()
    other = subprocess.Popen([sys.executable, "-c", script, str(path)], env=env, stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True)
    try:
        qtbot.waitUntil(lambda: window.files.path is None, timeout=20000)
        assert other.stdout is not None and other.stdout.readline().strip() == "took"
        assert window.files.name == "mine (copy)" and window.isWindowModified()
        assert "taken over by another Sheer" in window.statusBar().currentMessage()
        assert holder_of(path).pid == other.pid
    finally:
        other.kill()
        other.wait()


def test_closing_the_window_lets_go_and_an_old_killed_saves_temporary_is_swept_at_open(
        window: Any, driver: DialogDriver, tmp_path: Path) -> None:
    from project.io import STALE_TEMP_S

    path = _saved(window, tmp_path / "p.sheer")
    stale = tmp_path / ".p.sheer.k1ll3d.tmp"
    fresh = tmp_path / ".p.sheer.s4v1ng.tmp"
    for f in (stale, fresh):
        f.write_bytes(b"half a project")
    old = time.time() - STALE_TEMP_S - 60
    os.utime(stale, (old, old))
    assert window.files.open_project(path)
    assert not stale.exists() and fresh.exists()
    window.files.close()  # what the window's close does
    assert holder_of(path) is None
    window.files.timer.start()  # the module's window goes on for the tests after
    window.files.hold.timer.start()
