"""The cache folder and its one policy: where derived data lives, how big it may grow, what is evicted.

Every kind of cache (:data:`KINDS`: atlas bakes, texel indexes, UV layouts, looks, render data, colour
matrices, parsed meshes) lives in one folder per kind under :func:`cache_root` and goes through
:func:`save_arrays` / :func:`load_arrays` (or the one-array :func:`save_array` / :func:`load_array`):

- **One format with a check** (:mod:`core.cache_entry`): every entry carries its caller's version key
  and an XXH3-64 checksum of its bytes. An entry that fails to load (truncated, wrong version, a flipped bit) is
  deleted with one log line and the caller makes it again; never a crash, never a wrong result.
- **Atomic writes**: a temporary file in the same folder renamed over the entry, so processes sharing
  the cache (the studio and a catalogue worker) never read half an entry. No fsync: a power cut can
  leave a short file, which the length and checksum checks refuse.
- **A size cap** (:func:`cache_cap`): ``$SHEER_CACHE_MAX_MB``, else the studio's setting
  (:func:`set_configured_max_mb`), else 10 % of the free space of the cache's file system, at most
  2 GiB. Enforced at write time by evicting the least recently used entries (reading an entry marks it
  used); an entry larger than the cap is not kept at all.
- **Private caches** (:class:`PrivateCache`): data derived from a shopper's face is never written to
  the shared cache. While one is open, every write of this process goes to a temporary folder (mode
  0700) removed when it closes; reads fall back to the shared cache, which the private session never
  changes.
- **Code in the key** (:func:`source_digest`): a cache whose entries are computed by code (a look's painted
  maps, derived regions, a mask recipe's values) puts a digest of that code's source files in its keys.

A cache is an optimisation only: failing to write an entry is never an error.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import logging
import math
import os
import shutil
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from core.cache_entry import DamagedEntry, read_entry, write_entry
from core.locks import process_alive, process_token

if TYPE_CHECKING:
    from collections.abc import Iterable, Mapping

    import numpy as np

log = logging.getLogger("sheer.cache")

#: The kinds of cache, one folder each under :func:`cache_root`.
KINDS: tuple[str, ...] = ("atlas", "index", "layout", "looks", "render", "colour", "mesh")
#: The automatic cap never exceeds this many bytes (2 GiB).
DEFAULT_MAX_BYTES = 2 * 1024**3
#: The automatic cap: this fraction of the free space of the cache's file system (plus the cache itself).
DEFAULT_FREE_FRACTION = 0.10
#: The environment variable that sets the cap, in MiB (0: keep nothing).
ENV_MAX_MB = "SHEER_CACHE_MAX_MB"
#: A writer's temporary file older than this (s) was left by a crash and is deleted by the next scan.
STALE_TEMP_SECONDS = 3600.0
_MIB = 1024 * 1024

#: The cap from the studio's settings, in MiB (None: automatic); see :func:`set_configured_max_mb`.
_configured_max_mb: float | None = None
#: Open private caches, innermost last: (private root, the shared root it reads through to).
_PRIVATE: list[tuple[Path, Path]] = []
#: Private roots already closed: nothing is ever written under them again.
_CLOSED: set[Path] = set()
_warned_env: set[str] = set()
#: (cache folder, errno) of write failures already warned about: one warning each per process.
_warned_write: set[tuple[str, int | None]] = set()


# ---------------------------------------------------------------------------------------------- where


def shared_root() -> Path:
    """The shared cache folder: ``$SHEER_CACHE_DIR``, else ``$XDG_CACHE_HOME/sheer`` (``~/.cache/sheer``)."""
    if _PRIVATE:
        return _PRIVATE[0][1]
    env = os.environ.get("SHEER_CACHE_DIR")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "sheer"


def cache_root() -> Path:
    """The folder caches are written to now: the open private cache's, else :func:`shared_root`."""
    return _PRIVATE[-1][0] if _PRIVATE else shared_root()


def cache_dir(kind: str) -> Path:
    """The folder of one kind of cache (``kind``: one of :data:`KINDS`) under :func:`cache_root`."""
    return cache_root() / kind


def _under(path: Path, root: Path) -> bool:
    return Path(os.path.abspath(path)).is_relative_to(os.path.abspath(root))


def _write_target(path: Path) -> Path | None:
    """Where a write of ``path`` goes: its private twin while a private cache is open; None when refused."""
    if any(_under(path, closed) for closed in _CLOSED):
        return None  # a private session's entry after the session ended: never written again
    if _PRIVATE:
        private, shared = _PRIVATE[-1]
        if not _under(path, private):
            if not _under(path, shared):
                return None  # outside every cache: refuse rather than risk a shopper's data escaping
            return private / Path(os.path.abspath(path)).relative_to(os.path.abspath(shared))
    return path


def _read_candidates(path: Path) -> list[Path]:
    """``path``, then (inside an open private cache) the same entry in the shared cache."""
    out = [path]
    for private, shared in reversed(_PRIVATE):
        if _under(path, private):
            out.append(shared / Path(os.path.abspath(path)).relative_to(os.path.abspath(private)))
            break
    return out


# ---------------------------------------------------------------------------------------------- policy


@dataclass(frozen=True)
class CacheCap:
    """The cache's size cap.

    Attributes:
        bytes: the cap in bytes (≥ 0).
        source: where it comes from: ``SHEER_CACHE_MAX_MB``, ``settings`` or ``automatic (…)``.
    """

    bytes: int
    source: str


def set_configured_max_mb(max_mb: float | None) -> None:
    """The cap from the studio's settings in MiB (None or 0: automatic); ``SHEER_CACHE_MAX_MB`` wins over it.

    Raises:
        ValueError: ``max_mb`` is negative or not finite.
    """
    global _configured_max_mb
    if max_mb is not None and (not math.isfinite(max_mb) or max_mb < 0):
        raise ValueError(f"cache cap must be a number of MiB ≥ 0, got {max_mb!r}")
    _configured_max_mb = float(max_mb) if max_mb else None


def _env_max_mb() -> float | None:
    raw = os.environ.get(ENV_MAX_MB, "").strip()
    if not raw:
        return None
    try:
        value = float(raw)
    except ValueError:
        value = float("nan")
    if math.isfinite(value) and value >= 0:
        return value
    if raw not in _warned_env:
        _warned_env.add(raw)
        log.warning("%s=%r is not a number of MiB ≥ 0; ignored (using the settings or the automatic cap)",
                    ENV_MAX_MB, raw)
    return None


def _free_bytes(root: Path) -> int:
    probe = Path(os.path.abspath(root))
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    try:
        return shutil.disk_usage(probe).free
    except OSError:
        return 0


def cache_cap(root: Path | None = None, cached_bytes: int | None = None) -> CacheCap:
    """The cap of the cache at ``root`` (default :func:`cache_root`).

    Args:
        root: the cache folder (its file system decides the automatic cap).
        cached_bytes: the cache's current size in bytes, if known (else it is measured).
    """
    env = _env_max_mb()
    if env is not None:
        return CacheCap(int(env * _MIB), ENV_MAX_MB)
    if _configured_max_mb is not None:
        return CacheCap(int(_configured_max_mb * _MIB), "settings")
    root = root or cache_root()
    if cached_bytes is None:
        cached_bytes = sum(e.size for e in entries(root))
    share = int(DEFAULT_FREE_FRACTION * (_free_bytes(root) + cached_bytes))
    return CacheCap(min(DEFAULT_MAX_BYTES, share),
                    f"automatic ({DEFAULT_FREE_FRACTION:.0%} of free space, at most {DEFAULT_MAX_BYTES // _MIB} MiB)")


@dataclass(frozen=True)
class CacheEntry:
    """One entry on disk.

    Attributes:
        path: the entry (a file; a folder for entries of Sheer versions before this format).
        kind: its kind (its folder's name).
        size: bytes on disk.
        mtime: when it was last written or read (s since the epoch): the LRU order.
    """

    path: Path
    kind: str
    size: int
    mtime: float


def _tree_bytes(folder: str) -> int:
    total = 0
    for dirpath, _dirs, files in os.walk(folder):
        for f in files:
            with contextlib.suppress(OSError):
                total += os.lstat(os.path.join(dirpath, f)).st_size
    return total


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()


def entries(root: Path | None = None, kind: str | None = None) -> list[CacheEntry]:
    """Every entry under ``root`` (default :func:`cache_root`), of one ``kind`` or all.

    Writers' temporary files are not entries; those older than :data:`STALE_TEMP_SECONDS` (left by a
    crashed process) are deleted on the way.
    """
    root = root or cache_root()
    now = time.time()
    out: list[CacheEntry] = []
    try:
        kinds = [d for d in os.scandir(root) if d.is_dir(follow_symlinks=False) and not d.name.startswith(".")]
    except OSError:
        return out
    for kd in kinds:
        if kind is not None and kd.name != kind:
            continue
        try:
            items = list(os.scandir(kd.path))
        except OSError:
            continue
        for item in items:
            try:
                st = item.stat(follow_symlinks=False)
            except OSError:
                continue  # removed meanwhile (another process evicting)
            if item.name.startswith("."):
                if now - st.st_mtime > STALE_TEMP_SECONDS:
                    _remove(Path(item.path))
                continue
            size = _tree_bytes(item.path) if item.is_dir(follow_symlinks=False) else st.st_size
            out.append(CacheEntry(Path(item.path), kd.name, size, st.st_mtime))
    return out


def evict(keep: Path | None = None, root: Path | None = None) -> int:
    """Delete least-recently-used entries until the cache at ``root`` fits its cap; never ``keep``.

    Returns:
        The number of bytes freed.
    """
    root = root or cache_root()
    found = entries(root)
    total = sum(e.size for e in found)
    cap = cache_cap(root, total).bytes
    if total <= cap:
        return 0
    freed = removed = 0
    keep_abs = os.path.abspath(keep) if keep is not None else None
    for e in sorted(found, key=lambda e: e.mtime):
        if total - freed <= cap:
            break
        if keep_abs is not None and os.path.abspath(e.path) == keep_abs:
            continue
        _remove(e.path)
        freed += e.size
        removed += 1
    log.info("cache %s: evicted %d least recently used entries (%.1f MiB) to stay within %.1f MiB",
             root, removed, freed / _MIB, cap / _MIB)
    return freed


def clear(kind: str | None = None, root: Path | None = None) -> tuple[int, int]:
    """Delete every entry (of one ``kind``, or all) under ``root`` (default :func:`cache_root`).

    Returns:
        (entries removed, bytes freed).
    """
    found = entries(root, kind)
    for e in found:
        _remove(e.path)
    return len(found), sum(e.size for e in found)


# ---------------------------------------------------------------------------------------------- entries


def save_arrays(path: Path, arrays: Mapping[str, Any], version: int | str = 0, compress: bool = False) -> bool:
    """Write the entry ``path`` (``<root>/<kind>/<name>``) holding ``arrays``, atomically, then evict.

    Args:
        path: the entry, normally ``cache_dir(kind) / name``.
        arrays: name → array (no object dtypes).
        version: the caller's version key; :func:`load_arrays` refuses an entry of another.
        compress: deflate the entry (for sparse data: thickness maps); reading inflates it.

    Returns:
        Whether the entry was written (False on any failure, for an entry larger than the cap, and for
        a path outside the open private cache or under a closed one: a cache is an optimisation only).
    """
    target = _write_target(path)
    if target is None:
        log.debug("cache: not writing %s (outside the private cache, or after it closed)", path)
        return False
    root = target.parent.parent
    tmp: str | None = None
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
        with os.fdopen(fd, "wb") as fh:
            size = write_entry(fh, arrays, version, compress)
        cap = cache_cap(root)
        if size > cap.bytes:
            log.info("cache: %s (%.1f MiB) is larger than the cap (%.1f MiB, %s); not kept",
                     target.name, size / _MIB, cap.bytes / _MIB, cap.source)
            return False
        os.replace(tmp, target)
        tmp = None
    except OSError as exc:
        _write_failed(target, root, exc)
        return False
    except (TypeError, ValueError) as exc:
        log.debug("cache: could not write %s (%s)", target, exc)
        return False
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
    evict(keep=target, root=root)
    return True


def _write_failed(target: Path, root: Path, exc: OSError) -> None:
    """Say once per cache folder and cause (a full disk, a read-only folder) that entries cannot be written.

    One warning line naming the entry and the reason; the same failure again (every later entry on a full
    disk) is logged at debug level only. Nothing else happens: the caller computes what it needed.
    """
    key = (os.path.abspath(root), exc.errno)
    reason = exc.strerror or str(exc)
    if key in _warned_write:
        log.debug("cache: could not write %s (%s)", target, reason)
        return
    _warned_write.add(key)
    log.warning("cache: cannot write %s: %s (carrying on without caching)", target, reason)


def load_arrays(path: Path, version: int | str = 0) -> dict[str, np.ndarray] | None:
    """The arrays of the entry ``path``, or None when it is absent or damaged.

    A damaged entry (truncated, of another version, failing its checksum) is deleted with one warning and
    None is returned, so the caller makes it again. Reading marks the entry most recently used.
    """
    for i, candidate in enumerate(_read_candidates(path)):
        try:
            with open(candidate, "rb") as fh:
                arrays = read_entry(fh, os.fstat(fh.fileno()).st_size, version)
        except (FileNotFoundError, NotADirectoryError, IsADirectoryError):
            continue
        except OSError as exc:
            log.debug("cache: could not read %s (%s)", candidate, exc)
            continue
        except (DamagedEntry, ValueError, TypeError) as exc:  # (numpy refusing a header that passed its checks)
            if i == 0:  # (the shared cache is left alone while a private one is open)
                log.warning("cache: %s was damaged (%s); deleted, it will be made again", candidate, exc)
                _remove(candidate)
            continue
        if i == 0:
            with contextlib.suppress(OSError):
                os.utime(candidate)  # most recently used: evicted last
        return arrays
    return None


def entry_exists(path: Path) -> bool:
    """Whether the entry ``path`` is on disk (in the shared cache too, while a private one is open); unchecked."""
    return any(p.is_file() for p in _read_candidates(path))


def save_array(path: Path, array: np.ndarray, version: int | str = 0) -> bool:
    """:func:`save_arrays` of one array (stored as ``"data"``)."""
    return save_arrays(path, {"data": array}, version)


def load_array(path: Path, version: int | str = 0) -> np.ndarray | None:
    """The array :func:`save_array` stored at ``path``, or None (see :func:`load_arrays`)."""
    arrays = load_arrays(path, version)
    return None if arrays is None or "data" not in arrays else arrays["data"]


# ---------------------------------------------------------------------------------------------- code digests


def source_digest(files: Iterable[str | os.PathLike[str]]) -> str:
    """A SHA-256 hex digest (64 characters) of the source files that compute a cached value, for its key.

    A cache whose entries are made by code puts this in its key, so an entry is never reused after that
    code changed (e.g. a look's painted maps after a change of the stroke engine). Each file counts by
    its name (not its folder), its length and its bytes, in the order given; a missing file (a
    bytecode-only install) counts as its name and a marker, so the digest still exists.

    Memoised per list of files for the life of the process: the code that runs is the code that was
    imported, so later edits of the files on disk are not seen (:func:`forget_source_digests` forgets,
    for tests).

    Args:
        files: The source files, usually beside the caller (``Path(__file__).with_name("mask.py")``).

    Returns:
        The hex digest.
    """
    return _source_digest(tuple(os.fspath(f) for f in files))


@functools.cache
def _source_digest(files: tuple[str, ...]) -> str:
    h = hashlib.sha256()
    for name in files:
        path = Path(name)
        try:
            data = path.read_bytes()
        except OSError:
            h.update(f"{path.name}|-|".encode())
            continue
        h.update(f"{path.name}|{len(data)}|".encode())
        h.update(data)
    return h.hexdigest()


def forget_source_digests() -> None:
    """Forget the memoised :func:`source_digest` results (for tests that edit a source file)."""
    _source_digest.cache_clear()


# ---------------------------------------------------------------------------------------------- private


class PrivateCache:
    """A temporary cache for data derived from a shopper's face, removed when it closes.

    While open (:meth:`open` … :meth:`close`, or ``with PrivateCache() as root:``) every cache write of
    this process goes under :attr:`root` (a fresh folder of mode 0700 in the temporary directory), and
    ``$SHEER_CACHE_DIR`` points there for child processes; reads fall back to the shared cache. Closing
    deletes the folder and refuses any later write under it (an object that kept an entry's path).

    The folder's name carries its process (``sheer-private-cache-<pid>-<start>-XXXXXXXX``, see
    :func:`core.locks.process_token`), so one a killed kiosk left is known as such: making a
    ``PrivateCache`` (the kiosk does at start) removes those of processes that no longer run
    (:func:`sweep_private_caches`).
    """

    def __init__(self, sweep: bool = True) -> None:
        self.root: Path | None = None
        self._env: str | None = None
        if sweep:
            sweep_private_caches()

    @property
    def is_open(self) -> bool:
        """Whether the private cache is open."""
        return self.root is not None

    def open(self) -> Path:
        """Open the private cache (once); returns its folder."""
        if self.root is not None:
            return self.root
        shared = shared_root()
        self.root = Path(tempfile.mkdtemp(prefix=f"{PRIVATE_PREFIX}{os.getpid()}-{process_token()}-"))
        self._env = os.environ.get("SHEER_CACHE_DIR")
        _PRIVATE.append((self.root, shared))
        os.environ["SHEER_CACHE_DIR"] = str(self.root)
        log.info("cache: private session cache opened")
        return self.root

    def close(self) -> None:
        """Delete the private cache's folder and everything in it; later writes there are refused."""
        if self.root is None:
            return
        root, self.root = self.root, None
        _CLOSED.add(root)
        _PRIVATE[:] = [p for p in _PRIVATE if p[0] != root]
        if self._env is None:
            os.environ.pop("SHEER_CACHE_DIR", None)
        else:
            os.environ["SHEER_CACHE_DIR"] = self._env
        shutil.rmtree(root, ignore_errors=True)
        log.info("cache: private session cache removed")

    def __enter__(self) -> Path:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()


#: The name of every private cache folder starts so (then ``<pid>-<process token>-``).
PRIVATE_PREFIX = "sheer-private-cache-"


def _private_owner(folder: Path) -> tuple[int, str] | None:
    """The process id and token in a private folder's name, or None when it carries none."""
    parts = folder.name.removeprefix(PRIVATE_PREFIX).split("-")
    if len(parts) < 3 or not parts[0].isdigit():
        return None
    return int(parts[0]), parts[1]


#: Seconds after its last write that a private folder whose name carries no process is removed (1 day):
#: an older Sheer named them ``sheer-private-cache-XXXXXXXX``, so whether their kiosk still runs is unknown.
UNOWNED_PRIVATE_MAX_AGE_S = 86400.0


def _last_written(folder: Path) -> float:
    """The newest modification time (Unix time, s) of ``folder`` and of everything under it."""
    newest = folder.lstat().st_mtime
    for dirpath, dirnames, filenames in os.walk(folder):
        for name in (*dirnames, *filenames):
            with contextlib.suppress(OSError):
                newest = max(newest, os.lstat(os.path.join(dirpath, name)).st_mtime)
    return newest


def _private_folder_ended(candidate: Path) -> bool:
    """Whether the session of the private folder ``candidate`` is over.

    Its process no longer runs or, for a name without one (an older Sheer's), nothing in it was written for
    :data:`UNOWNED_PRIVATE_MAX_AGE_S` seconds.
    """
    owner = _private_owner(candidate)
    if owner is not None:
        return not process_alive(*owner)
    return time.time() - _last_written(candidate) >= UNOWNED_PRIVATE_MAX_AGE_S


def sweep_private_caches(folder: Path | None = None) -> list[Path]:
    """Remove the private cache folders (a shopper's photo, mesh, albedo) of sessions that are over.

    A kiosk killed during a session (``kill -9``, a power cut) leaves its folder in the temporary directory
    (``folder``, default ``tempfile.gettempdir()``); a folder whose process still runs (another kiosk's live
    session), or that is not this user's, is never touched. A folder an older Sheer named without its
    process (``sheer-private-cache-XXXXXXXX``) goes once nothing in it was written for a day
    (:data:`UNOWNED_PRIVATE_MAX_AGE_S`). Returns the folders removed.
    """
    base = Path(tempfile.gettempdir()) if folder is None else Path(folder)
    removed = []
    with contextlib.suppress(OSError):
        for candidate in sorted(base.glob(f"{PRIVATE_PREFIX}*")):
            with contextlib.suppress(OSError):
                if (not candidate.is_dir() or candidate.is_symlink() or candidate.stat().st_uid != os.getuid()
                        or not _private_folder_ended(candidate)):
                    continue
                shutil.rmtree(candidate)
                removed.append(candidate)
    if removed:
        log.info("cache: removed %d private folder(s) left by a process that ended", len(removed))
    return removed
