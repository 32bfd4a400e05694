"""``sheer bench paint --json``: brush and undo timings on the sample head (not a timed test).

Prints one JSON object: ``dab_ms_1024``, ``dab_ms_2048``, ``dab_ms_4096`` (median wall-clock ms of one
1 cm radius dab, the first of its stroke: the map written, the touched tiles saved for undo, the change
event sent; ``dab_cpu_ms_*`` the same in process CPU time, which a busy shared machine disturbs less;
``dab_stroke_ms_*`` the whole one-dab stroke, its undo step pushed at the end included),
``dab_ratio_4096_1024``, ``stroke_1000_ms`` (a 1000-dab stroke including its undo record),
``undo_ms``, ``redo_ms``, ``undo_peak_mb`` (peak bytes held by the undo stack), texel counts (in a 1 cm
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
``dab_ns_per_texel_*`` = (dab − fixed) / texels in the dab: flat or falling with the map size when a
dab's cost follows the texels under the brush and nothing else.
Atlases are baked once and cached on disk (the first run takes longer); the kernels are compiled (or
loaded from their cache) before timing.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from typing import Any

import numpy as np

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


def _face_path(doc: Any, n: int) -> np.ndarray:
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
            """Read the position (``pos``: flat (H·W·3,) float32) of each texel ``flat`` (ascending) and
            write its squared distance to ``c`` into ``out`` when inside ``r2``; returns the count."""
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


def floor_and_fixed(doc: Any, layer: Any, pts: np.ndarray, radius_mm: float = 10.0) -> dict[str, float]:
    """``floor_ms``: the median floor pass (module docstring) over each point's dab texels (the covered
    texels within ``radius_mm``, found outside the timing); ``fixed_ms``: the median real dab of 0.2 mm
    radius at the same points (each the first of its stroke, as in :func:`measure`)."""
    from painting import Brush

    out: dict[str, float] = {}
    kernel = _floor_kernel()
    if kernel is not None:
        index = doc.atlas.index
        pos = doc.atlas.position.reshape(-1)
        res = doc.atlas.resolution
        target = np.zeros(res * res, dtype=np.float32)
        target[:] = 0.0  # map the pages now: the floor leaves out first-touch faults
        r = radius_mm / doc.mm_per_unit
        r2 = np.float32(r * r)
        times = []
        for i, p in enumerate(pts):
            c = p.astype(np.float32)
            idx = index.query_sphere(p, r)
            flat = np.sort(index.flat[idx[index.distance2(idx, p) < r2]])
            if i == 0:
                kernel(flat, pos, c, r2, target)  # compile
            t0 = time.perf_counter()
            kernel(flat, pos, c, r2, target)
            times.append(time.perf_counter() - t0)
        out["floor_ms"] = 1000 * statistics.median(times)
    tiny = Brush(radius_mm=0.2, hardness=0.5, strength=1.0, mode="add")
    times = []
    for p in pts:
        with doc.stroke(layer, tiny) as s:
            t0 = time.perf_counter()
            s.dab(p)
            times.append(time.perf_counter() - t0)
    out["fixed_ms"] = 1000 * statistics.median(times)
    return out


def measure(resolution: int, library: Any, material: str, dabs: int = 40) -> dict[str, Any]:
    from painting import Brush, Document

    doc = Document.from_head(None, library=library, resolution=resolution)
    layer = doc.add_layer(material)
    _ = doc.atlas.index  # build the spatial index outside the timing
    pts = _face_path(doc, dabs)
    brush = Brush(radius_mm=10.0, hardness=0.5, strength=1.0, mode="add")
    times = []
    cpu = []
    strokes = []
    texels = []
    for p in pts:
        s0 = time.perf_counter()
        with doc.stroke(layer, brush) as s:
            c0 = time.process_time()
            t0 = time.perf_counter()
            s.dab(p)
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        strokes.append(time.perf_counter() - s0)
        texels.append(int(np.count_nonzero(layer.thickness)))
    extra = floor_and_fixed(doc, layer, pts)
    return {"doc": doc, "layer": layer, "dab_ms": 1000 * statistics.median(times), **extra,
            "dab_cpu_ms": 1000 * statistics.median(cpu), "dab_stroke_ms": 1000 * statistics.median(strokes),
            "texels_per_dab": int(np.median(np.diff([0, *texels])[1:]) if len(texels) > 1 else texels[0])}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="sheer bench paint", description=__doc__)
    parser.add_argument("--json", action="store_true", help="print JSON (the only format)")
    parser.add_argument("--quick", action="store_true", help="skip the 4096² map")
    args = parser.parse_args(argv)
    library, material = _library()
    from painting import kernels

    if kernels.enabled():
        kernels.warm_up(background=False)  # compiled (or loaded from the cache) before any timing
    out: dict[str, Any] = {"paint_path": "numba" if kernels.active() else "numpy"}
    sizes = (1024, 2048) if args.quick else (1024, 2048, 4096)
    keep: dict[str, Any] = {}
    for res in sizes:
        r = measure(res, library, material)
        out[f"dab_ms_{res}"] = round(r["dab_ms"], 3)
        out[f"dab_cpu_ms_{res}"] = round(r["dab_cpu_ms"], 3)
        out[f"dab_stroke_ms_{res}"] = round(r["dab_stroke_ms"], 3)
        out[f"dab_new_texels_{res}"] = r["texels_per_dab"]
        out[f"texels_in_1cm_dab_{res}"] = int(round(np.pi * (10.0 / r["doc"].atlas.texel_mm) ** 2))
        out[f"dab_fixed_ms_{res}"] = round(r["fixed_ms"], 3)
        texels = out[f"texels_in_1cm_dab_{res}"]
        out[f"dab_ns_per_texel_{res}"] = round(1e6 * (r["dab_ms"] - r["fixed_ms"]) / max(texels, 1), 1)
        if "floor_ms" in r:
            out[f"dab_floor_ms_{res}"] = round(r["floor_ms"], 3)
        if res == 2048:
            keep = r
        else:
            del r
    if "dab_ms_4096" in out:
        out["dab_ratio_4096_1024"] = round(out["dab_ms_4096"] / out["dab_ms_1024"], 3)
        out["dab_cpu_ratio_4096_1024"] = round(out["dab_cpu_ms_4096"] / out["dab_cpu_ms_1024"], 3)
        if "dab_floor_ms_4096" in out:
            fixed, lo, hi = out["dab_fixed_ms_1024"], out["dab_floor_ms_1024"], out["dab_floor_ms_4096"]
            out["dab_floor_ratio_4096_1024"] = round((fixed + hi) / (fixed + lo), 3)
            out["dab_fixed_needed_ms"] = round(2 * hi - 3 * lo, 3)
    from painting import Brush

    doc, layer = keep["doc"], keep["layer"]
    doc.clear_history()
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
    out["stroke_tiles"] = int(sum(len(d.tiles) for d in doc.history._undo[-1].deltas)) if doc.history.can_undo else 0
    out["targets"] = TARGETS
    print(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
