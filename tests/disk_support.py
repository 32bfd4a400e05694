"""Real file systems for the tests of what the user sees when a write fails: a tiny tmpfs that fills up, a
read-only one, and checks run as the unprivileged user ``nobody``.

The suite runs as root, for whom no folder is read-only; these need root to mount a tmpfs and to become
``nobody``, and skip with the reason where that is not possible.
"""

from __future__ import annotations

import errno
import json
import os
import select
import shutil
import signal
import subprocess
import time
import traceback
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator
    from pathlib import Path

#: The user and group id of ``nobody``.
NOBODY = 65534


def _mount(target: Path, options: str) -> str | None:
    """Mount a tmpfs on ``target`` with ``options``; None, or why it could not be mounted."""
    if os.geteuid() != 0:
        return "needs root to mount a tmpfs"
    if shutil.which("mount") is None:
        return "mount(8) is not installed"
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(target)], capture_output=True,
                          text=True)
    return (done.stderr.strip() or f"mount exited {done.returncode}") if done.returncode else None


@pytest.fixture
def tiny_tmpfs(tmp_path: Path) -> Iterator[Callable[..., Path]]:
    """``mount(name, options="size=64k")``: a fresh tmpfs on ``tmp_path / name``, unmounted after the test.

    Skips the test (with the reason) where a tmpfs cannot be mounted (not root, no mount(8)).
    """
    mounted: list[Path] = []

    def mount(name: str, options: str = "size=64k") -> Path:
        target = tmp_path / name
        target.mkdir()
        why = _mount(target, options)
        if why is not None:
            pytest.skip(f"cannot mount a tmpfs here: {why}")
        mounted.append(target)
        return target

    try:
        yield mount
    finally:
        for target in reversed(mounted):  # lazily where a file is still open there (a failed test's)
            if subprocess.run(["umount", str(target)], check=False, capture_output=True).returncode:
                subprocess.run(["umount", "-l", str(target)], check=False, capture_output=True)


def fill(folder: Path) -> Path:
    """Fill the file system of ``folder`` to the last byte (``folder/filler``); returns the filler file.

    Writes until the file system answers ENOSPC, so a later write of even one byte fails.
    """
    filler = folder / "filler"
    with open(filler, "wb", buffering=0) as fh:
        for chunk in (65536, 4096, 512, 1):
            try:
                while True:
                    fh.write(b"\0" * chunk)
            except OSError as exc:
                if exc.errno != errno.ENOSPC:
                    raise
    return filler


def listing(folder: Path) -> dict[str, bytes]:
    """Every file in ``folder`` (hidden ones too) and its bytes, the filler left out."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file() and p.name != "filler"}


def can_drop_to_nobody() -> str | None:
    """None when this process can fork a child that becomes ``nobody`` (root), else why not."""
    if os.geteuid() != 0 or not hasattr(os, "fork"):
        return "needs root (and fork) to run as nobody"
    return None


def run_as_nobody(checks: Callable[[], Any], timeout_s: float = 60.0) -> Any:
    """``checks()`` run in a forked child that has become ``nobody`` (uid, gid 65534, no other groups).

    Its result must be JSON; it comes back through a pipe. The child is this process (Sheer and its
    libraries already imported) rather than a new interpreter, because the virtual environment's
    interpreter may live where ``nobody`` cannot read it (pyenv's, under root's 0700 home); what the child
    imports later comes from the checkout, readable by everyone.

    Raises:
        AssertionError: the child failed (its traceback in the message) or ran over ``timeout_s`` seconds.
    """
    read_fd, write_fd = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        status = 1
        try:
            os.close(read_fd)
            os.setgroups([])
            os.setresgid(NOBODY, NOBODY, NOBODY)
            os.setresuid(NOBODY, NOBODY, NOBODY)
            try:
                reply = {"result": checks()}
            except BaseException:
                reply = {"error": traceback.format_exc()}
            with os.fdopen(write_fd, "w") as fh:
                json.dump(reply, fh)
            status = 0
        finally:
            os._exit(status)
    os.close(write_fd)
    deadline = time.monotonic() + timeout_s
    chunks: list[bytes] = []
    try:
        while (left := deadline - time.monotonic()) > 0 and select.select([read_fd], [], [], left)[0]:
            if not (chunk := os.read(read_fd, 65536)):
                break
            chunks.append(chunk)
    finally:
        os.close(read_fd)
    while (waited := os.waitpid(pid, os.WNOHANG))[0] == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    if waited[0] == 0:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        raise AssertionError(f"the child running as nobody ran over {timeout_s:g} s")
    assert os.waitstatus_to_exitcode(waited[1]) == 0 and chunks, "the child running as nobody failed"
    reply = json.loads(b"".join(chunks))
    assert "error" not in reply, reply.get("error")
    return reply["result"]
