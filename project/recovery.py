"""Autosave and crash recovery (Qt-free: the studio drives :class:`Autosaver` from a timer).

- Every ``interval_s`` seconds (default :data:`DEFAULT_AUTOSAVE_INTERVAL_S`, configurable) a project
  with unsaved changes is written, atomically, to this process's *recovery file*: ``.<name>.<pid>.recovery``
  beside the project, or in :func:`recovery_dir` when the project has no file yet
  (``untitled-<pid>-<time>.recovery``) or its folder is not writable (``<hash>-<pid>-<name>.recovery``). A
  recovery file is an ordinary ``.sheer`` zip whose ``project.json`` has a ``recovery`` block
  (original path, UTC time, process id). Where it goes is :mod:`project.recovery_files`.
- A normal save (:func:`project.io.save_project`) or close (:meth:`Autosaver.close`) removes it.
  So a recovery file that exists when the studio starts means the last session did not end normally:
  offer :func:`find_recovery` (for a file being opened) or :func:`list_recoveries` (all of them,
  including untitled work), then :func:`recover` or
  :func:`project.recovery_files.discard_recovery`.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

from core.locks import process_alive
from project.errors import ProjectError
from project.io import open_project, save_project
from project.recovery_files import (
    RECOVERY_SUFFIX,
    discard_recovery,
    new_session_id,
    recovery_candidates,
    recovery_dir,
    recovery_path,
)

if TYPE_CHECKING:
    from collections.abc import Callable

    from painting.document import ChangeEvent, Document
    from project.model import Project

#: Seconds between autosaves of a project with unsaved changes.
DEFAULT_AUTOSAVE_INTERVAL_S = 180.0


@dataclass
class RecoveryInfo:
    """A recovery file found on disk.

    Attributes:
        path: the recovery file.
        original: the project file it belongs to (None for untitled work).
        saved_at: UTC time of the autosave (ISO 8601).
        pid: the process that wrote it; ``owner_alive`` is True when that process still runs (then
            it is another open studio's live autosave, not a crash: do not offer it). A process that
            has the same id but started later (the id was reused) is not the owner.
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


def _pid_alive(pid: int, written_at: float) -> bool:
    """True when process ``pid`` runs and started before ``written_at`` (Unix time, s); this one included.

    A process that started after its file was written only reuses the id of the one that wrote it.
    """
    if pid == os.getpid():
        return True
    return process_alive(pid, since=written_at)


def _info(path: Path) -> RecoveryInfo:
    """Describe the recovery file at ``path`` (its ``error`` says why when it does not open)."""
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
    alive = _pid_alive(pid, path.stat().st_mtime)
    return RecoveryInfo(path, original, str(block.get("saved_at", "")), pid, alive, newer)


def autosave(project: Project, project_path: str | Path | None, *, session_id: str | None = None) -> Path:
    """Write ``project`` to the recovery file of ``project_path`` (None: untitled), atomically.

    ``session_id`` names an untitled project's file. The project object is not modified. Returns the
    recovery file's path.
    """
    target = recovery_path(project_path, session_id)
    target.parent.mkdir(parents=True, exist_ok=True)
    snapshot = replace(project, recovery={
        "original": None if project_path is None else str(Path(project_path).absolute()),
        "saved_at": datetime.now(UTC).isoformat(timespec="seconds"),
        "pid": os.getpid(),
    })
    # this process's own file: no other writer to wait for
    save_project(snapshot, target, keep_backup=False, clear_recovery=False, lock=False)
    return target


def find_recovery(project_path: str | Path) -> RecoveryInfo | None:
    """A recovery file of ``project_path``, or None: one left by a process that ended first.

    A live process's file (``owner_alive``: another studio's autosave, or this one's) comes only when
    there is none of a dead process.
    """
    found = [_info(c) for c in recovery_candidates(project_path) if c.is_file()]
    found.sort(key=lambda info: info.owner_alive)
    return found[0] if found else None


def list_recoveries() -> list[RecoveryInfo]:
    """Every recovery file in :func:`recovery_dir` (untitled work and unwritable folders), newest first."""
    folder = recovery_dir()
    if not folder.is_dir():
        return []
    found = [_info(p) for p in folder.glob(f"*{RECOVERY_SUFFIX}") if p.is_file()]
    return sorted(found, key=lambda info: info.saved_at, reverse=True)


def recover(info: RecoveryInfo | str | Path, *, head_path: str | Path | None = None,
            accept_head_change: bool = False) -> Project:
    """Open a recovery file as a project (``source_path`` = the original file, or None when untitled).

    The recovery file is left in place until the recovered project is saved (which removes it) or
    :func:`project.recovery_files.discard_recovery` is called. ``head_path`` and
    ``accept_head_change`` relink the head as in :func:`project.io.open_project`.
    """
    path = info.path if isinstance(info, RecoveryInfo) else Path(info)
    project = open_project(path, head_path=head_path, accept_head_change=accept_head_change)
    block = project.recovery or {}
    project.recovery = None
    project.source_path = Path(block["original"]) if block.get("original") else None
    return project


class Autosaver:
    """Periodic autosave driven by the caller's clock (a ``QTimer`` in the studio, a loop in tests).

    Args:
        snapshot: returns the current :class:`project.model.Project` (called only when saving).
        project_path: the project's file, or None while untitled.
        interval_s: seconds between autosaves of unsaved changes.
        clock: monotonic time source in seconds (tests inject a fake one).
    """

    def __init__(self, snapshot: Callable[[], Project], project_path: str | Path | None = None,
                 interval_s: float = DEFAULT_AUTOSAVE_INTERVAL_S,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if not interval_s > 0:
            raise ValueError(f"autosave interval must be positive, got {interval_s}")
        self.snapshot = snapshot
        self.project_path = None if project_path is None else Path(project_path).absolute()
        self.interval_s = float(interval_s)
        self.clock = clock
        self.session_id = new_session_id()
        self.dirty = False
        self.last_autosave: Path | None = None
        self._last = clock()

    def mark_dirty(self) -> None:
        """Record that the project changed since it was last saved (connect to the document's events)."""
        self.dirty = True

    def watch(self, doc: Document) -> Callable[[], None]:
        """Mark dirty on every change event of ``doc`` (paint, layers, material); returns the unsubscribe.

        A "library" event alone (a material no layer uses was edited) changes nothing a project saves.
        """

        def on_event(event: ChangeEvent) -> None:
            if event.kind not in ("history", "library"):
                self.dirty = True

        return doc.subscribe(on_event)

    def due(self) -> bool:
        """Unsaved changes and at least ``interval_s`` since the last save or autosave."""
        return self.dirty and self.clock() - self._last >= self.interval_s

    def tick(self) -> Path | None:
        """Call periodically; autosaves when :meth:`due`. Returns the recovery file when it wrote one."""
        return self.autosave_now() if self.due() else None

    def autosave_now(self, project: Project | None = None) -> Path:
        """Write the recovery file now, of ``project`` or else of ``snapshot()``.

        Writing a large project takes a moment (about 1 s for four 2048² layers): the studio can take
        the snapshot on the UI thread when :meth:`due` (``project_from_document`` copies the maps) and
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
        """Remove this session's recovery files (of the project's file and of its untitled work).

        Another process's (a crashed session's the user kept for later) stay; a save of the project
        (:func:`project.io.save_project`) removes those of processes that ended.
        """
        if self.project_path is not None:
            discard_recovery(self.project_path, ended=False)
        discard_recovery(None, self.session_id)
        self.last_autosave = None
