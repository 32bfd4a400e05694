"""``sheer bench km --json``: CPU throughput of the spectral KM pipeline, in texels per second.

Per texel: 4 cosmetic layers (each with its own thickness map) evaluated spectrally at 81
wavelengths with :func:`km.optics.layer_rt`, combined with :func:`km.optics.stack`, put over a
per-texel skin reflectance with :func:`km.optics.over` (using the stack's reflectance from below),
and converted to linear sRGB with :func:`km.colour.spectrum_to_rgb`. This is the CPU reference the
renderer's texture-space pass is compared with.

All numpy, vectorised over texels and wavelengths; the only Python loop is over chunks of texels,
which bounds the memory and keeps the temporaries in cache (a chunk of 1024 texels × 81
wavelengths is 0.66 MB per temporary).
The inputs are synthetic and seeded; generating them is not timed.

Prints one JSON object: the median over ``--repeats`` runs (``seconds_median``, with ``seconds_p90``
and ``seconds_max`` beside it: a median hides hitches), the per-stage breakdown (``stages_s``: medians,
s; ``stages_s_p90``, ``stages_s_max``), and the machine. ``--size 8 --repeats 3`` is a quick run (the
test suite's smoke test).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import statistics
import sys
import time

import numpy as np

from km.colour import spectral_rgb_matrix, spectrum_to_rgb
from km.optics import layer_rt, over, stack
from km.spectra import DEFAULT_GRID

__all__ = ["main", "run"]

_STAGES = ("layer_rt", "stack", "over", "spectrum_to_rgb")


def _gauss(wl: np.ndarray, centre: float, width: float) -> np.ndarray:
    return np.exp(-0.5 * ((wl - centre) / width) ** 2)


def _materials(wl: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Four smooth synthetic (S, K) spectra in 1/mm: foundation, blush, eye shadow, a sheer top coat."""
    foundation = (40.0 + 10.0 * (wl - 380.0) / 400.0, 0.8 + 4.0 * _gauss(wl, 420.0, 60.0))
    blush = (15.0 + 0.0 * wl, 0.3 + 12.0 * _gauss(wl, 530.0, 45.0))
    shadow = (25.0 + 0.0 * wl, 2.0 + 6.0 * _gauss(wl, 600.0, 70.0))
    top = (2.0 + 0.0 * wl, 0.05 + 0.0 * wl)
    return [(np.asarray(s, float), np.asarray(k, float)) for s, k in (foundation, blush, shadow, top)]


def _skin(wl: np.ndarray) -> np.ndarray:
    """A plausible smooth skin reflectance (rising to the red, haemoglobin dips near 540 and 575 nm)."""
    base = 0.18 + 0.42 / (1.0 + np.exp(-(wl - 600.0) / 25.0))
    return base * (1.0 - 0.12 * _gauss(wl, 542.0, 12.0) - 0.12 * _gauss(wl, 577.0, 10.0))


def _inputs(n_texels: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Thickness maps (4, n) in mm (about half the texels bare per layer) and a skin albedo scale (n,)."""
    rng = np.random.default_rng(seed)
    thick = rng.uniform(0.0, 0.04, size=(4, n_texels))
    thick[rng.random((4, n_texels)) < 0.5] = 0.0
    albedo = rng.uniform(0.7, 1.1, size=n_texels)
    return thick, albedo


def run(size: int, chunk: int = 1024, seed: int = 0) -> tuple[float, dict[str, float], np.ndarray]:
    """One timed pass over ``size × size`` texels: (seconds, seconds per stage, linear sRGB (n, 3))."""
    wl = DEFAULT_GRID.wavelengths
    mats = _materials(wl)
    skin = _skin(wl)
    n = size * size
    thick, albedo = _inputs(n, seed)
    spectral_rgb_matrix(DEFAULT_GRID, "D65")  # build the cached matrix outside the timing
    rgb = np.empty((n, 3))
    stages = dict.fromkeys(_STAGES, 0.0)
    clock = time.perf_counter
    start = clock()
    for lo in range(0, n, chunk):
        hi = min(lo + chunk, n)
        t0 = clock()
        layers = [layer_rt(S, K, thick[i, lo:hi, None]) for i, (S, K) in enumerate(mats)]
        t1 = clock()
        R_top, R_bottom, T = stack(layers)
        t2 = clock()
        R = over(R_top, T, skin * albedo[lo:hi, None], R_bottom)
        t3 = clock()
        rgb[lo:hi] = spectrum_to_rgb(R, DEFAULT_GRID, "D65")
        t4 = clock()
        stages["layer_rt"] += t1 - t0
        stages["stack"] += t2 - t1
        stages["over"] += t3 - t2
        stages["spectrum_to_rgb"] += t4 - t3
    return clock() - start, stages, rgb


def _machine() -> dict[str, object]:
    info: dict[str, object] = {
        "platform": platform.platform(),
        "machine": platform.machine(),
        "processor": platform.processor() or None,
        "cpu_count": os.cpu_count(),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
    }
    with contextlib.suppress(OSError):
        info["loadavg_1min"] = round(os.getloadavg()[0], 2)
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    info["cpu_model"] = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return info


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def main(argv: list[str]) -> int:
    """Run the benchmark and print one JSON object on stdout; returns the exit status."""
    parser = argparse.ArgumentParser(prog="sheer bench km", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--json", action="store_true", help="JSON output (the only format; accepted)")
    parser.add_argument("--size", type=_positive_int, default=1024, help="texture side in texels (default 1024)")
    parser.add_argument("--repeats", type=_positive_int, default=3, help="timed runs (default 3)")
    parser.add_argument("--chunk", type=_positive_int, default=1024, help="texels per chunk (default 1024)")
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, or a bad option (argparse has printed why)
        return int(exc.code or 0)

    totals: list[float] = []
    per_stage: dict[str, list[float]] = {k: [] for k in _STAGES}
    rgb = np.zeros((0, 3))
    for _ in range(args.repeats):
        total, stages, rgb = run(args.size, args.chunk)
        totals.append(total)
        for k, v in stages.items():
            per_stage[k].append(v)
    texels = args.size * args.size
    median = statistics.median(totals)
    result = {
        "benchmark": "km",
        "what": "4-layer KM stack, 81 wavelengths, over skin, to linear sRGB (D65), float64 numpy",
        "texels": texels,
        "size": [args.size, args.size],
        "wavelengths": len(DEFAULT_GRID),
        "layers": 4,
        "repeats": args.repeats,
        "chunk_texels": args.chunk,
        "texels_per_s": texels / median if median > 0 else None,
        "seconds_median": median,
        "seconds_p90": float(np.percentile(totals, 90)),
        "seconds_max": max(totals),
        "seconds_all": totals,
        "stages_s": {k: statistics.median(v) for k, v in per_stage.items()},
        "stages_s_p90": {k: float(np.percentile(v, 90)) for k, v in per_stage.items()},
        "stages_s_max": {k: max(v) for k, v in per_stage.items()},
        "mean_rgb": [float(c) for c in rgb.mean(axis=0)] if rgb.size else None,
        "machine": _machine(),
    }
    print(json.dumps(result, indent=2))
    return 0
