"""A full disk, for real: each writer of something the user keeps, on a tiny tmpfs filled to the last byte.

Project save (with its backup), library save, the cache, the kiosk's Save Photo and the studio's autosave:
the write fails with ENOSPC, the user gets one line naming the file and "No space left on device" (the
command line's stderr, or the message the studio or kiosk shows), the previous file is byte-identical
and no temporary file is left behind.
"""

from __future__ import annotations

import logging
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from tests import disk_support
from tests.cli_support import sheer
from tests.disk_support import fill, listing

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

FULL = "No space left on device"
tiny_tmpfs = disk_support.tiny_tmpfs  # the fixture: a tmpfs mounted for the test


def _one_line(text: str) -> str:
    assert text.count("\n") <= 1 and text.strip(), text
    return text.strip()


def test_project_save_on_a_full_disk(tiny_tmpfs: Callable[..., Path], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SHEER_RECOVERY_DIR", str(tiny_tmpfs("recovery")))
    disk = tiny_tmpfs("disk")
    path = disk / "p.sheer"
    for _ in range(2):  # the second save keeps the first as p.sheer.bak
        done = sheer("project", "new", "--out", str(path), "--force", "--resolution", "64")
        assert done.returncode == 0, done.stderr
    before = listing(disk)
    assert set(before) == {"p.sheer", "p.sheer.bak"}
    fill(disk)
    done = sheer("project", "new", "--out", str(path), "--force", "--resolution", "64", "--name", "changed")
    assert done.returncode == 2
    line = _one_line(done.stderr)
    assert FULL in line and str(path) in line and ".tmp" not in line, line
    assert listing(disk) == before  # the project and its backup byte-identical, no temporary file


def test_library_save_on_a_full_disk(tiny_tmpfs: Callable[..., Path], tmp_path: Path) -> None:
    from km.library import Library, default_library_path
    from km.measurements import export_csv

    stock = Library.load(default_library_path())
    first, second = stock.materials[0], stock.materials[1]
    disk = tiny_tmpfs("disk")
    library = disk / "lib.json"
    Library([first], name="lib").save(library)
    Library.load(library).save()  # a backup too
    csv = export_csv(second, tmp_path / "m.csv")
    before = listing(disk)
    assert set(before) == {"lib.json", "lib.json.bak"}
    fill(disk)
    done = sheer("materials", "import", str(csv), "--library", str(library))
    assert done.returncode == 2
    line = _one_line(done.stderr)
    assert FULL in line and str(library) in line and ".tmp" not in line, line
    assert listing(disk) == before


def test_cache_on_a_full_disk(tiny_tmpfs: Callable[..., Path], monkeypatch: pytest.MonkeyPatch,
                              caplog: pytest.LogCaptureFixture) -> None:
    from core import cache

    root = tiny_tmpfs("cache")
    monkeypatch.setenv("SHEER_CACHE_DIR", str(root))
    monkeypatch.setenv(cache.ENV_MAX_MB, "1")
    entry = cache.cache_dir("looks") / "entry"
    old = np.arange(64, dtype=np.float32)
    assert cache.save_array(entry, old)
    before = listing(entry.parent)
    fill(root)
    with caplog.at_level(logging.DEBUG, logger="sheer.cache"):
        for _ in range(3):  # the cache is an optimisation: never an error, one warning for a full disk
            assert not cache.save_array(entry, old + 1.0)
            assert not cache.save_array(entry.with_name("other"), old)
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1, warnings
    line = _one_line(warnings[0])
    assert FULL in line and str(entry) in line and ".tmp" not in line, line
    assert listing(entry.parent) == before
    loaded = cache.load_array(entry)
    assert loaded is not None and np.array_equal(loaded, old)


def test_kiosk_save_photo_on_a_full_disk(tiny_tmpfs: Callable[..., Path]) -> None:
    from PySide6.QtGui import QImage

    from app.kiosk.window import KioskWindow

    folder = tiny_tmpfs("photos")
    image = QImage(48, 32, QImage.Format.Format_RGB32)
    image.fill(0x336699)

    def kiosk(n: int) -> Any:  # what Save Photo uses of the kiosk, the sample head on screen
        return SimpleNamespace(config=SimpleNamespace(snapshot_dir=str(folder)), snapshots=[None] * n,
                               tryon=SimpleNamespace(active=False), toast=SimpleNamespace(setText=lambda _t: None),
                               viewport=SimpleNamespace(grabFramebuffer=lambda: image))

    first = KioskWindow.snapshot(kiosk(0))
    before = listing(folder)
    assert list(before) == [first.name] and before[first.name].startswith(b"\x89PNG")
    fill(folder)
    with pytest.raises(Exception) as caught:  # noqa: PT011  (any error: the kiosk's guard shows it)
        KioskWindow.snapshot(kiosk(1))
    line = _one_line(str(caught.value))  # what the guard logs and keeps as the kiosk's last error
    assert FULL in line and str(folder / "sheer-") in line and ".tmp" not in line, line
    assert listing(folder) == before


def test_studio_autosave_on_a_full_disk(tiny_tmpfs: Callable[..., Path], monkeypatch: pytest.MonkeyPatch) -> None:
    from app import project_io
    from app.studio.project_files import autosave_failure
    from bench.fuzz import sample_project

    monkeypatch.setenv("SHEER_RECOVERY_DIR", str(tiny_tmpfs("recovery")))
    disk = tiny_tmpfs("disk")
    projects = iter([sample_project(64, 1, embedded=False, name="first"),
                     sample_project(64, 1, embedded=False, name="second")])
    saver = project_io.make_autosaver(lambda: next(projects), disk / "p.sheer", 60.0)
    written = saver.autosave_now()
    assert written.parent == disk  # beside the project: its folder is writable
    before = listing(disk)
    fill(disk)
    saver.mark_dirty()
    with pytest.raises(OSError) as caught:
        saver.autosave_now()
    line = _one_line(autosave_failure(str(caught.value)))  # the studio's status bar says this
    assert FULL in line and str(written) in line and ".tmp" not in line, line
    assert listing(disk) == before and saver.dirty  # the recovery file byte-identical; still to autosave
