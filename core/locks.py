"""One writer at a time: advisory locks on project files, and whether the process that made a file still runs.

- :class:`FileLock`: a lock on a file (a project), held through the hidden file ``.<name>.lock`` beside it.
  The studio holds it while a project is open (``purpose="open"``); every writer (a save, ``sheer project
  upgrade``) takes it for the length of the write (:func:`writing`). Whoever holds it writes its host,
  process id and purpose into the lock file, so another Sheer can say who has the project open.
- :func:`process_token` / :func:`process_alive`: a process's id plus its start time and the machine's boot,
  so a file named after a process (a recovery file, a kiosk's private folder) is known to be left by a dead
  one even when its process id has been reused since.

The lock is an ``fcntl.flock`` on the lock file, written here rather than with the ``filelock`` package:
``filelock`` truncates the lock file whenever it *tries* to lock it, which would wipe the holder's host and
process id that the question "open in another Sheer (host, pid)" needs. An flock dies with its process (a
crash or ``kill -9`` never leaves a project locked) and serves every process on the machine (threads of one
process are kept in order by a ``threading`` lock per file). POSIX only, as is the rest of Sheer's file
handling.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from core.errors import SheerError

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator

#: Seconds a writer waits for another writer's save before giving up (a large project saves in ~1 s).
WRITE_WAIT_S = 30.0
#: Seconds between two tries of a lock held by someone else.
POLL_S = 0.005
#: The purposes a lock is held for: a project open in a studio, or one write.
PURPOSES = ("open", "write")


@dataclass(frozen=True)
class Holder:
    """Who holds a lock: the machine's name, the process id, and what for (one of :data:`PURPOSES`)."""

    host: str
    pid: int
    purpose: str = "open"

    def __str__(self) -> str:
        return f"{self.host}, pid {self.pid}"


class LockedError(SheerError):
    """The file is locked by another Sheer (:attr:`holder`); the message names the file and the holder."""

    def __init__(self, path: Path, holder: Holder) -> None:
        what = "open in another Sheer" if holder.purpose == "open" else "being written by another Sheer"
        super().__init__(f"{path}: {what} ({holder})")
        self.path = path
        self.holder = holder


def lock_file(path: str | Path) -> Path:
    """The lock file of ``path``: ``.<name>.lock`` in its folder."""
    p = Path(path).absolute()
    return p.with_name(f".{p.name}.lock")


_REGISTRY = threading.Lock()
_HELD: dict[Path, FileLock] = {}
_WRITERS: dict[Path, threading.RLock] = {}


def _me(purpose: str) -> Holder:
    return Holder(socket.gethostname(), os.getpid(), purpose)


def _read_holder(fd: int) -> Holder | None:
    with contextlib.suppress(OSError, ValueError, TypeError, KeyError):
        data = json.loads(os.pread(fd, 4096, 0).decode("utf-8"))
        return Holder(str(data["host"]), int(data["pid"]), str(data.get("purpose", "open")))
    return None


class FileLock:
    """One holder's advisory lock on ``path`` (see the module docstring).

    Args:
        path: the file to lock (it need not exist).
        purpose: ``"open"`` (a studio has the project open) or ``"write"`` (one save).
    """

    def __init__(self, path: str | Path, purpose: str = "open") -> None:
        if purpose not in PURPOSES:
            raise ValueError(f"lock purpose must be one of {PURPOSES}, got {purpose!r}")
        self.path = Path(path).absolute()
        self.purpose = purpose
        self._fd: int | None = None
        self._held = False

    @property
    def held(self) -> bool:
        """Whether this object holds the lock."""
        return self._held

    def try_acquire(self) -> Holder | None:
        """Take the lock if nobody holds it: None when taken (or already held), else who holds it.

        A folder where no lock file can be made (read-only) is not locked: None (nothing can be saved there).
        """
        with _REGISTRY:
            other = _HELD.get(self.path)
            if other is self:
                return None
            if other is not None:
                return _me(other.purpose)
            while True:
                try:
                    fd = os.open(lock_file(self.path), os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
                except OSError as exc:
                    if exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
                        self._held = True  # nothing to lock against where nothing can be written
                        _HELD[self.path] = self
                        return None
                    raise
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except BlockingIOError:
                    holder = _read_holder(fd)
                    os.close(fd)
                    return holder or Holder("unknown host", 0, "write")
                if self._same_file(fd):
                    break
                os.close(fd)  # locked a lock file its holder removed on release: lock the new one
            # who holds it is for the messages only: on a full disk the flock alone still locks, and the
            # save itself says what is wrong
            with contextlib.suppress(OSError):
                os.ftruncate(fd, 0)
                os.pwrite(fd, json.dumps(_me(self.purpose).__dict__).encode("utf-8"), 0)
            self._fd, self._held = fd, True
            _HELD[self.path] = self
            return None

    def _same_file(self, fd: int) -> bool:
        try:
            now = os.stat(lock_file(self.path))
        except FileNotFoundError:
            return False
        mine = os.fstat(fd)
        return (now.st_dev, now.st_ino) == (mine.st_dev, mine.st_ino)

    def acquire(self, timeout_s: float = WRITE_WAIT_S) -> None:
        """Take the lock, waiting up to ``timeout_s`` seconds while another *write* holds it.

        Raises:
            LockedError: a studio has the file open (raised at once), or a write did not end in time.
        """
        deadline = time.monotonic() + timeout_s
        while True:
            holder = self.try_acquire()
            if holder is None:
                return
            if holder.purpose == "open" or time.monotonic() >= deadline:
                raise LockedError(self.path, holder)
            time.sleep(POLL_S)

    def release(self) -> None:
        """Let go of the lock (removing the lock file); nothing when not held."""
        with _REGISTRY:
            if not self._held:
                return
            self._held = False
            if _HELD.get(self.path) is self:
                del _HELD[self.path]
            fd, self._fd = self._fd, None
            if fd is not None:
                with contextlib.suppress(OSError):
                    if self._same_file(fd):
                        os.unlink(lock_file(self.path))
                os.close(fd)

    def __enter__(self) -> FileLock:
        self.acquire()
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def holder_of(path: str | Path) -> Holder | None:
    """Who holds the lock of ``path`` now (None: nobody); takes and releases it when free."""
    probe = FileLock(path, "write")
    holder = probe.try_acquire()
    probe.release()
    return holder


@contextlib.contextmanager
def writing(path: str | Path, timeout_s: float = WRITE_WAIT_S) -> Iterator[None]:
    """Hold the lock of ``path`` while the block writes it.

    Threads of this process take turns; when this process already holds the lock (a studio that has the
    project open) the block runs under it; else the lock is taken, waiting up to ``timeout_s`` seconds for
    another process's save.

    Raises:
        LockedError: another Sheer has the file open, or its save did not end in ``timeout_s`` seconds.
    """
    p = Path(path).absolute()
    with _REGISTRY:
        mutex = _WRITERS.setdefault(p, threading.RLock())
    with mutex:
        with _REGISTRY:
            mine = p in _HELD
        if mine:
            yield
            return
        lock = FileLock(p, "write")
        lock.acquire(timeout_s)
        try:
            yield
        finally:
            lock.release()


# ---------------------------------------------------------------------------------------------- processes


def _boot_id() -> str:
    with contextlib.suppress(OSError):
        return Path("/proc/sys/kernel/random/boot_id").read_text().strip().replace("-", "")[:8]
    return ""


def _stat_fields(pid: int) -> list[str] | None:
    """``/proc/<pid>/stat`` from the state on (field 3 first), or None where there is none."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return text[text.rfind(")") + 2:].split()


def process_token(pid: int | None = None) -> str:
    """``<boot id>.<start time>`` of process ``pid`` (default this one); "" where unknown (not Linux).

    The start time is in clock ticks since the boot (``/proc/<pid>/stat`` field 22): together with the
    boot id it tells a process from a later one that was given the same id.
    """
    fields = _stat_fields(os.getpid() if pid is None else pid)
    if fields is None or len(fields) < 20:
        return ""
    return f"{_boot_id()}.{fields[19]}"


def process_started_at(pid: int) -> float | None:
    """When process ``pid`` started (Unix time, s; to a clock tick), or None where unknown."""
    fields = _stat_fields(pid)
    if fields is None or len(fields) < 20:
        return None
    try:
        boot = next(float(line.split()[1]) for line in Path("/proc/stat").read_text().splitlines()
                    if line.startswith("btime "))
    except (OSError, StopIteration, ValueError, IndexError):
        return None
    return boot + int(fields[19]) / os.sysconf("SC_CLK_TCK")


def process_alive(pid: int, token: str = "", since: float | None = None) -> bool:
    """Whether process ``pid`` runs (a zombie does not) and is the one that made a file.

    Args:
        pid: the process id.
        token: its :func:`process_token` when the file was made ("": not known).
        since: a time the process ran (a file's modification time, Unix s; None: not known). A process
            that started after it only reuses the id.
    """
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        pass  # another user's process: it exists
    fields = _stat_fields(pid)
    if fields is not None and fields and fields[0] in ("Z", "X"):
        return False
    if token:
        now = process_token(pid)
        if now and now != token:
            return False
    if since is not None:
        started = process_started_at(pid)
        if started is not None and started > since + 2.0:  # 2 s: btime is rounded to whole seconds
            return False
    return True


# ---------------------------------------------------------------------------------------------- take over

#: Seconds a studio that asks to take a project over waits for the one that has it open to let go.
TAKEOVER_WAIT_S = 10.0


def takeover_file(path: str | Path) -> Path:
    """The file in which a Sheer asks the holder of ``path`` to let go of it: ``.<name>.takeover``."""
    p = Path(path).absolute()
    return p.with_name(f".{p.name}.takeover")


def takeover_request(path: str | Path) -> Holder | None:
    """Who asks to take ``path`` over (another Sheer), or None."""
    try:
        data = json.loads(takeover_file(path).read_text(encoding="utf-8"))
        return Holder(str(data["host"]), int(data["pid"]), "open")
    except (OSError, ValueError, TypeError, KeyError):
        return None


def take_over(path: str | Path, timeout_s: float = TAKEOVER_WAIT_S,
              wait: Callable[[], None] | None = None) -> FileLock:
    """Ask the Sheer that has ``path`` open to let go of it, and hold it (purpose ``"open"``) once it has.

    The request is the file :func:`takeover_file`; the holder (a studio checks every second) keeps its work
    as an untitled copy and releases the lock. ``wait`` is called between tries (the studio's runs its
    events; default: sleep :data:`POLL_S` seconds).

    Raises:
        LockedError: the holder did not let go in ``timeout_s`` seconds (the message names it).
    """
    lock = FileLock(path, "open")
    request = takeover_file(path)
    request.write_text(json.dumps(_me("open").__dict__), encoding="utf-8")
    deadline = time.monotonic() + timeout_s
    try:
        while True:
            holder = lock.try_acquire()
            if holder is None:
                return lock
            if time.monotonic() >= deadline:
                raise LockedError(lock.path, holder)
            (wait or (lambda: time.sleep(POLL_S)))()
    finally:
        with contextlib.suppress(OSError):
            request.unlink()
