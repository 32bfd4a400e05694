"""Atomic file writes: a failed or interrupted save never damages the file it replaces.

The data goes to a temporary file in the target's folder, is flushed and fsynced, optionally the old
file is kept as ``<name>.bak``, and the temporary file is renamed over the target (atomic on POSIX),
then the folder is fsynced. At any moment the target is either the complete old file or the complete
new one.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import shutil
import tempfile
from pathlib import Path
from typing import IO, TYPE_CHECKING

from core.errors import SheerError

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator


@contextlib.contextmanager
def atomic_writer(path: str | Path, mode: str = "wb", keep_backup: bool = False,
                  encoding: str | None = None, file_mode: int | None = None) -> Iterator[IO]:
    """Context manager yielding a file object; on a clean exit the content replaces ``path`` atomically.

    If the block raises, the temporary file is removed and ``path`` is untouched. With
    ``keep_backup=True`` the previous file (if any) is kept as ``<path>.bak`` (a hard link or copy made
    before the rename, so the target never disappears). The new file keeps the replaced file's
    permissions (a new one gets the umask's), or ``file_mode`` when given: e.g. 0o600 for a secret, which
    the temporary file has from its creation (``mkstemp``), so it is never readable by others.
    """
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise _naming(exc, target) from None
    tmp = Path(tmp_name)
    try:
        with os.fdopen(fd, mode, encoding=encoding) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        if file_mode is not None:
            os.chmod(tmp, file_mode)
        elif target.exists():
            with contextlib.suppress(OSError):
                os.chmod(tmp, target.stat().st_mode & 0o777)
        else:
            os.chmod(tmp, 0o666 & ~_umask())
        if keep_backup and target.exists():
            _keep_backup(target)
        os.replace(tmp, target)
        _fsync_dir(folder)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        if exc.filename is None or exc.filename == tmp_name:
            raise _naming(exc, target) from exc
        raise
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def _naming(exc: OSError, target: Path) -> OSError:
    """``exc`` naming ``target``, the file the caller asked for, instead of the hidden temporary file.

    The temporary file (``.NAME.XXXXXXXX.tmp``) is this module's business: a message naming it ("Read-only
    file system (…/.p.png.z13ce114.tmp)") sends the reader looking for a file that never existed.
    """
    return type(exc)(exc.errno, exc.strerror or str(exc), str(target))


def check_can_create(path: str | Path, error: type[Exception] = SheerError) -> None:
    """Raise ``error`` naming ``path`` when nothing can be created there; create nothing.

    For a command that works long before it writes (a capture's fit): the nearest folder that exists
    above ``path`` must be a folder this process can create a file in (checked by creating and removing
    a temporary folder there, so a read-only file system, a missing permission or a file in the way is
    found as the writer would find it).
    """
    target = Path(path).absolute()
    above = target.parent
    while not above.exists() and above != above.parent:
        above = above.parent
    if not above.is_dir():
        raise error(f"{path}: cannot be created: {above} is a file, not a folder")
    try:
        probe = tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".check", dir=above)
    except OSError as exc:
        raise error(f"{path}: cannot be created: {exc.strerror or exc} ({above})") from None
    os.rmdir(probe)


def atomic_write_bytes(path: str | Path, data: bytes, keep_backup: bool = False) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_writer`)."""
    with atomic_writer(path, "wb", keep_backup=keep_backup) as fh:
        fh.write(data)


def atomic_write_text(path: str | Path, text: str, keep_backup: bool = False) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically (see :func:`atomic_writer`)."""
    atomic_write_bytes(path, text.encode("utf-8"), keep_backup=keep_backup)


def atomic_write_with(path: str | Path, writer: Callable[[IO], None], keep_backup: bool = False) -> None:
    """Call ``writer(fileobj)`` on a binary temporary file, then replace ``path`` atomically."""
    with atomic_writer(path, "wb", keep_backup=keep_backup) as fh:
        writer(fh)


def _keep_backup(target: Path) -> None:
    """Make ``<target>.bak`` the current ``target``.

    A hard link when the file system allows it (no copy of a large project on every save), else a
    copy; fsynced, and put in place by a rename, so the previous ``.bak`` is replaced atomically too.
    """
    backup = target.with_name(target.name + ".bak")
    # a name of its own (two writers of one file never share it; one left by a killed save is swept by
    # project.recovery_files.remove_stale_temporaries, as ``.<name>.*.tmp``)
    backup_tmp = target.with_name(f".{target.name}.bak.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    try:
        try:
            os.link(target, backup_tmp)
        except OSError:
            shutil.copy2(target, backup_tmp)
            with open(backup_tmp, "rb") as bfh:
                os.fsync(bfh.fileno())
        os.replace(backup_tmp, backup)
        # a rename between two links of one file does nothing (POSIX): another writer's backup of the same
        # version already is the .bak, and this name goes
        with contextlib.suppress(FileNotFoundError):
            backup_tmp.unlink()
    except BaseException:
        with contextlib.suppress(OSError):
            backup_tmp.unlink()
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _fsync_dir(folder: Path) -> None:
    try:
        dfd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(dfd)
    except OSError:
        pass
    finally:
        os.close(dfd)
