"""One writer at a time: the advisory lock on a file, backups of concurrent writers, and dead processes."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from typing import TYPE_CHECKING

import pytest

from core.atomicio import atomic_write_bytes
from core.locks import (
    FileLock,
    Holder,
    LockedError,
    holder_of,
    lock_file,
    process_alive,
    process_started_at,
    process_token,
    take_over,
    takeover_request,
    writing,
)
from tests.cli_support import checkout_env

if TYPE_CHECKING:
    from pathlib import Path

#: A child that holds the lock of argv[1] for a studio ("open"), says so, and waits to be killed.
HOLDER = (
    "import sys, time\n"
    "from core.locks import FileLock\n"
    "lock = FileLock(sys.argv[1], 'open')\n"
    "assert lock.try_acquire() is None\n"
    "print('held', flush=True)\n"
    "time.sleep(120)\n"
)


def _child(script: str, *args: str) -> subprocess.Popen[str]:
    env = checkout_env()
    proc = subprocess.Popen([sys.executable, "-c", script, *args], env=env, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "held"
    return proc


def test_two_threads_keeping_backups_of_one_file_never_fail(tmp_path: Path) -> None:
    """Each save's backup has a temporary name of its own: two writers of one file never collide on it."""
    target = tmp_path / "p.bin"
    atomic_write_bytes(target, b"0" * 4096)
    errors: list[BaseException] = []

    def saves(tag: bytes) -> None:
        for _ in range(300):
            try:
                atomic_write_bytes(target, tag * 4096, keep_backup=True)
            except BaseException as exc:  # noqa: BLE001 - every failure is counted
                errors.append(exc)

    threads = [threading.Thread(target=saves, args=(tag,)) for tag in (b"a", b"b")]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    assert target.read_bytes() in (b"a" * 4096, b"b" * 4096)
    assert target.with_name("p.bin.bak").stat().st_size == 4096
    assert list(tmp_path.glob(".p.bin.*.tmp")) == []


def test_a_held_lock_names_its_holder_and_refuses_writers(tmp_path: Path) -> None:
    path = tmp_path / "look.sheer"
    proc = _child(HOLDER, str(path))
    try:
        assert holder_of(path) == Holder(socket.gethostname(), proc.pid, "open")
        with (pytest.raises(LockedError, match=rf"look\.sheer: open in another Sheer \(.+, pid {proc.pid}\)"),
              writing(path, timeout_s=0.2)):
            pass
    finally:
        proc.kill()
        proc.wait()


def test_a_sigkilled_holder_does_not_block(tmp_path: Path) -> None:
    """An flock dies with its process: after ``kill -9`` of the holder the file is free at once."""
    path = tmp_path / "look.sheer"
    proc = _child(HOLDER, str(path))
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert lock_file(path).exists()  # the killed holder could not remove it; it locks nothing
    lock = FileLock(path)
    assert lock.try_acquire() is None and lock.held
    lock.release()
    assert not lock_file(path).exists() and holder_of(path) is None


def test_released_lock_lets_the_next_holder_in_and_the_holder_writes_under_its_own(tmp_path: Path) -> None:
    path = tmp_path / "look.sheer"
    lock = FileLock(path)
    assert lock.try_acquire() is None
    with writing(path, timeout_s=0.1):  # this process holds it: its own saves go on
        pass
    other = FileLock(path)
    assert other.try_acquire() == Holder(socket.gethostname(), os.getpid(), "open")  # a second window
    lock.release()
    assert other.try_acquire() is None
    other.release()
    assert holder_of(path) is None


def test_a_writer_waits_for_another_write_then_goes_on(tmp_path: Path) -> None:
    path = tmp_path / "look.sheer"
    script = HOLDER.replace("'open'", "'write'").replace("time.sleep(120)", "time.sleep(0.5)")
    proc = _child(script, str(path))
    start = time.monotonic()
    with writing(path, timeout_s=20):
        waited = time.monotonic() - start
    proc.wait()
    assert 0.1 < waited < 10


def test_take_over_asks_the_holder_to_let_go(tmp_path: Path) -> None:
    path = tmp_path / "look.sheer"
    script = (
        "import sys, time\n"
        "from core.locks import FileLock, takeover_request\n"
        "lock = FileLock(sys.argv[1], 'open')\n"
        "assert lock.try_acquire() is None\n"
        "print('held', flush=True)\n"
        "while takeover_request(sys.argv[1]) is None:\n"
        "    time.sleep(0.02)\n"
        "lock.release()\n"
        "time.sleep(120)\n"
    )
    proc = _child(script, str(path))
    try:
        lock = take_over(path, timeout_s=20)
        assert lock.held and holder_of(path) == Holder(socket.gethostname(), os.getpid(), "open")
        assert takeover_request(path) is None  # the request is gone once answered
        lock.release()
        stubborn = _child(HOLDER, str(path))
        with pytest.raises(LockedError, match=f"pid {stubborn.pid}"):
            take_over(path, timeout_s=0.3)
        stubborn.kill()
        stubborn.wait()
    finally:
        proc.kill()
        proc.wait()


def test_a_dead_or_reused_process_id_is_not_alive() -> None:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    assert not process_alive(proc.pid)
    assert process_alive(os.getpid(), process_token())
    if process_token():  # Linux: a process with the same id but another start is not the same
        assert not process_alive(os.getpid(), process_token() + "0")
        started = process_started_at(os.getpid())
        assert started is not None and abs(started - time.time()) < 24 * 3600 * 365
        assert not process_alive(os.getpid(), since=started - 60.0)
        assert process_alive(os.getpid(), since=time.time())
    zombie = subprocess.Popen([sys.executable, "-c", "pass"])
    time.sleep(0.5)  # exited, not reaped: a zombie is dead
    assert not process_alive(zombie.pid)
    zombie.wait()
