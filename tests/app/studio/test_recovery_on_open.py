"""Opening a project whose autosave a Sheer that did not close normally left beside it offers that work:
the start-up question ("Recover unsaved work": Recover / Discard / Later), asked on File → Open and for
``sheer studio --project`` (both open in the background), answered by clicking the real message box."""

from __future__ import annotations

import os
import subprocess
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from app.qt_compat import pin_singletons
from tests.app.studio_support import driver_fixture, studio_fixture, window_fixture

if TYPE_CHECKING:
    from pathlib import Path

    from tests.app.studio_support import DialogDriver

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]

studio = studio_fixture(wait_full_quality=False, check_gl_release=False)
window = window_fixture()
driver = driver_fixture()


def _paint(window: Any, seed: int) -> np.ndarray:
    """Random (not quantisable) thickness on the first layer; returns a copy of every layer's map."""
    rng = np.random.default_rng(seed)
    lay = window.doc.layers[0]
    res = lay.thickness.shape[0]
    window.doc.set_thickness(lay, (rng.random((res, res)) * 0.5 * lay.max_thickness).astype(np.float32))
    return np.stack([np.array(layer.thickness, copy=True) for layer in window.doc.layers])


def _maps(window: Any) -> np.ndarray:
    return np.stack([np.asarray(layer.thickness) for layer in window.doc.layers])


def _dead_pid() -> int:
    """The id of a process that has ended."""
    done = subprocess.Popen(["true"])
    done.wait()
    return done.pid


def _crashed_session(window: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, Path,
                                                                                            np.ndarray, np.ndarray]:
    """A project saved, then painted on and autosaved by a process that has ended (its recovery file
    beside the project, newer than it); the window then shows a new, untitled document.

    Returns:
        The project, the recovery file, the saved maps and the autosaved (unsaved) maps.
    """
    from project.recovery import autosave

    project = tmp_path / "look.sheer"
    saved = _paint(window, 1)
    assert window.files.save_project(path=project)
    unsaved = _paint(window, 2)
    snapshot = window.files.snapshot()
    window.files.new_project("natural")
    dead = _dead_pid()
    with monkeypatch.context() as m:  # the autosave of a studio that was killed
        m.setattr(os, "getpid", lambda: dead)
        recovery = autosave(snapshot, project)
    later = project.stat().st_mtime + 2.0
    os.utime(recovery, (later, later))
    assert recovery.parent == tmp_path and recovery.is_file()
    return project, recovery, saved, unsaved


def _open(window: Any, qtbot: Any, driver: DialogDriver, project: Path, asked: int) -> None:
    """Open ``project`` in the background, as File → Open and ``--project`` do; wait until it is shown
    and ``asked`` questions were answered."""
    assert window.files.open_project(project, background=True)
    qtbot.waitUntil(lambda: window.files.path is not None and len(driver.questions()) >= asked, timeout=20000)


def test_recover_brings_back_the_autosave_of_the_opened_project(window: Any, qtbot: Any, driver: DialogDriver,
                                                                tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    project, recovery, saved, unsaved = _crashed_session(window, tmp_path, monkeypatch)
    driver.answer("Recover")
    _open(window, qtbot, driver, project, 1)
    asked = driver.questions()
    assert [q.title for q in asked] == ["Recover unsaved work"]
    assert set(asked[0].buttons) == {"Recover", "Discard", "Later"} and "look.sheer" in asked[0].text
    assert np.array_equal(_maps(window), unsaved) and not np.array_equal(unsaved, saved)
    assert window.files.path == project.absolute() and window.isWindowModified()
    assert not recovery.exists() and window.files.hold.path == project.absolute()


def test_later_keeps_it_and_discard_removes_it(window: Any, qtbot: Any, driver: DialogDriver, tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    project, recovery, saved, _unsaved = _crashed_session(window, tmp_path, monkeypatch)
    driver.answer("Later")
    _open(window, qtbot, driver, project, 1)
    assert recovery.is_file() and np.array_equal(_maps(window), saved) and not window.isWindowModified()

    window.files.new_project("natural")
    driver.answer("Discard")
    _open(window, qtbot, driver, project, 2)
    assert not recovery.exists() and np.array_equal(_maps(window), saved) and not window.isWindowModified()
    assert [q.title for q in driver.questions()] == ["Recover unsaved work"] * 2


def test_an_autosave_older_than_the_project_is_not_offered(window: Any, qtbot: Any, driver: DialogDriver,
                                                           tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    project, recovery, saved, _unsaved = _crashed_session(window, tmp_path, monkeypatch)
    earlier = project.stat().st_mtime - 60.0
    os.utime(recovery, (earlier, earlier))
    _open(window, qtbot, driver, project, 0)
    assert driver.questions() == [] and np.array_equal(_maps(window), saved) and recovery.is_file()
