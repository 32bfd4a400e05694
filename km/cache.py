"""The spectral → linear sRGB matrix, cached on disk (colour-science is imported only to make it).

The folder is :func:`core.cache.cache_dir`; :func:`spectral_rgb_matrix_cached` is the
spectral → linear sRGB matrix of :func:`km.colour.spectral_rgb_matrix` kept on disk, so that a process
which only needs the matrix (the renderer's texture-space pass) never imports colour-science: importing it
pulls in matplotlib through ``colour.plotting`` and took 1.5–6 s of the studio's start-up on this
project's machine. A missing, unreadable or malformed cache file is made again; failing to write one is
not an error (the cache is an optimisation only).
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import os
from typing import TYPE_CHECKING

import numpy as np

from core.cache import cache_dir, entry_exists, load_array, save_array

if TYPE_CHECKING:
    from pathlib import Path

    from numpy.typing import ArrayLike

#: bump when the cached matrices' definition changes
_MATRIX_CACHE_VERSION = 1
#: matrices already read or made in this process, by (grid bytes, illuminant, transform, cache folder)
_IN_MEMORY: dict[tuple[bytes, str, str, str], np.ndarray] = {}


@functools.lru_cache(maxsize=1)
def _colour_science_version() -> str:
    try:  # read from the installed metadata (about 10 ms: once per process)
        return importlib.metadata.version("colour-science")
    except importlib.metadata.PackageNotFoundError:
        return "none"


def _matrix_path(wl: np.ndarray, illuminant: str, cat: str) -> Path:
    version = _colour_science_version()
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(wl, dtype="<f8").tobytes())
    h.update(f"|{illuminant}|{cat}|colour-science {version}|v{_MATRIX_CACHE_VERSION}".encode())
    return cache_dir("colour") / f"rgb-{h.hexdigest()[:32]}.cache"


def spectral_rgb_matrix_ready(wavelengths: ArrayLike, illuminant: str = "D65", cat: str = "CAT02") -> bool:
    """Whether :func:`spectral_rgb_matrix_cached` would answer without colour-science.

    True when the matrix is in this process already or its cache file exists.
    """
    wl = np.asarray(wavelengths, dtype=np.float64)
    memo = (wl.tobytes(), illuminant, cat, os.environ.get("SHEER_CACHE_DIR", ""))
    return memo in _IN_MEMORY or entry_exists(_matrix_path(wl, illuminant, cat))


def spectral_rgb_matrix_cached(wavelengths: ArrayLike, illuminant: str = "D65", cat: str = "CAT02") -> np.ndarray:
    """:func:`km.colour.spectral_rgb_matrix` for ``wavelengths`` (nm), through the disk cache.

    Read from the cache when it is there (keyed by the grid, the illuminant, the adaptation transform
    and colour-science's version) and written to it otherwise. Returns a read-only float64
    (n_wavelengths, 3) array.
    """
    wl = np.asarray(wavelengths, dtype=np.float64)
    memo = (wl.tobytes(), illuminant, cat, os.environ.get("SHEER_CACHE_DIR", ""))
    hit = _IN_MEMORY.get(memo)
    if hit is not None:
        return hit
    path = _matrix_path(wl, illuminant, cat)
    m = load_array(path, _MATRIX_CACHE_VERSION)
    if m is not None and m.shape == (wl.size, 3) and m.dtype == np.float64 and np.all(np.isfinite(m)):
        m.setflags(write=False)
        _IN_MEMORY[memo] = m
        return m
    from km.colour import spectral_rgb_matrix

    m = np.array(spectral_rgb_matrix(wl, illuminant, cat), dtype=np.float64)
    save_array(path, m, _MATRIX_CACHE_VERSION)
    m.setflags(write=False)
    _IN_MEMORY[memo] = m
    return m
