"""Compiled (numba) kernels for the brush: the nearest texel, a dab's weights and its compositing.

Each kernel does in one pass over the candidate texels what the numpy reference in
:mod:`painting.stroke` and :mod:`painting.spatial` does in a few dozen array operations, with the same
float32 arithmetic in the same order, so the two paths give bit-identical maps (tested in
``tests/painting/test_kernels.py``). Measured (``sheer bench paint``, 1 cm dabs, shared machine): numpy
~0.15 µs per painted texel plus ~1 ms per dab; the kernels 44–63 ns per texel at 4096² (weights ~12 ns
per candidate, compositing and the 64² tiles saved for undo the rest) plus 0.04–0.12 ms per dab, mostly
Python. That is about five times the bench's floor (a bare pass that reads each texel's position and
writes one value), with warm caches too, so it is not memory-bound. Two restructurings were measured
and not kept, both bit-identical: reading the atlas in map order through 8² UV blocks (1.2–1.3× slower)
and fusing weights and compositing over the cell-sorted index (1.0–1.2× slower).

The numpy path stays the reference and the fallback: it is used when numba is not installed, or when the
environment variable ``SHEER_PAINT_KERNEL=numpy`` is set, or ``painting.kernels.set_enabled(False)``.

Compiled code is cached on disk (``cache=True``, beside this file). :func:`warm_up` starts with a
document's first stroke: on a background thread it imports numba and loads the cache (about 1 s of CPU),
after compiling it in a child process the first time on a machine (25–50 s of CPU on this project's
machine, kept off the caller's GIL); dabs take the numpy path until the kernels are loaded, so the JIT
cost never lands in a dab, and a process that never paints never imports numba.

Units: positions in mesh units, thickness in µm, weights and coverage in [0, 1].
"""

from __future__ import annotations

import atexit
import contextlib
import hashlib
import importlib.metadata
import importlib.util
import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np

from painting.tiles import TILE, tile_of

#: numba is a dependency; the numpy reference path keeps painting usable without it. It is imported only
#: by the warm-up thread (importing it takes most of a second: never on the caller's start-up path).
HAVE_NUMBA = importlib.util.find_spec("numba") is not None

#: Composite modes understood by :func:`composite` (smooth and fill are not per-texel composites).
MODE_CODES = {"add": 0, "erase": 1, "set": 2}
#: Falloff kinds: smoothstep from ``hardness``, hard edge, custom curve (see :meth:`Brush.falloff`).
FALLOFF_SMOOTH, FALLOFF_HARD, FALLOFF_CURVE = 0, 1, 2

_enabled = HAVE_NUMBA and os.environ.get("SHEER_PAINT_KERNEL", "").strip().lower() != "numpy"
_warm_lock = threading.Lock()
_warm_thread: threading.Thread | None = None
_ready = False  # the kernels are loaded in this process
_loading = False  # the warm-up thread is compiling or loading them in this process


def enabled() -> bool:
    """Whether dabs use the compiled kernels (False: the numpy reference path), once :func:`ready` too."""
    return _enabled


def set_enabled(on: bool) -> bool:
    """Switch the compiled kernels on or off (on only if numba is installed); returns the old setting."""
    global _enabled
    old = _enabled
    _enabled = bool(on) and HAVE_NUMBA
    return old


#: The functions compiled by :func:`_jit_all`, in dependency order: (name, inline into callers). An
#: inlined helper saves a call between compiled functions, whose array arguments cost atomic reference
#: counting (~100 ns: far more than the per-texel work). Until then the names are plain Python.
_KERNELS = (("_sphere_runs", False), ("nearest", False), ("weights", False), ("_touch", True),
            ("tile_of", True), ("composite", False))
_jit_lock = threading.Lock()
_jitted = False


def _jit_all() -> None:
    """Import numba and replace each function of :data:`_KERNELS` in this module by its compiled dispatcher.

    The dispatchers are cached on disk; the compiled callers then find their helpers compiled.
    """
    global _jitted
    with _jit_lock:
        if _jitted:
            return
        import numba

        for name, inline in _KERNELS:
            fn = globals()[name]
            globals()[name] = numba.njit(cache=True, nogil=True, error_model="numpy",
                                         inline="always" if inline else "never")(fn)
        _jitted = True


# ---------------------------------------------------------------------------------------- grid runs
def _sphere_runs(origin: np.ndarray, cell: float, dims: np.ndarray, cell_start: np.ndarray,
                 c: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Runs [start, end) of cell-sorted texels in the grid cells meeting the sphere (``c``, mesh units).

    In the order :meth:`painting.spatial.TexelIndex.query_sphere` concatenates them (grid y outer, z
    inner); returns (starts, ends, total texels).
    """
    nx, ny = dims[0], dims[1]
    lo = np.empty(3, np.int64)
    hi = np.empty(3, np.int64)
    for a in range(3):
        lo[a] = max(np.int64(np.floor((c[a] - radius - origin[a]) / cell)), np.int64(0))
        hi[a] = min(np.int64(np.floor((c[a] + radius - origin[a]) / cell)), dims[a] - 1)
    ny_run = hi[1] - lo[1] + 1
    nz_run = hi[2] - lo[2] + 1
    if hi[0] < lo[0] or ny_run <= 0 or nz_run <= 0:
        return np.empty(0, np.int64), np.empty(0, np.int64), 0
    starts = np.empty(ny_run * nz_run, np.int64)
    ends = np.empty(ny_run * nz_run, np.int64)
    count = 0
    total = 0
    rr = radius * radius
    for jy in range(lo[1], hi[1] + 1):
        y0 = origin[1] + jy * cell
        dy = max(max(y0 - c[1], c[1] - (y0 + cell)), 0.0)
        for jz in range(lo[2], hi[2] + 1):
            z0 = origin[2] + jz * cell
            dz = max(max(z0 - c[2], c[2] - (z0 + cell)), 0.0)
            rem = rr - (dy ** 2 + dz ** 2)
            if rem >= 0:
                half = np.sqrt(rem)
                ix0 = max(np.int64(np.floor((c[0] - half - origin[0]) / cell)), 0)
                ix1 = min(np.int64(np.floor((c[0] + half - origin[0]) / cell)), nx - 1)
                row = nx * (jy + ny * jz)
                s = cell_start[row + ix0]
                e = cell_start[row + ix1 + 1]
                if e > s:
                    starts[count] = s
                    ends[count] = e
                    count += 1
                    total += e - s
    return starts[:count], ends[:count], total


def nearest(pn: np.ndarray, origin: np.ndarray, cell: float, dims: np.ndarray, cell_start: np.ndarray,
            p: np.ndarray, max_distance: float) -> tuple[int, float]:
    """Sorted index and distance (mesh units) of the texel nearest to ``p`` within ``max_distance``.

    (-1, inf) when there is none.

    ``pn``: the index's (N, 6) positions and normals. The same texel as
    :meth:`painting.spatial.TexelIndex.nearest_reference`.

    The ball searched grows from half a grid cell, doubling up to ``max_distance``, and stops as soon as
    its nearest texel lies inside it (then no texel outside it can be nearer). Equal float32 distances
    resolve to the first in query order, which is the same order in every ball (grid y, z, x, then the
    texel's place in its cell), so the answer is the reference's.
    """
    px, py, pz = np.float32(p[0]), np.float32(p[1]), np.float32(p[2])
    rho = min(max_distance, 0.5 * cell)
    while True:
        starts, ends, total = _sphere_runs(origin, cell, dims, cell_start, p, rho)
        best = np.float32(np.inf)
        kbest = -1
        for i in range(len(starts)):
            for k in range(starts[i], ends[i]):
                dx = pn[k, 0] - px
                dy = pn[k, 1] - py
                dz = pn[k, 2] - pz
                d2 = dx * dx + dy * dy + dz * dz
                if d2 < best or kbest < 0:
                    best = d2
                    kbest = k
        if kbest >= 0 and float(np.sqrt(best)) <= rho:
            return kbest, float(np.sqrt(best))
        if rho >= max_distance:
            break
        rho = min(2.0 * rho, max_distance)
    if kbest < 0:
        return -1, np.inf
    d = float(np.sqrt(best))
    if d > max_distance:
        return -1, np.inf
    return kbest, d


def weights(pn: np.ndarray, origin: np.ndarray, cell: float, dims: np.ndarray, cell_start: np.ndarray,
            a_pts: np.ndarray, b_pts: np.ndarray, normals: np.ndarray, r: float, cos_max: np.float32,
            use_angle: bool, kind: int, h: np.float32, xs: np.ndarray, curve: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """Texels within ``r`` of any capsule (a_pts[i], b_pts[i]) and facing ``normals[i]``, with their weights.

    Capsules are float64 (P, 3) in mesh units; ``pn`` is the index's (N, 6) texel positions and normals.
    Returns (sorted indices int64, falloff weights float32 in [0, 1], as
    :meth:`painting.brush.Brush.falloff` with ``kind``, hardness ``h`` and the curve samples
    ``xs``/``curve``); a texel reached by several capsules keeps its largest weight (then the indices
    are ascending).

    Long: one compiled pass over the candidate texels, written as the numpy reference's steps in the same
    order (the two paths must stay bit-identical); a helper called per texel between compiled functions
    costs its arrays' reference counting (see :data:`_KERNELS`), more than the per-texel work.
    """
    f32 = np.float32
    one = f32(1.0)
    zero = f32(0.0)
    r2 = f32(r * r)
    rf = f32(r)
    npieces = a_pts.shape[0]
    # Candidate runs of every piece (piece i owns runs [first[i], first[i + 1])): counted, then stored
    # (twice the few-µs grid walk, rather than a list of arrays, which compiles slowly).
    first = np.zeros(npieces + 1, np.int64)
    centres = (a_pts + b_pts) / 2.0
    radii = np.empty(npieces)
    cap = 0
    for i in range(npieces):
        d0 = b_pts[i, 0] - a_pts[i, 0]
        d1 = b_pts[i, 1] - a_pts[i, 1]
        d2 = b_pts[i, 2] - a_pts[i, 2]
        radii[i] = r + np.sqrt(d0 * d0 + d1 * d1 + d2 * d2) / 2.0
        starts, ends, total = _sphere_runs(origin, cell, dims, cell_start, centres[i], radii[i])
        first[i + 1] = first[i] + len(starts)
        cap += total
    run_s = np.empty(first[npieces], np.int64)
    run_e = np.empty(first[npieces], np.int64)
    for i in range(npieces):
        starts, ends, _ = _sphere_runs(origin, cell, dims, cell_start, centres[i], radii[i])
        run_s[first[i]:first[i + 1]] = starts
        run_e[first[i]:first[i + 1]] = ends
    out_k = np.empty(cap, np.int64)
    out_d = np.empty(cap, np.float32)
    n = 0
    for i in range(npieces):
        a0, a1, a2 = f32(a_pts[i, 0]), f32(a_pts[i, 1]), f32(a_pts[i, 2])
        segment = a_pts[i, 0] != b_pts[i, 0] or a_pts[i, 1] != b_pts[i, 1] or a_pts[i, 2] != b_pts[i, 2]
        ab0 = f32(b_pts[i, 0] - a_pts[i, 0])
        ab1 = f32(b_pts[i, 1] - a_pts[i, 1])
        ab2 = f32(b_pts[i, 2] - a_pts[i, 2])
        abab = ab0 * ab0 + ab1 * ab1 + ab2 * ab2
        n0, n1, n2 = f32(normals[i, 0]), f32(normals[i, 1]), f32(normals[i, 2])
        for j in range(first[i], first[i + 1]):
            for k in range(run_s[j], run_e[j]):
                dx = pn[k, 0] - a0
                dy = pn[k, 1] - a1
                dz = pn[k, 2] - a2
                if segment:
                    t = (dx * ab0 + dy * ab1 + dz * ab2) / abab
                    if t < zero:
                        t = zero
                    elif t > one:
                        t = one
                    dx = dx - t * ab0
                    dy = dy - t * ab1
                    dz = dz - t * ab2
                d2 = dx * dx + dy * dy + dz * dz
                if not d2 < r2:
                    continue
                if use_angle and not (pn[k, 3] * n0 + pn[k, 4] * n1 + pn[k, 5] * n2) >= cos_max:
                    continue
                out_k[n] = k
                out_d[n] = d2
                n += 1
    # Falloff of t = d / r (float32), as Brush.falloff.
    out_w = np.empty(n, np.float32)
    if kind == FALLOFF_CURVE:
        for i in range(n):
            t = np.sqrt(out_d[i]) / rf
            out_w[i] = f32(np.interp(np.float64(t), xs, curve)) if t < one else zero
    elif kind == FALLOFF_HARD:
        for i in range(n):
            t = np.sqrt(out_d[i]) / rf
            out_w[i] = one if t < one else zero
    else:
        inv = one - h
        three = f32(3.0)
        two = f32(2.0)
        for i in range(n):  # branch-free, so it vectorises
            q = min(max((np.sqrt(out_d[i]) / rf - h) / inv, zero), one)
            out_w[i] = one - q * q * (three - two * q)
    out_k = out_k[:n]
    if npieces > 1 and n > 1:
        order = np.argsort(out_k, kind="mergesort")
        ks = out_k[order]
        ws = out_w[order]
        m = 0
        for i in range(n):
            if m > 0 and ks[i] == out_k[m - 1]:
                if ws[i] > out_w[m - 1]:
                    out_w[m - 1] = ws[i]
            else:
                out_k[m] = ks[i]
                out_w[m] = ws[i]
                m += 1
        out_k = out_k[:m]
        out_w = out_w[:m]
    return out_k, out_w


# ---------------------------------------------------------------------------------------- compositing
def _touch(tid: int, touched: np.ndarray, mark: np.ndarray, tiles: np.ndarray, ntiles: int,
           data: np.ndarray, base: np.ndarray, res: int, nt: int) -> int:
    """Get tile ``tid`` ready for a write: save it in ``base`` if the stroke had not touched it yet.

    It is listed among this dab's tiles; returns the new tile count.
    """
    if not mark[tid]:
        mark[tid] = True
        tiles[ntiles] = tid
        ntiles += 1
        if not touched[tid]:
            touched[tid] = True
            r0 = (tid // nt) * TILE
            c0 = (tid % nt) * TILE
            for rr in range(r0, r0 + TILE):
                o = rr * res + c0
                base[o:o + TILE] = data[o:o + TILE]
    return ntiles


def composite(sidx: np.ndarray, w: np.ndarray, alpha: np.float32, flat: np.ndarray, tile: np.ndarray,
              has_pad: np.ndarray, pad_src: np.ndarray, pad_dst: np.ndarray, data: np.ndarray,
              mask: np.ndarray, base: np.ndarray, touched: np.ndarray, mark: np.ndarray, res: int,
              mode: int, strength: np.float32, amount: np.float32, top: np.float32) -> np.ndarray:
    """Composite one dab into a stroke (the reference: ``Stroke._composite``).

    For the sorted texels ``sidx`` with weights ``w``, ``m ← m + (1 − m)·w·alpha`` in the stroke's
    coverage ``mask`` and the texel (and the padding texels it feeds) set from its stroke ``base``
    value by ``mode`` (0 add up to ``top``, 1 erase, 2 set towards ``amount``; thickness in µm). Tiles
    are saved to ``base`` when first touched (``touched``, the stroke's tile table; ``mark`` all False
    on entry and exit). Flat maps of side ``res``. Returns the dab's tile ids (row · tiles per row +
    column), ascending.
    """
    nt = res // TILE
    one = np.float32(1.0)
    tiles = np.empty(nt * nt, np.int64)
    ntiles = 0
    sa = strength * amount
    target = amount if amount < top else top
    npad = len(pad_src)
    for i in range(len(sidx)):
        k = sidx[i]
        f = flat[k]
        if not mark[tile[k]]:
            ntiles = _touch(tile[k], touched, mark, tiles, ntiles, data, base, res, nt)
        if has_pad[k]:
            lo = np.searchsorted(pad_src, f, side="left")
            hi = lo
            while hi < npad and pad_src[hi] == f:
                dst = pad_dst[hi]
                ntiles = _touch(tile_of(dst, res), touched, mark, tiles, ntiles, data, base, res, nt)
                hi += 1
        else:
            lo = 0
            hi = 0
        a = w[i] * alpha
        m = mask[f]
        m = m + (one - m) * a
        mask[f] = m
        b = base[f]
        if mode == 0:
            v = b + sa * m
            if v > top:
                v = top
            if b > top:
                v = b
        elif mode == 1:
            v = b * (one - strength * m)
        else:
            v = b + (target - b) * (strength * m)
        data[f] = v
        for j in range(lo, hi):
            data[pad_dst[j]] = v
    out = np.sort(tiles[:ntiles])
    for i in range(ntiles):
        mark[out[i]] = False
    return out


# ---------------------------------------------------------------------------------------- warm-up
def _compile_all() -> None:
    """Compile every kernel (:func:`_jit_all`) and call it once on tiny arrays of the document's types.

    This compiles them, or loads the on-disk cache.
    """
    _jit_all()
    f32, f64, i64 = np.float32, np.float64, np.int64
    pn = np.zeros((4, 6), f32)
    origin = np.zeros(3, f64)
    dims = np.ones(3, i64)
    cell_start = np.array([0, 4], i64)
    p = np.zeros(3, f64)
    nearest(pn, origin, 1.0, dims, cell_start, p, 1.0)
    pts = np.zeros((1, 3), f64)
    xs = np.linspace(0.0, 1.0, 2)
    k, w = weights(pn, origin, 1.0, dims, cell_start, pts, pts, pts, 0.5, f32(0.0), True,
                   FALLOFF_SMOOTH, f32(0.5), xs, xs)
    res = 64
    data = np.zeros(res * res, f32)
    composite(k, w, f32(1.0), np.arange(4, dtype=i64), np.zeros(4, np.int32), np.zeros(4, np.bool_),
              np.zeros(0, i64), np.zeros(0, i64), data, data.copy(), data.copy(), np.zeros(1, np.bool_),
              np.zeros(1, np.bool_), res, 0, f32(1.0), f32(1.0), f32(1.0))


def _marker() -> Path | None:
    """A file saying these kernels were compiled into the on-disk cache once, or None.

    Its name holds the source, numba and Python versions; None when the cache folder cannot be written.
    """
    src = Path(__file__)
    # numba's cache is keyed by the source's modification time and size: so is the marker.
    stamp = f"{src.stat().st_mtime} {importlib.metadata.version('numba')} {sys.version}"
    digest = hashlib.sha256(src.read_bytes() + stamp.encode()).hexdigest()
    folder = src.parent / "__pycache__"
    try:
        folder.mkdir(exist_ok=True)
    except OSError:
        return None
    return folder / f"kernels-compiled-{digest[:16]}" if os.access(folder, os.W_OK) else None


def _mark_compiled() -> None:
    """Write this version's marker (see :func:`_marker`) and drop those of older versions."""
    marker = _marker()
    if marker is None:
        return
    for old in marker.parent.glob("kernels-compiled-*"):
        if old != marker:
            with contextlib.suppress(OSError):
                old.unlink()
    marker.touch()


def _warm() -> None:
    """The warm-up thread: compile the kernels (first time on a machine) or load them.

    The first time on a machine, compile in a child process (the compiler holds the GIL for tens of
    seconds, which would stall the studio) and let it fill the disk cache; then load the cached kernels
    here (a fraction of a second). Dabs use the numpy path until this ends.
    """
    global _ready, _loading
    marker = _marker()
    if marker is not None and not marker.exists():
        code = "from painting import kernels; kernels._compile_all(); kernels._mark_compiled()"
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(Path(__file__).parent.parent),
                                                           os.environ.get("PYTHONPATH", "")]))
        with contextlib.suppress(OSError, subprocess.SubprocessError):  # else compile here
            subprocess.run([sys.executable, "-c", code], env=env, stdin=subprocess.DEVNULL,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=900, check=False)
    _loading = True
    try:
        _compile_all()
        _ready = True
    except Exception as exc:  # a broken numba install: keep painting with the numpy reference path
        import warnings

        warnings.warn(f"painting kernels unavailable, using numpy: {exc}", RuntimeWarning, stacklevel=1)
    finally:
        _loading = False


def _join_warm_up() -> None:
    """At exit, let an in-process compile or cache load finish.

    One torn down by the interpreter's shutdown can crash it; a child process compiling the cache is
    left to finish on its own.
    """
    thread = _warm_thread
    if thread is not None and thread.is_alive() and _loading:
        thread.join()


atexit.register(_join_warm_up)


def ready() -> bool:
    """Whether the kernels are compiled and loaded in this process (dabs use them only then)."""
    return _ready


def active() -> bool:
    """Whether dabs and nearest-texel queries take the compiled path now (enabled and ready)."""
    return _enabled and _ready


def warm_up(background: bool = True) -> None:
    """Compile (first run on a machine: in a child process) or load the cached kernels, once per process.

    On a daemon thread; with ``background`` False, wait for it. Until it ends, dabs take the numpy path
    (bit-identical), so no dab ever waits for the compiler.
    """
    global _warm_thread
    if not _enabled:  # numba missing, or the numpy path chosen: nothing to load
        return
    with _warm_lock:
        if _warm_thread is None:
            _warm_thread = threading.Thread(target=_warm, name="sheer-paint-jit", daemon=True)
            _warm_thread.start()
        thread = _warm_thread
    if not background:
        thread.join()
