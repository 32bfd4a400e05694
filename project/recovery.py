"""Autosave and crash recovery (Qt-free: the studio drives :class:`Autosaver` from a timer).

- Every ``interval_s`` seconds (default :data:`DEFAULT_AUTOSAVE_INTERVAL_S`, configurable) a project
  with unsaved changes is written, atomically, to its *recovery file*: ``.<name>.recovery`` beside the
  project (``<folder>/.<name>.recovery``), or in :func:`recovery_dir` when the project has no file yet
  (``untitled-<session>.recovery``) or its folder is not writable (``<hash>-<name>.recovery``). A
  recovery file is an ordinary ``.sheer`` zip whose ``project.json`` has a ``recovery`` block
  (original path, UTC time, process id).
- A normal save (:func:`project.io.save_project`) or close (:meth:`Autosaver.close`) removes it.
  So a recovery file that exists when the studio starts means the last session did not end normally:
  offer :func:`find_recovery` (for a file being opened) or :func:`list_recoveries` (all of them,
  including untitled work), then :func:`recover` or :func:`discard_recovery`.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import time
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

from project.errors import ProjectError

if TYPE_CHECKING:
    from collections.abc import Callable

#: Seconds between autosaves of a project with unsaved changes.
DEFAULT_AUTOSAVE_INTERVAL_S = 180.0
RECOVERY_SUFFIX = ".recovery"


def recovery_dir() -> Path:
    """Where recovery files of untitled projects go: ``$SHEER_RECOVERY_DIR``, else
    ``$XDG_STATE_HOME/sheer/recovery`` (default ``~/.local/state/sheer/recovery``).
    """
    env = os.environ.get("SHEER_RECOVERY_DIR")
    if env:
        return Path(env).expanduser()
    state = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(state) / "sheer" / "recovery"


def _beside(project_path: Path) -> Path:
    return project_path.with_name(f".{project_path.name}{RECOVERY_SUFFIX}")


def _central(project_path: Path) -> Path:
    digest = hashlib.sha256(str(project_path.absolute()).encode()).hexdigest()[:12]
    return recovery_dir() / f"{digest}-{project_path.name}{RECOVERY_SUFFIX}"


def recovery_candidates(project_path: str | Path) -> list[Path]:
    """Where the recovery file of ``project_path`` may be, in order of preference."""
    p = Path(project_path).absolute()
    return [_beside(p), _central(p)]


def recovery_path(project_path: str | Path | None, session_id: str | None = None) -> Path:
    """The recovery file autosave writes for ``project_path`` (None: an untitled project)."""
    if project_path is None:
        return recovery_dir() / f"untitled-{session_id or _session_id()}{RECOVERY_SUFFIX}"
    p = Path(project_path).absolute()
    beside = _beside(p)
    return beside if os.access(p.parent, os.W_OK) else _central(p)


def _session_id() -> str:
    return f"{os.getpid()}-{int(time.time())}"


@dataclass
class RecoveryInfo:
    """A recovery file found on disk.

    Attributes:
        path: the recovery file.
        original: the project file it belongs to (None for untitled work).
        saved_at: UTC time of the autosave (ISO 8601).
        pid: the process that wrote it; ``owner_alive`` is True when that process still runs (then
            it is another open studio's live autosave, not a crash: do not offer it).
        newer_than_original: the autosave is more recent than the project file (or there is none).
        error: why the file cannot be recovered (damaged), or None.
    """

    path: Path
    original: Path | None
    saved_at: str
    pid: int
    owner_alive: bool
    newer_than_original: bool
    error: str | None = None


def _pid_alive(pid: int) -> bool:
    if pid <= 0 or pid == os.getpid():
        return pid == os.getpid()
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def _info(path: Path) -> RecoveryInfo:
    from project.io import open_project

    try:
        project = open_project(path, verify_head=False)
    except ProjectError as exc:
        return RecoveryInfo(path, None, "", 0, False, True, str(exc))
    block = project.recovery or {}
    original = Path(block["original"]) if block.get("original") else None
    newer = True
    if original is not None and original.exists():
        newer = path.stat().st_mtime >= original.stat().st_mtime
    pid = int(block.get("pid", 0))
    return RecoveryInfo(path, original, str(block.get("saved_at", "")), pid, _pid_alive(pid), newer)


def autosave(project: object, project_path: str | Path | None, *, session_id: str | None = None) -> Path:
    """Write ``project`` (a :class:`project.io.Project`) to its recovery file, atomically.

    The project object is not modified. Returns the recovery file's path.
    """
    from project.io import Project, save_project

    assert isinstance(project, Project)
    target = recovery_path(project_path, session_id)
    target.parent.mkdir(parents=True, exist_ok=True)
    snapshot = replace(project, recovery={
        "original": None if project_path is None else str(Path(project_path).absolute()),
        "saved_at": datetime.now(UTC).isoformat(timespec="seconds"),
        "pid": os.getpid(),
    })
    save_project(snapshot, target, keep_backup=False, clear_recovery=False)
    return target


def find_recovery(project_path: str | Path) -> RecoveryInfo | None:
    """The recovery file left for ``project_path`` by a session that did not end normally, or None."""
    for candidate in recovery_candidates(project_path):
        if candidate.is_file():
            return _info(candidate)
    return None


def list_recoveries() -> list[RecoveryInfo]:
    """Every recovery file in :func:`recovery_dir` (untitled work and unwritable folders), newest first."""
    folder = recovery_dir()
    if not folder.is_dir():
        return []
    found = [_info(p) for p in folder.glob(f"*{RECOVERY_SUFFIX}") if p.is_file()]
    return sorted(found, key=lambda info: info.saved_at, reverse=True)


def recover(info: RecoveryInfo | str | Path, **open_kwargs: object) -> object:
    """Open a recovery file as a project (``source_path`` = the original file, or None when untitled).

    The recovery file is left in place until the recovered project is saved (which removes it) or
    :func:`discard_recovery` is called. ``open_kwargs`` go to :func:`project.io.open_project`
    (``head_path=`` to relink, ``accept_head_change=True``).
    """
    from project.io import open_project

    path = info.path if isinstance(info, RecoveryInfo) else Path(info)
    project = open_project(path, **open_kwargs)  # type: ignore[arg-type]
    block = project.recovery or {}
    project.recovery = None
    project.source_path = Path(block["original"]) if block.get("original") else None
    return project


def discard_recovery(project_path: str | Path | None, session_id: str | None = None) -> None:
    """Remove the recovery file(s) of ``project_path`` (or of an untitled session)."""
    paths = (recovery_candidates(project_path) if project_path is not None
             else [recovery_path(None, session_id)] if session_id else [])
    for p in paths:
        with contextlib.suppress(FileNotFoundError):
            p.unlink()


class Autosaver:
    """Periodic autosave driven by the caller's clock (a ``QTimer`` in the studio, a loop in tests).

    Args:
        snapshot: returns the current :class:`project.io.Project` (called only when saving).
        project_path: the project's file, or None while untitled.
        interval_s: seconds between autosaves of unsaved changes.
        clock: monotonic time source in seconds (tests inject a fake one).
    """

    def __init__(self, snapshot: Callable[[], object], project_path: str | Path | None = None,
                 interval_s: float = DEFAULT_AUTOSAVE_INTERVAL_S,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if not interval_s > 0:
            raise ValueError(f"autosave interval must be positive, got {interval_s}")
        self.snapshot = snapshot
        self.project_path = None if project_path is None else Path(project_path).absolute()
        self.interval_s = float(interval_s)
        self.clock = clock
        self.session_id = _session_id()
        self.dirty = False
        self.last_autosave: Path | None = None
        self._last = clock()

    def mark_dirty(self) -> None:
        """Record that the project changed since it was last saved (connect to the document's events)."""
        self.dirty = True

    def watch(self, doc: object) -> Callable[[], None]:
        """Mark dirty on every change event of a ``painting.Document`` (paint, layers, material);
        returns the unsubscribe function.
        """

        def on_event(event: object) -> None:
            if getattr(event, "kind", "") != "history":
                self.dirty = True

        return doc.subscribe(on_event)  # type: ignore[attr-defined]

    def due(self) -> bool:
        """Unsaved changes and at least ``interval_s`` since the last save or autosave."""
        return self.dirty and self.clock() - self._last >= self.interval_s

    def tick(self) -> Path | None:
        """Call periodically; autosaves when :meth:`due`. Returns the recovery file when it wrote one."""
        return self.autosave_now() if self.due() else None

    def autosave_now(self, project: object | None = None) -> Path:
        """Write the recovery file now, of ``project`` or else of ``snapshot()``.

        Writing a large project takes a moment (about 1 s for four 2048² layers): the studio can take
        the snapshot on the UI thread when :meth:`due` (``Project.from_document`` copies the maps) and
        pass it to this method on a worker thread.
        """
        path = autosave(self.snapshot() if project is None else project, self.project_path,
                        session_id=self.session_id)
        self.last_autosave = path
        self.dirty = False
        self._last = self.clock()
        return path

    def saved(self, project_path: str | Path) -> None:
        """After a normal save to ``project_path``: remove every recovery file of this session."""
        self._discard()
        self.project_path = Path(project_path).absolute()
        self._discard()
        self.dirty = False
        self._last = self.clock()

    def close(self) -> None:
        """A normal close (after the user saved or chose to discard changes): remove the recovery file."""
        self._discard()
        self.dirty = False

    def _discard(self) -> None:
        if self.project_path is not None:
            discard_recovery(self.project_path)
        discard_recovery(None, self.session_id)
        self.last_autosave = None


def stale_temporaries(project_path: str | Path, min_age_s: float = 60.0) -> list[Path]:
    """Temporary files an interrupted save of ``project_path`` left beside it (``.<name>.*.tmp``)
    that are older than ``min_age_s`` seconds (a save in progress is never that old).
    """
    p = Path(project_path).absolute()
    now = time.time()
    found = []
    for candidate in p.parent.glob(f".{p.name}.*.tmp"):
        with contextlib.suppress(OSError):
            if candidate.is_file() and not candidate.is_symlink() and now - candidate.stat().st_mtime >= min_age_s:
                found.append(candidate)
    return sorted(found)


def remove_stale_temporaries(project_path: str | Path, min_age_s: float = 60.0) -> int:
    """Remove :func:`stale_temporaries`; returns how many were removed."""
    removed = 0
    for candidate in stale_temporaries(project_path, min_age_s):
        with contextlib.suppress(OSError):
            candidate.unlink()
            removed += 1
    return removed
