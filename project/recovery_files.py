"""Where crash-recovery files live, and removing them; the temporaries an interrupted save leaves.

A project's recovery file (an autosave, see :mod:`project.recovery`) is ``.<name>.recovery`` beside the
project, or, when the project has no file yet or its folder is not writable, a file in
:func:`recovery_dir`. A normal save (:func:`project.io.save_project`) calls :func:`discard_recovery`.
This module only names and removes files: it reads none.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import time
from pathlib import Path

#: Suffix of every recovery file.
RECOVERY_SUFFIX = ".recovery"


def recovery_dir() -> Path:
    """The folder of recovery files for untitled projects and unwritable folders.

    ``$SHEER_RECOVERY_DIR``, else ``$XDG_STATE_HOME/sheer/recovery`` (default
    ``~/.local/state/sheer/recovery``).
    """
    env = os.environ.get("SHEER_RECOVERY_DIR")
    if env:
        return Path(env).expanduser()
    state = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(state) / "sheer" / "recovery"


def _beside(project_path: Path) -> Path:
    """``.<name>.recovery`` in the project's folder."""
    return project_path.with_name(f".{project_path.name}{RECOVERY_SUFFIX}")


def _central(project_path: Path) -> Path:
    """``<hash of the absolute path>-<name>.recovery`` in :func:`recovery_dir`."""
    digest = hashlib.sha256(str(project_path.absolute()).encode()).hexdigest()[:12]
    return recovery_dir() / f"{digest}-{project_path.name}{RECOVERY_SUFFIX}"


def recovery_candidates(project_path: str | Path) -> list[Path]:
    """Where the recovery file of ``project_path`` may be, in order of preference."""
    p = Path(project_path).absolute()
    return [_beside(p), _central(p)]


def recovery_path(project_path: str | Path | None, session_id: str | None = None) -> Path:
    """The recovery file autosave writes for ``project_path``.

    Beside the project when its folder is writable, else in :func:`recovery_dir`; for an untitled
    project (``project_path`` None) ``untitled-<session_id>.recovery`` in :func:`recovery_dir`.
    """
    if project_path is None:
        return recovery_dir() / f"untitled-{session_id or new_session_id()}{RECOVERY_SUFFIX}"
    p = Path(project_path).absolute()
    beside = _beside(p)
    return beside if os.access(p.parent, os.W_OK) else _central(p)


def new_session_id() -> str:
    """An id for one studio session's untitled recovery file: ``<process id>-<Unix time, s>``."""
    return f"{os.getpid()}-{int(time.time())}"


def discard_recovery(project_path: str | Path | None, session_id: str | None = None) -> None:
    """Remove the recovery file(s) of ``project_path`` (or of an untitled session)."""
    paths = (recovery_candidates(project_path) if project_path is not None
             else [recovery_path(None, session_id)] if session_id else [])
    for p in paths:
        with contextlib.suppress(FileNotFoundError):
            p.unlink()


def stale_temporaries(project_path: str | Path, min_age_s: float = 60.0) -> list[Path]:
    """Temporary files an interrupted save of ``project_path`` left beside it (``.<name>.*.tmp``).

    Only those older than ``min_age_s`` seconds (a save in progress is never that old), sorted.
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
