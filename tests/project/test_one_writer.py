"""One writer at a time: processes saving one project never fail, and a reader always loads a whole version."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bench.fuzz import sample_project
from core.locks import FileLock, LockedError
from project.io import STALE_TEMP_S, open_project, save_project
from tests.cli_support import checkout_env

#: Saves ``argv[3]`` versions of one small project (64² maps, with its .bak) to ``argv[1]``, named
#: ``<argv[2]> <i>``; prints ``{"failures": [...]}``.
WRITER = (
    "import json, sys\n"
    "from bench.fuzz import sample_project\n"
    "from project.io import save_project\n"
    "project = sample_project(64, 2)\n"
    "failures = []\n"
    "for i in range(int(sys.argv[3])):\n"
    "    project.name = f'{sys.argv[2]} {i}'\n"
    "    try:\n"
    "        save_project(project, sys.argv[1])\n"
    "    except Exception as exc:\n"
    "        failures.append(f'{type(exc).__name__}: {exc}')\n"
    "print(json.dumps({'failures': failures}))\n"
)

#: Loads ``argv[1]`` in a loop until ``argv[2]`` exists; prints ``{"loads": n, "failures": [...], "names": k}``.
READER = (
    "import json, os, sys\n"
    "from project.io import open_project\n"
    "loads, failures, names = 0, [], set()\n"
    "while not os.path.exists(sys.argv[2]):\n"
    "    try:\n"
    "        names.add(open_project(sys.argv[1], verify_head=False).name)\n"
    "        loads += 1\n"
    "    except Exception as exc:\n"
    "        failures.append(f'{type(exc).__name__}: {exc}')\n"
    "print(json.dumps({'loads': loads, 'failures': failures[:5], 'names': len(names)}))\n"
)


def _python(script: str, *args: str) -> subprocess.Popen[str]:
    env = checkout_env()
    return subprocess.Popen([sys.executable, "-c", script, *args], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _result(proc: subprocess.Popen[str]) -> dict:
    out, err = proc.communicate(timeout=240)
    assert proc.returncode == 0, err
    return json.loads(out.strip().splitlines()[-1])


def test_two_processes_saving_one_project_300_times_each_never_fail(tmp_path: Path) -> None:
    """600 saves (with .bak) of one file from two processes: none fails; a third process loads it meanwhile
    and every load gets one complete version."""
    path = tmp_path / "shared.sheer"
    save_project(sample_project(64, 2, name="first"), path)
    stop = tmp_path / "stop"
    reader = _python(READER, str(path), str(stop))
    writers = [_python(WRITER, str(path), tag, "300") for tag in ("one", "two")]
    try:
        results = [_result(w) for w in writers]
    finally:
        stop.touch()
    read = _result(reader)
    assert [r["failures"] for r in results] == [[], []]
    assert read["failures"] == [] and read["loads"] > 0
    assert read["names"] > 1  # the reader saw the file change under it
    assert open_project(path).name in ("one 299", "two 299")
    assert open_project(path.with_name("shared.sheer.bak")).name.split()[0] in ("one", "two", "first")
    assert list(tmp_path.glob(".shared.sheer.*")) == []  # no temporary file, no lock file left


def test_a_save_is_refused_while_another_sheer_has_the_project_open(tmp_path: Path) -> None:
    path = tmp_path / "held.sheer"
    save_project(sample_project(64, 1, name="held"), path)
    holder = _python("import sys, time\nfrom core.locks import FileLock\nlock = FileLock(sys.argv[1])\n"
                     "assert lock.try_acquire() is None\nprint('held', flush=True)\ntime.sleep(120)\n", str(path))
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        with pytest.raises(LockedError, match=rf"held\.sheer: open in another Sheer \(.*pid {holder.pid}\)"):
            save_project(sample_project(64, 1, name="other"), path)
        assert open_project(path).name == "held"
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait()
    save_project(sample_project(64, 1, name="after"), path)  # the killed holder's lock died with it
    assert open_project(path).name == "after"


def test_a_killed_saves_temporary_file_is_swept_by_the_next_save(tmp_path: Path) -> None:
    """A save SIGKILLed while writing leaves ``.NAME.XXXX.tmp``; the next save removes it once it is old."""
    path = tmp_path / "p.sheer"
    save_project(sample_project(64, 1, name="saved"), path)
    script = ("import os, signal, sys\nfrom core.atomicio import atomic_writer\n"
              "with atomic_writer(sys.argv[1], 'wb', keep_backup=True) as fh:\n"
              "    fh.write(b'half a project')\n    fh.flush()\n    os.kill(os.getpid(), signal.SIGKILL)\n")
    env = checkout_env()
    proc = subprocess.run([sys.executable, "-c", script, str(path)], env=env, timeout=60)
    assert proc.returncode == -signal.SIGKILL
    left = list(tmp_path.glob(".p.sheer.*.tmp"))
    assert len(left) == 1 and left[0].read_bytes() == b"half a project"
    save_project(sample_project(64, 1, name="again"), path)
    assert left[0].exists()  # a fresh one may be a save in progress (of an older Sheer, without the lock)
    old = time.time() - STALE_TEMP_S - 60
    os.utime(left[0], (old, old))
    save_project(sample_project(64, 1, name="later"), path)
    assert not left[0].exists() and open_project(path).name == "later"


def test_autosaves_of_two_processes_never_overwrite_each_other(tmp_path: Path) -> None:
    """Each process writes its own recovery file (its pid in the name); a save removes only its own."""
    from project.recovery import autosave, find_recovery
    from project.recovery_files import discard_recovery

    path = tmp_path / "p.sheer"
    save_project(sample_project(64, 1, name="saved"), path)
    script = ("import sys, time\nfrom bench.fuzz import sample_project\nfrom project.recovery import autosave\n"
              "autosave(sample_project(64, 1, name='theirs'), sys.argv[1])\nprint('held', flush=True)\n"
              "time.sleep(120)\n")
    other = _python(script, str(path))
    try:
        assert other.stdout is not None and other.stdout.readline().strip() == "held"
        mine = autosave(sample_project(64, 1, name="mine"), path)
        theirs = path.with_name(f".p.sheer.{other.pid}.recovery")
        assert mine == path.with_name(f".p.sheer.{os.getpid()}.recovery") and theirs.is_file()
        info = find_recovery(path)
        assert info is not None and info.owner_alive  # both live: neither is a crash
        discard_recovery(path)  # this process saved: its file goes, the other studio's stays
        assert not mine.exists() and theirs.is_file()
        assert FileLock(path).try_acquire() is None  # nobody holds the project itself
    finally:
        other.send_signal(signal.SIGKILL)
        other.wait()
    info = find_recovery(path)
    assert info is not None and info.path == theirs and not info.owner_alive and info.pid == other.pid


def test_sheer_project_upgrade_is_refused_while_a_studio_has_the_project_open(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import shutil
    import socket

    from app.cli import main
    from project.io import project_version

    shutil.copytree(Path(__file__).resolve().parents[1] / "data" / "project", tmp_path / "d")
    path = tmp_path / "d" / "v1-draft.sheer"
    holder = _python("import sys, time\nfrom core.locks import FileLock\nlock = FileLock(sys.argv[1])\n"
                     "assert lock.try_acquire() is None\nprint('held', flush=True)\ntime.sleep(120)\n", str(path))
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        capsys.readouterr()
        assert main(["project", "upgrade", str(path)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.splitlines() == [err]
        assert f"{path}: open in another Sheer ({socket.gethostname()}, pid {holder.pid})" in err
        assert project_version(path) == 1 and not path.with_name("v1-draft.sheer.v1.bak").exists()
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait()
    assert main(["project", "upgrade", str(path)]) == 0
