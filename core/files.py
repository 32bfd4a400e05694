"""Reading a user's file: whole, bounded in size, and refused with a message that names the file.

The readers of the files a user gives (a material library, a measurement, a head and its textures, a
thickness map) go through :func:`read_bounded`, so all of them refuse the same things the same way: a
missing file, a folder, a FIFO or device (which could block or never end), and a file over the size
limit, checked before reading and again while reading (a file that grows is refused too).
"""

from __future__ import annotations

import os
import stat
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from pathlib import Path

    from core.errors import SheerError


def read_bounded(path: Path, limit: int, what: str, error: type[SheerError]) -> bytes:
    """The bytes of the regular file at ``path``, at most ``limit`` bytes.

    Args:
        path: the file.
        limit: the largest size accepted, in bytes (> 0).
        what: the file's role in messages, e.g. "library file", "head mesh", "map file".
        error: the :class:`~core.errors.SheerError` subclass to raise.

    Raises:
        SheerError: ``error``, whose message starts with the path and says what is wrong: "no such
            <what> (not found)", "is a folder, not a <what>", "not a regular file", "<what> too large
            (N bytes, over the limit of M)" or "cannot read <what>: <reason>".
    """
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise error(f"{path}: no such {what} (not found)") from None
    except OSError as exc:
        raise error(f"{path}: cannot read {what}: {exc.strerror or exc}") from None
    if stat.S_ISDIR(info.st_mode):
        raise error(f"{path}: is a folder, not a {what}")
    if not stat.S_ISREG(info.st_mode):
        raise error(f"{path}: not a regular file")
    if info.st_size > limit:
        raise error(f"{path}: {what} too large ({info.st_size:,} bytes, over the limit of {limit:,})")
    try:
        with open(path, "rb") as fh:
            raw = fh.read(limit + 1)
    except FileNotFoundError:  # removed since the stat
        raise error(f"{path}: no such {what} (not found)") from None
    except OSError as exc:
        raise error(f"{path}: cannot read {what}: {exc.strerror or exc}") from None
    if len(raw) > limit:
        raise error(f"{path}: {what} too large (over the limit of {limit:,} bytes)")
    return raw
