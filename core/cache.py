"""The cache folder: where Sheer keeps derived data that is expensive to make and cheap to make again.

:func:`cache_dir` is the one place that decides where caches live; :func:`save_array` writes one cached
array. A cache is an optimisation only: failing to write one is never an error, and a missing or damaged
cache file is made again by whoever reads it.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from core.atomicio import atomic_write_bytes


def cache_dir(kind: str) -> Path:
    """The folder of one kind of cache (``kind``: e.g. "atlas", "colour").

    ``$SHEER_CACHE_DIR/<kind>``, else ``$XDG_CACHE_HOME/sheer/<kind>`` (default ``~/.cache/sheer/<kind>``).
    """
    env = os.environ.get("SHEER_CACHE_DIR")
    if env:
        return Path(env).expanduser() / kind
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "sheer" / kind


def save_array(path: Path, array: np.ndarray) -> None:
    """Write ``array`` to the cache file ``path`` (``.npy``) atomically, making its folder.

    Failing to write is not an error (a cache is an optimisation only).
    """
    try:
        buf = io.BytesIO()
        np.save(buf, array, allow_pickle=False)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, buf.getvalue())
    except OSError:
        pass
