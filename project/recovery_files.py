"""Where crash-recovery files live, and removing them; the temporaries an interrupted save leaves.

A project's recovery file (an autosave, see :mod:`project.recovery`) is ``.<name>.<pid>.recovery`` beside
the project, or, when the project has no file yet or its folder is not writable, a file in
:func:`recovery_dir`. Each process writes its own (the process id is in the name), so two studios with
one project open never overwrite each other's autosave. A normal save (:func:`project.io.save_project`)
calls :func:`discard_recovery`, which removes this process's file. This module only names and removes
files: it reads none.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import time
from pathlib import Path

from core.locks import process_alive

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


def _beside(project_path: Path, pid: int | None = None) -> Path:
    """``.<name>.<pid>.recovery`` in the project's folder (``pid``: this process by default)."""
    return project_path.with_name(f".{project_path.name}.{os.getpid() if pid is None else pid}{RECOVERY_SUFFIX}")


def _central(project_path: Path, pid: int | None = None) -> Path:
    """``<hash of the absolute path>-<pid>-<name>.recovery`` in :func:`recovery_dir`."""
    digest = hashlib.sha256(str(project_path.absolute()).encode()).hexdigest()[:12]
    return recovery_dir() / f"{digest}-{os.getpid() if pid is None else pid}-{project_path.name}{RECOVERY_SUFFIX}"


def recovery_candidates(project_path: str | Path) -> list[Path]:
    """Every recovery file of ``project_path`` on disk, of any process: beside it first, then central ones.

    Also the one file an older Sheer wrote for every process (``.<name>.recovery``) when it is there.
    """
    p = Path(project_path).absolute()
    beside = sorted(p.parent.glob(f".{_glob_escape(p.name)}.*{RECOVERY_SUFFIX}"))
    legacy = p.with_name(f".{p.name}{RECOVERY_SUFFIX}")
    central = sorted(recovery_dir().glob(f"{_central(p, 0).name.split('-')[0]}-*-{_glob_escape(p.name)}"
                                         f"{RECOVERY_SUFFIX}"))
    own = [q for q in beside if q.name[len(p.name) + 2:-len(RECOVERY_SUFFIX)].isdigit()]
    return own + ([legacy] if legacy.is_file() else []) + central


def _glob_escape(name: str) -> str:
    """``name`` with glob's special characters taken literally."""
    return "".join(f"[{c}]" if c in "*?[]" else c for c in name)


def recovery_path(project_path: str | Path | None, session_id: str | None = None) -> Path:
    """The recovery file autosave writes for ``project_path`` in this process.

    Beside the project when its folder is writable, else in :func:`recovery_dir`; for an untitled
    project (``project_path`` None) ``untitled-<session_id>.recovery`` in :func:`recovery_dir` (the
    session id starts with the process id).
    """
    if project_path is None:
        return recovery_dir() / f"untitled-{session_id or new_session_id()}{RECOVERY_SUFFIX}"
    p = Path(project_path).absolute()
    return _beside(p) if os.access(p.parent, os.W_OK) else _central(p)


def _owner(recovery_file: Path) -> int:
    """The process id in a recovery file's name (0 for an older Sheer's shared file)."""
    name = recovery_file.name.removesuffix(RECOVERY_SUFFIX)
    if recovery_file.name.startswith("."):
        tail = name.rsplit(".", 1)[-1]
    else:
        tail = name.split("-")[1] if name.count("-") >= 2 else ""
    return int(tail) if tail.isdigit() else 0


def new_session_id() -> str:
    """An id for one studio session's untitled recovery file: ``<process id>-<Unix time, s>``."""
    return f"{os.getpid()}-{int(time.time())}"


def discard_recovery(project_path: str | Path | None, session_id: str | None = None, *,
                     ended: bool = True) -> None:
    """Remove this process's recovery file(s) of ``project_path`` (or of an untitled session).

    With ``ended`` (a save of ``project_path``), those of processes that ended (crashed: their work is in
    the project just saved) and the file an older Sheer shared between processes (``.<name>.recovery``) go
    too; without it (a window closing, or showing another project) they stay, to be offered again (the
    user may have answered "Later"). The autosave of a process that still runs (a second studio's unsaved
    work) is always left alone.
    """
    paths: list[Path] = []
    if project_path is not None:
        p = Path(project_path).absolute()
        paths = [_beside(p), _central(p)]
        if ended:
            paths += [q for q in recovery_candidates(p) if not process_alive(_owner(q))]
    elif session_id:
        paths = [recovery_path(None, session_id)]
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
