"""``sheer bench paint --json``: brush and undo timings on the sample head (not a timed test).

Prints one JSON object: ``dab_ms_1024``, ``dab_ms_2048``, ``dab_ms_4096`` (median wall-clock ms of one
1 cm radius dab, the first of its stroke: the map written, the touched tiles saved for undo, the change
event sent; ``dab_cpu_ms_*`` the same in process CPU time, which a busy shared machine disturbs less;
``dab_stroke_ms_*`` the whole one-dab stroke, its undo step pushed at the end included;
``dab_cold_ms_*`` the same dabs on a fresh layer, each after reading 160 MB, so that the caches are as
cold at every map size), ``dab_ratio_4096_1024`` (and ``dab_cold_ratio_4096_1024``),
``stroke_1000_ms`` (a 1000-dab stroke including its undo record), ``undo_ms``, ``redo_ms``, ``undo_peak_mb`` (peak bytes held by the undo stack), texel counts (in a 1 cm
dab, and ``dab_new_texels_*`` the median a dab newly painted), ``paint_path`` ("numba" kernels, or the
"numpy" reference under ``SHEER_PAINT_KERNEL=numpy``: see :mod:`painting.kernels`) and the targets.

What bounds ``dab_ratio_4096_1024`` (with the compiled kernels): ``dab_fixed_ms_*`` is the median dab
of 0.2 mm radius (a texel or none: the cost of a dab that does not grow with its texels — checks, the
nearest texel, the capsule, the call, the change event); ``dab_floor_ms_*`` the least any dab must
spend per texel, measured: one compiled pass over exactly the 1 cm dab's texels, in map order, that
reads each texel's position and writes one value (no falloff, no facing test, no undo, no padding;
the map's pages already mapped). ``dab_floor_ratio_4096_1024`` = (fixed₁₀₂₄ + floor₄₀₉₆) /
(fixed₁₀₂₄ + floor₁₀₂₄) is the best ratio a dab with this fixed cost could reach, and
``dab_fixed_needed_ms`` = 2·floor₄₀₉₆ − 3·floor₁₀₂₄ the fixed cost a dab would need for the ratio to reach
1.5 even with floor-speed texel work: a 1 cm dab covers 16× the texels on a 4096² map.
The ``_cold`` variants measure the same with the caches cold (160 MB read before each pass or dab).
``dab_ns_per_texel_*`` = (dab − fixed) / texels in the dab: flat or falling with the map size when a
dab's cost follows the texels under the brush and nothing else.
Every median ``K`` has ``K_p90`` and ``K_max`` beside it (the 90th percentile and the slowest of the
same runs: a median hides hitches); ``stroke_resolution`` names the map the 1000-dab stroke, undo and
redo ran on (2048², or the largest map measured below it with ``--sizes``).
Atlases are baked once and cached on disk (the first run takes longer); the kernels are compiled (or
loaded from their cache) before timing. ``--sizes 256,512 --dabs 5 --evict-mb 16`` is a quick run
(the test suite's smoke test).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from bench.stats import spread

if TYPE_CHECKING:
    from painting.brush import Brush
    from painting.document import Document
    from painting.layer import Layer

TARGETS = {"dab_ms_2048": 5.0, "dab_ratio_4096_1024": 1.5, "stroke_1000_ms": 2000.0, "undo_ms": 20.0,
           "redo_ms": 20.0}


class _StandInMaterial:
    name = "Bench foundation"
    category = "foundation"
    thickness_um = 20.0
    max_thickness_um = 60.0


class _StandInLibrary:
    def get(self, name: str) -> Any:
        return _StandInMaterial()


def _library() -> Any:
    try:
        import km

        lib = km.default_library()
        first = next(iter(lib))
        return lib, first.name
    except Exception:  # the library may be unavailable in a partial build
        return _StandInLibrary(), "Bench foundation"


def _face_path(doc: Document, n: int) -> np.ndarray:
    """``n`` surface points along a Lissajous curve over the face, seen from the front (+Z)."""
    mesh = doc.layout.trimesh()
    head = doc.head
    lm = head.metadata.landmarks
    if {"left_cheek", "right_cheek", "forehead", "chin"} <= set(lm):
        x0 = min(lm["right_cheek"][0], lm["left_cheek"][0])
        x1 = max(lm["right_cheek"][0], lm["left_cheek"][0])
        y0, y1 = lm["chin"][1], lm["forehead"][1]
    else:
        lo, hi = head.vertices.min(axis=0), head.vertices.max(axis=0)
        x0, x1, y0, y1 = lo[0] * 0.4, hi[0] * 0.4, lo[1] * 0.4, hi[1] * 0.4
    s = np.linspace(0.0, 2.0 * np.pi, n)
    xs = (x0 + x1) / 2 + (x1 - x0) / 2 * np.sin(3 * s)
    ys = (y0 + y1) / 2 + (y1 - y0) / 2 * np.sin(2 * s + 0.5)
    z = float(head.vertices[:, 2].max()) + 1.0
    origins = np.stack([xs, ys, np.full(n, z)], axis=1)
    dirs = np.tile([0.0, 0.0, -1.0], (n, 1))
    loc, ray, _ = mesh.ray.intersects_location(origins, dirs, multiple_hits=False)
    out = np.zeros((n, 3))
    out[ray] = loc
    return out[np.isin(np.arange(n), ray)]


_FLOOR_KERNEL: Any = None


def _floor_kernel() -> Any:
    """The compiled floor pass (see the module docstring), or None without numba."""
    global _FLOOR_KERNEL
    if _FLOOR_KERNEL is None:
        from painting import kernels

        if not kernels.HAVE_NUMBA:
            return None
        import numba

        def texel_floor(flat: np.ndarray, pos: np.ndarray, c: np.ndarray, r2: np.float32,
                        out: np.ndarray) -> int:
            """Write the squared distance to ``c`` of each texel inside ``r2`` into ``out``; returns the count.

            ``flat``: the texels (ascending); ``pos``: the positions, flat (H·W·3,) float32.
            """
            n = 0
            for i in range(len(flat)):
                f = flat[i]
                dx = pos[3 * f] - c[0]
                dy = pos[3 * f + 1] - c[1]
                dz = pos[3 * f + 2] - c[2]
                d2 = dx * dx + dy * dy + dz * dz
                if d2 < r2:
                    out[f] = d2
                    n += 1
            return n

        _FLOOR_KERNEL = numba.njit(nogil=True, error_model="numpy")(texel_floor)
    return _FLOOR_KERNEL


def floor_and_fixed(doc: Document, layer: Layer, pts: np.ndarray, radius_mm: float = 10.0,
                    evict: np.ndarray | None = None) -> dict[str, list[float]]:
    """The floor pass and the fixed cost of a dab at each point (seconds, one value per point).

    ``floor``: the floor pass (module docstring) over each point's dab texels (the covered texels within
    ``radius_mm``, found outside the timing); ``fixed``: the real dab of 0.2 mm radius at the same points
    (each the first of its stroke, as in :func:`measure`). With ``evict``, also ``floor_cold`` and
    ``fixed_cold``, each pass or dab after reading ``evict``. ``floor`` is missing without numba.
    """
    from painting import Brush

    out: dict[str, list[float]] = {}
    passes: list[tuple[str, np.ndarray | None]] = [("", None)]
    if evict is not None:
        passes.append(("_cold", evict))
    kernel = _floor_kernel()
    if kernel is not None:
        index = doc.atlas.index
        pos = doc.atlas.position.reshape(-1)
        res = doc.atlas.resolution
        target = np.zeros(res * res, dtype=np.float32)
        target[:] = 0.0  # map the pages now: the floor leaves out first-touch faults
        r = radius_mm / doc.mm_per_unit
        r2 = np.float32(r * r)
        lists = []
        for p in pts:
            idx = index.query_sphere(p, r)
            lists.append(np.sort(index.flat[idx[index.distance2(idx, p) < r2]]))
        kernel(lists[0], pos, pts[0].astype(np.float32), r2, target)  # compile
        for suffix, buffer in passes:
            times = []
            for p, flat in zip(pts, lists):
                c = p.astype(np.float32)
                if buffer is not None:
                    float(buffer.sum())
                t0 = time.perf_counter()
                kernel(flat, pos, c, r2, target)
                times.append(time.perf_counter() - t0)
            out[f"floor{suffix}"] = times
    tiny = Brush(radius_mm=0.2, hardness=0.5, strength=1.0, mode="add")
    for suffix, buffer in passes:
        times = []
        for p in pts:
            if buffer is not None:
                float(buffer.sum())
            with doc.stroke(layer, tiny) as s:
                t0 = time.perf_counter()
                s.dab(p)
                times.append(time.perf_counter() - t0)
        out[f"fixed{suffix}"] = times
    return out


#: Bytes read before each "cold" dab: more than this machine's last-level cache (105 MB), the same at
#: every map size (``--evict-mb``).
EVICT_BYTES = 160 * 2**20


def _timed_dabs(doc: Document, layer: Layer, pts: np.ndarray, brush: Brush,
                evict: np.ndarray | None = None) -> tuple[list[float], list[float], list[float], list[int]]:
    """One single-dab stroke at each point: (dab wall s, dab CPU s, whole stroke s, texels newly painted).

    The new texels are counted in the dab's own 64² tiles (a count over the whole map between dabs
    would itself read 64 MB at 4096² and leave the next dab with cold caches only there). With
    ``evict`` (a large array), it is read before each dab: the caches cold, alike at every map size.
    """
    res = layer.resolution
    nt = res // 64
    counts = np.zeros(nt * nt, dtype=np.int64)
    tiles_view = layer.thickness.reshape(nt, 64, nt, 64)
    times, cpu, strokes, new = [], [], [], []
    for p in pts:
        if evict is not None:
            float(evict.sum())
        s0 = time.perf_counter()
        with doc.stroke(layer, brush) as s:
            c0 = time.process_time()
            t0 = time.perf_counter()
            tiles = s.dab(p)
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        strokes.append(time.perf_counter() - s0)
        added = 0
        for ty, tx in tiles:
            n = int(np.count_nonzero(tiles_view[ty, :, tx, :]))
            added += n - int(counts[ty * nt + tx])
            counts[ty * nt + tx] = n
        new.append(added)
    return times, cpu, strokes, new


def measure(resolution: int, library: Any, material: str, dabs: int = 40,
            evict: np.ndarray | None = None) -> tuple[Document, Layer, dict[str, list[float]]]:
    """The dab figures at one map size (see the module docstring), as raw values per dab.

    Returns the document, its layer painted by the timed dabs, and lists of seconds per dab: ``dab``
    (wall), ``dab_cpu`` (process CPU), ``dab_stroke`` (the whole one-dab stroke), ``dab_cold`` (with
    ``evict`` as :func:`_timed_dabs`: a second pass on a fresh layer with cold caches), and those of
    :func:`floor_and_fixed` as ``dab_fixed``, ``dab_floor`` (and ``_cold``); ``new_texels`` counts the
    texels each dab newly painted.
    """
    from painting import Brush, Document

    doc = Document.from_head(None, library=library, resolution=resolution)
    layer = doc.add_layer(material)
    _ = doc.atlas.index  # build the spatial index outside the timing
    pts = _face_path(doc, dabs)
    brush = Brush(radius_mm=10.0, hardness=0.5, strength=1.0, mode="add")
    times, cpu, strokes, new = _timed_dabs(doc, layer, pts, brush)
    runs: dict[str, list[float]] = {"dab": times, "dab_cpu": cpu, "dab_stroke": strokes,
                                    "new_texels": [float(n) for n in new]}
    if evict is not None:
        runs["dab_cold"], _, _, _ = _timed_dabs(doc, doc.add_layer(material), pts, brush, evict)
    runs.update({f"dab_{k}": v for k, v in floor_and_fixed(doc, layer, pts, evict=evict).items()})
    return doc, layer, runs


def _sizes(text: str) -> tuple[int, ...]:
    try:
        sizes = tuple(int(t) for t in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be map sizes separated by commas, got {text!r}") from None
    if not sizes or any(n < 64 or n % 64 for n in sizes):
        raise argparse.ArgumentTypeError(f"map sizes must be multiples of 64, got {text!r}")
    return sizes


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print one JSON object on stdout; returns the exit status."""
    parser = argparse.ArgumentParser(prog="sheer bench paint", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--json", action="store_true", help="print JSON (the only format)")
    parser.add_argument("--quick", action="store_true",
                        help="skip the 4096² map (the same as --sizes 1024,2048)")
    parser.add_argument("--sizes", type=_sizes, default=None,
                        help="map sizes in texels per side, separated by commas (default 1024,2048,4096)")
    parser.add_argument("--dabs", type=int, default=40, help="timed dabs per map size (default 40)")
    parser.add_argument("--evict-mb", type=int, default=EVICT_BYTES // 2**20,
                        help=f"MB read before each cold dab (default {EVICT_BYTES // 2**20})")
    try:
        args = parser.parse_args(argv)
        if args.dabs < 1 or args.evict_mb < 1:
            parser.error(f"--dabs and --evict-mb must be at least 1, got {args.dabs} and {args.evict_mb}")
    except SystemExit as exc:  # --help, or a bad option (argparse has printed why)
        return int(exc.code or 0)
    library, material = _library()
    from painting import kernels

    if kernels.enabled():
        kernels.warm_up(background=False)  # compiled (or loaded from the cache) before any timing
    out: dict[str, Any] = {"paint_path": "numba" if kernels.active() else "numpy"}
    sizes = args.sizes or ((1024, 2048) if args.quick else (1024, 2048, 4096))
    stroke_res = 2048 if 2048 in sizes else max((n for n in sizes if n < 2048), default=min(sizes))
    keep: tuple[Document, Layer] | None = None
    evict = np.ones(args.evict_mb * 2**20 // 4, dtype=np.float32)
    for res in sizes:
        doc, layer, runs = measure(res, library, material, dabs=args.dabs, evict=evict)
        for name in ("dab", "dab_cpu", "dab_cold", "dab_stroke", "dab_fixed", "dab_fixed_cold", "dab_floor",
                     "dab_floor_cold"):
            if name in runs:
                out.update(spread(f"{name}_ms_{res}", [1000 * t for t in runs[name]], digits=3))
        new = runs["new_texels"]
        out[f"dab_new_texels_{res}"] = int(np.median(new))
        out[f"dab_new_texels_{res}_p90"] = int(np.percentile(new, 90))
        out[f"dab_new_texels_{res}_max"] = int(max(new))
        out[f"texels_in_1cm_dab_{res}"] = int(round(np.pi * (10.0 / doc.atlas.texel_mm) ** 2))
        texels = out[f"texels_in_1cm_dab_{res}"]
        fixed_ms = 1000 * statistics.median(runs["dab_fixed"])
        dab_ms = 1000 * statistics.median(runs["dab"])
        out[f"dab_ns_per_texel_{res}"] = round(1e6 * (dab_ms - fixed_ms) / max(texels, 1), 1)
        if res == stroke_res:
            keep = (doc, layer)
        del doc, layer, runs
    if "dab_ms_4096" in out and "dab_ms_1024" in out:
        out["dab_ratio_4096_1024"] = round(out["dab_ms_4096"] / out["dab_ms_1024"], 3)
        out["dab_cpu_ratio_4096_1024"] = round(out["dab_cpu_ms_4096"] / out["dab_cpu_ms_1024"], 3)
        out["dab_cold_ratio_4096_1024"] = round(out["dab_cold_ms_4096"] / out["dab_cold_ms_1024"], 3)
        for cold in ("", "_cold"):
            if f"dab_floor{cold}_ms_4096" in out:
                fixed = out[f"dab_fixed{cold}_ms_1024"]
                lo, hi = out[f"dab_floor{cold}_ms_1024"], out[f"dab_floor{cold}_ms_4096"]
                out[f"dab_floor{cold}_ratio_4096_1024"] = round((fixed + hi) / (fixed + lo), 3)
                out[f"dab_fixed{cold}_needed_ms"] = round(2 * hi - 3 * lo, 3)
    assert keep is not None
    out.update(_stroke_and_undo(*keep))
    out["stroke_resolution"] = stroke_res
    out["targets"] = TARGETS
    print(json.dumps(out, indent=2))
    return 0


def _stroke_and_undo(doc: Document, layer: Layer) -> dict[str, Any]:
    """Time a 1000-dab stroke on ``layer`` (its undo record included), then its undo and redo.

    Returns the times (ms), the dabs painted, whether redo restored the map bit-exactly, and the undo
    stack's peak and budget (MB).
    """
    from painting import Brush

    out: dict[str, Any] = {}
    doc.clear_history()
    doc.history.peak_bytes = 0  # the peak of the 1000-dab stroke alone, not of the single dabs above
    pts = _face_path(doc, 1100)[:1000]  # a few rays may miss the face: keep exactly 1000 points
    brush = Brush(radius_mm=10.0, hardness=0.5, strength=0.8, mode="add", spacing=0.001)
    c0 = time.process_time()
    t0 = time.perf_counter()
    with doc.stroke(layer, brush) as s:
        for p in pts:
            s.dab(p)
    out["stroke_1000_ms"] = round(1000 * (time.perf_counter() - t0), 2)
    out["stroke_1000_cpu_ms"] = round(1000 * (time.process_time() - c0), 2)
    out["stroke_dabs"] = s.dabs
    before = layer.thickness.copy()
    t0 = time.perf_counter()
    doc.undo()
    out["undo_ms"] = round(1000 * (time.perf_counter() - t0), 3)
    t0 = time.perf_counter()
    doc.redo()
    out["redo_ms"] = round(1000 * (time.perf_counter() - t0), 3)
    out["redo_bit_exact"] = bool(np.array_equal(before, layer.thickness))
    out["undo_peak_mb"] = round(doc.history.peak_bytes / 2**20, 3)
    out["undo_budget_mb"] = round(doc.history.budget_bytes / 2**20, 1)
    last = doc.history.undo_step
    out["stroke_tiles"] = int(sum(len(d.tiles) for d in last.deltas)) if last is not None else 0
    return out


if __name__ == "__main__":
    raise SystemExit(main())
