"""Never lose work: a save killed at any moment, autosave, recovery after a crash."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from bench.fuzz import crash_runs, sample_project
from project.io import open_project, save_project
from project.recovery import Autosaver, autosave, find_recovery, list_recoveries, recover
from project.recovery_files import (
    discard_recovery,
    recovery_path,
    remove_stale_temporaries,
    stale_temporaries,
)
from tests.cli_support import checkout_env


@pytest.fixture(autouse=True)
def _recovery_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path / "recovery-dir"
    monkeypatch.setenv("SHEER_RECOVERY_DIR", str(folder))
    return folder


def test_killing_a_saving_process_always_leaves_a_loadable_project(tmp_path: Path) -> None:
    """A few dozen SIGKILLs at random moments of repeated saves; the file (and .bak) always opens."""
    result = crash_runs(30, seed=7, folder=tmp_path, max_delay_s=0.08)
    assert result["runs"] == 30
    assert result["failures"] == 0, result["failure_examples"]
    assert result["file_loaded"] == 30 and result["file_absent"] == 0  # the first save happens before any kill
    assert result["bak_loaded"] == 30 and result["bak_absent"] == 0  # so does the first .bak


def test_a_failing_save_leaves_the_old_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "p.sheer"
    save_project(sample_project(64, 2, name="old"), path, self_contained=True)
    import project.io as pp

    def explode(*args: object, **kwargs: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(pp, "write_container", explode)
    with pytest.raises(OSError):
        save_project(sample_project(64, 2, name="new"), path, self_contained=True)
    monkeypatch.undo()
    assert open_project(path).name == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["p.sheer"]


def test_autosave_recovery_after_a_crash(tmp_path: Path) -> None:
    """A studio process autosaves then dies; the next session finds and recovers the work."""
    path = tmp_path / "look.sheer"
    save_project(sample_project(64, 2, name="saved"), path, self_contained=True)
    script = (
        "import os, sys\n"
        "from bench.fuzz import sample_project\n"
        "from project.recovery import Autosaver\n"
        "clock = [0.0]\n"
        "a = Autosaver(lambda: sample_project(64, 2, name='unsaved work'), sys.argv[1], interval_s=60,"
        " clock=lambda: clock[0])\n"
        "a.mark_dirty(); clock[0] = 61.0\n"
        "assert a.tick() is not None\n"
        "os._exit(9)  # crash: no close, no save\n"
    )
    env = checkout_env()
    proc = subprocess.run([sys.executable, "-c", script, str(path)], env=env, capture_output=True, timeout=60)
    assert proc.returncode == 9, proc.stderr.decode()
    info = find_recovery(path)
    assert info is not None and info.error is None
    assert info.original == path.absolute() and not info.owner_alive and info.newer_than_original
    assert info.path == tmp_path / f".look.sheer.{info.pid}.recovery" and info.pid > 0
    project = recover(info)
    assert project.name == "unsaved work" and project.source_path == path.absolute()
    assert project.recovery is None
    assert open_project(path).name == "saved"  # the project file itself is untouched
    save_project(project, path)  # a normal save removes the recovery file
    assert find_recovery(path) is None and open_project(path).name == "unsaved work"


def test_autosaver_interval_dirty_flag_and_close(tmp_path: Path) -> None:
    now = [0.0]
    path = tmp_path / "p.sheer"
    saver = Autosaver(lambda: sample_project(64, 1, name="work"), path, interval_s=120, clock=lambda: now[0])
    assert saver.tick() is None  # nothing changed
    saver.mark_dirty()
    now[0] = 100.0
    assert saver.tick() is None  # not yet due
    now[0] = 121.0
    written = saver.tick()
    assert written == recovery_path(path) and written.is_file()
    assert saver.tick() is None  # clean again
    saver.mark_dirty()
    now[0] = 300.0
    assert saver.tick() == written
    saver.close()
    assert not written.exists() and find_recovery(path) is None
    with pytest.raises(ValueError):
        Autosaver(lambda: None, path, interval_s=0)


def test_untitled_work_is_recovered_from_the_recovery_folder(_recovery_dir: Path) -> None:
    saver = Autosaver(lambda: sample_project(64, 1, name="untitled work"), None, interval_s=1, clock=lambda: 5.0)
    saver.mark_dirty()
    written = saver.autosave_now()
    assert written.parent == _recovery_dir and written.name.startswith("untitled-")
    found = list_recoveries()
    assert [i.path for i in found] == [written]
    assert found[0].original is None and found[0].owner_alive  # this very process: not a crash
    project = recover(found[0])
    assert project.name == "untitled work" and project.source_path is None
    saver.saved(_recovery_dir.parent / "named.sheer")  # "save as": the untitled recovery goes away
    assert list_recoveries() == []


def test_unwritable_folder_autosaves_to_the_recovery_folder(tmp_path: Path, _recovery_dir: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / "kiosk"
    folder.mkdir()
    path = folder / "p.sheer"
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if Path(p) == folder else real_access(p, mode))
    written = autosave(sample_project(64, 1), path)
    assert written.parent == _recovery_dir and written.name.endswith("-p.sheer.recovery")
    assert find_recovery(path) is not None
    discard_recovery(path)
    assert find_recovery(path) is None


def test_damaged_recovery_file_is_reported_not_raised(tmp_path: Path) -> None:
    path = tmp_path / "p.sheer"
    (tmp_path / ".p.sheer.recovery").write_bytes(b"garbage")
    info = find_recovery(path)
    assert info is not None and info.error is not None and "not a Sheer project" in info.error


def test_stale_temporaries_are_found_and_removed(tmp_path: Path) -> None:
    path = tmp_path / "p.sheer"
    stale = tmp_path / ".p.sheer.abc123.tmp"
    stale.write_bytes(b"half a zip")
    os.utime(stale, (1_000_000, 1_000_000))
    fresh = tmp_path / ".p.sheer.def456.tmp"
    fresh.write_bytes(b"a save in progress")
    assert stale_temporaries(path) == [stale]
    assert remove_stale_temporaries(path) == 1 and not stale.exists() and fresh.exists()


def test_a_crash_just_before_or_after_every_file_system_call_of_a_save(tmp_path: Path) -> None:
    from bench.fuzz import crash_at_every_step

    result = crash_at_every_step(tmp_path)
    assert result["failures"] == 0, result["failure_examples"]
    assert result["steps"] >= 8  # fsyncs, the backup copy, chmod, the replaces: each before and after
