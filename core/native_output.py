"""What native libraries print on file descriptors 1 and 2, captured around a call.

OpenEXR's C++ core prints ``EXR_ERR_*`` lines and "Exception raised reading pixel data" warnings; MediaPipe
(absl, TensorFlow Lite) prints ``I0000``/``W0000`` lines and "Created TensorFlow Lite XNNPACK delegate" on its
first images. They write to the process's descriptors, below Python's ``sys.stdout``/``sys.stderr``, so they
would corrupt ``--json`` output and the one-line messages of the command line. :func:`captured_output`
sends both descriptors into pipes during a block and hands back what was written; :func:`pass_on` writes
back the lines that are not a library's noise (another thread's message, printed during the block, is
delayed, not lost).

The pipes are non-blocking, so a chatty library cannot block; at most the first 64 KiB of each are kept.
One block at a time in the process (a lock): the descriptors are the process's.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import sys
import threading
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator

#: The most bytes kept from each descriptor.
MAX_CAPTURED_BYTES = 65536

_FD_LOCK = threading.RLock()


@contextlib.contextmanager
def captured_output() -> Iterator[list[str]]:
    """Capture what is written on file descriptors 1 and 2 during the block.

    Yields:
        A list that receives the captured text after the block: standard output's, then standard error's.
    """
    captured: list[str] = []
    with _FD_LOCK:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        saved: list[tuple[int, int, int]] = []  # (fd, saved copy, pipe read end)
        try:
            for fd in (1, 2):
                read_end, write_end = os.pipe()
                fcntl.fcntl(write_end, fcntl.F_SETFL, fcntl.fcntl(write_end, fcntl.F_GETFL) | os.O_NONBLOCK)
                fcntl.fcntl(read_end, fcntl.F_SETFL, fcntl.fcntl(read_end, fcntl.F_GETFL) | os.O_NONBLOCK)
                saved.append((fd, os.dup(fd), read_end))
                os.dup2(write_end, fd)
                os.close(write_end)
            yield captured
        finally:
            for fd, copy, read_end in saved:
                os.dup2(copy, fd)
                os.close(copy)
                chunks = []
                with contextlib.suppress(BlockingIOError, OSError):
                    while chunk := os.read(read_end, MAX_CAPTURED_BYTES):
                        chunks.append(chunk)
                        if sum(map(len, chunks)) >= MAX_CAPTURED_BYTES:
                            break
                os.close(read_end)
                captured.append(b"".join(chunks).decode("utf-8", "replace"))


def pass_on(captured: list[str], noise: Callable[[str], bool]) -> None:
    """Write back to standard output and standard error the captured lines for which ``noise`` is False."""
    for text, stream in zip(captured, (sys.stdout, sys.stderr)):
        kept = [line for line in text.splitlines(keepends=True) if line.strip() and not noise(line)]
        if kept:
            with contextlib.suppress(Exception):
                stream.write("".join(kept))
                stream.flush()
