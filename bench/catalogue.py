"""``sheer bench catalogue --json [--workers 1,2,4,8] [--views N]``: a catalogue on 1, 2, … local Dask workers.

Compared with one ``sheer render`` process per image, and the no-op rerun of a finished catalogue.

The catalogue: red-lip on the sample head, 4 lipsticks × 3 lightings × ``--views`` views (default 2: 24
images; 8: 96), 640×640 (``--size``), fast mode. The views turn the head by yaw: front (0°), three-quarter
(30°), then ±7°, ±14°, ±21°, … Each repeat starts a new ``LocalCluster`` per worker count (its start is
timed apart: ``cluster_start_s``) and renders into a new folder, so every worker starts cold (context,
head, look, shaders) as in a real run. Keys (``N``: a worker count of ``--workers``):

- ``images_per_s``: {N: images / wall time of ``run_catalogue``} (cluster already up; the workers'
  warm-up, :mod:`catalogue.warmup`, starts with them and may still be running), median over the
  repeats; ``scaling_vs_1``: {N: that over one worker's} (with 1 in ``--workers``). The same as flat keys:
  ``images_per_s_1_worker``, ``images_per_s_2_workers``, …, ``scaling_2_vs_1``, …;
  ``scaling_2_vs_1_with_cluster_start``: the ratio of cluster start + run (the whole wait).
- ``jobs_per_worker``: {N: images each worker rendered, most first, zeros included} in the run of the
  first repeat; ``max_over_min_jobs``: {N: the most over the fewest, the worst repeat} (null when a worker
  rendered nothing).
- ``first_jobs_s``: {N: each worker's first (cold) job's seconds added up over the workers} (as
  ``first_jobs_s_1_worker``, … : what every further worker duplicates), ``first_job_s_max``: {N: the
  slowest single one}; ``worker_busy_s``: {N: the job seconds of every worker added up}.
- ``speedup_vs_separate_processes``: seconds per image of ``sheer render`` processes (one per image, run
  one after another, ``--separate`` of them; 0: not measured, null) over seconds per image of the
  1-worker catalogue.
- ``resume_noop_s``: a rerun of the finished catalogue (no cluster is started), and ``resume_noop_ratio``
  over the first run's wall time including the cluster's start (≤ 0.05).
- ``egl_devices``: the EGL devices the workers share round robin (:mod:`render.context`).
- ``load_avg_start``/``_end``: the machine's 1-minute load average (other work on the cores shows).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench.stats import spread

SPEC = """
name = "bench"
size = [{size}, {size}]
mode = "fast"
[[looks]]
look = "red-lip"
[products]
category = "lipstick"
materials = ["Lipstick Classic Red", "Lipstick Nude", "Lipstick Pink", "Lipstick Coral"]
[[lights]]
preset = "portrait"
[[lights]]
name = "key"
preset = "key"
[[lights]]
name = "studio"
preset = "flat"
environment = "studio"
{views}"""
#: The most views ``--views`` takes (the yaws stay within ±180°).
MAX_VIEWS = 48
#: Yaw step (degrees) of the views after the first two.
YAW_STEP = 7


def view_yaws(n: int) -> list[tuple[str, float]]:
    """(name, yaw in degrees) of ``n`` views: front 0°, three-quarter 30°, then +7°, −7°, +14°, −14° and so on."""
    views: list[tuple[str, float]] = [("front", 0.0), ("three-quarter", 30.0)][:n]
    for k in range(2, n):
        yaw = (1 if k % 2 == 0 else -1) * YAW_STEP * (k // 2)
        views.append((f"yaw{yaw:d}", float(yaw)))
    return views


def bench_spec(views: int = 2, size: int = 640) -> str:
    """The bench's spec (TOML) with ``views`` views of ``size``×``size`` pixels (2, 640: 24 images as always)."""
    blocks = []
    for name, yaw in view_yaws(views):
        blocks.append(f'[[views]]\nname = "{name}"\n' + (f"yaw = {yaw:g}\n" if yaw else ""))
    return SPEC.replace("{size}", str(size)).replace("{views}", "".join(blocks))


def _catalogue(spec_path: Path, folder: Path, workers: int) -> tuple[float, float, int]:
    """(cluster start s, run s, images rendered) on a new LocalCluster of ``workers`` processes."""
    from catalogue import load_spec, run_catalogue
    from catalogue.driver import dask_client

    spec = load_spec(spec_path)
    t0 = time.perf_counter()
    with dask_client(workers) as client:
        client.wait_for_workers(workers)
        t1 = time.perf_counter()
        result = run_catalogue(spec, folder, client=client)
        t2 = time.perf_counter()
    if result.failed:
        raise RuntimeError(f"bench catalogue: {len(result.failed)} jobs failed: {result.failed[0]['error']}")
    return t1 - t0, t2 - t1, result.rendered


def _busy(folder: Path, workers: int) -> dict[str, Any]:
    """A run's per-worker figures from its manifest (seconds; image counts).

    Returns:
        ``busy``: Σ job seconds over every worker; ``first``: Σ of each worker's first job, ``first_max``
        the slowest of them; ``jobs``: images per worker, most first, padded with zeros to ``workers``.
    """
    images = json.loads((folder / "manifest.json").read_text(encoding="utf-8"))["images"]
    first: dict[str, float] = {}
    count: dict[str, int] = {}
    for e in images:
        first.setdefault(e["worker"], e["seconds"])
        count[e["worker"]] = count.get(e["worker"], 0) + 1
    jobs = sorted(count.values(), reverse=True)
    jobs += [0] * max(0, workers - len(jobs))
    return {"busy": sum(e["seconds"] for e in images), "first": sum(first.values()),
            "first_max": max(first.values()), "jobs": jobs}


def _separate(folder: Path, n: int, size: int) -> list[float]:
    """Seconds of ``n`` ``sheer render`` processes, one image each, ``size``² fast, red-lip."""
    times = []
    for i in range(n):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "app.cli", "render", "--look", "red-lip", "--size", f"{size}x{size}",
                        "--yaw", str(10 * i), "--out", str(folder / f"sep{i}.png")], check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
    return times


def _worker_counts(text: str) -> list[int]:
    """``--workers``: a comma list of positive worker counts, e.g. ``1,2,4,8`` (sorted, each once)."""
    try:
        counts = sorted({int(t) for t in text.split(",") if t.strip()})
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a comma list of worker counts, e.g. 1,2,4,8; got {text!r}") from None
    if not counts or counts[0] < 1:
        raise argparse.ArgumentTypeError(f"worker counts must be positive integers, got {text!r}")
    return counts


def _ranged(low: int, high: int) -> Any:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = low - 1
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be an integer from {low} to {high}, got {text}")
        return value

    return parse


def main(argv: list[str]) -> int:
    """Run the benchmark and print its JSON (see the module docstring); 2 for bad options."""
    p = argparse.ArgumentParser(prog="sheer bench catalogue", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--json", action="store_true", help="print JSON (the only format)")
    p.add_argument("--workers", type=_worker_counts, default=[1, 2],
                   help="worker counts to measure, a comma list (default 1,2)")
    p.add_argument("--views", type=_ranged(1, MAX_VIEWS), default=2,
                   help=f"views by yaw: 12 images each (default 2: 24 images; 8: 96; at most {MAX_VIEWS})")
    p.add_argument("--size", type=_ranged(16, 8192), default=640, help="image side in pixels (default 640)")
    p.add_argument("--repeats", type=_ranged(1, 100), default=2, help="catalogue runs per worker count (default 2)")
    p.add_argument("--separate", type=_ranged(0, 1000), default=6,
                   help="sheer render processes timed (default 6; 0: none)")
    try:
        args = p.parse_args(argv)
    except SystemExit as exc:  # --help, or a bad option (argparse has printed why)
        return int(exc.code or 0)
    load0 = os.getloadavg()[0]
    measured = _measure(args)
    print(json.dumps(_figures(args, *measured, load0), indent=1))
    return 0


def _measure(args: argparse.Namespace) -> tuple[dict[int, list[tuple[float, float, int]]],
                                                dict[int, list[dict[str, Any]]], float, list[float]]:
    """The catalogue run ``args.repeats`` times per worker count, its no-op rerun, and separate processes.

    Returns each worker count's runs (cluster start s, run s, images) and the workers' busy figures
    (:func:`_busy`), the no-op rerun's seconds and the separate processes' seconds per image.
    """
    counts: list[int] = args.workers
    with tempfile.TemporaryDirectory(prefix="sheer-bench-catalogue-") as tmp:
        root = Path(tmp)
        spec_path = root / "bench.toml"
        spec_path.write_text(bench_spec(args.views, args.size), encoding="utf-8")
        from catalogue import load_spec, run_catalogue

        runs: dict[int, list[tuple[float, float, int]]] = {w: [] for w in counts}
        busy: dict[int, list[dict[str, Any]]] = {w: [] for w in counts}
        resume_s = 0.0
        for r in range(args.repeats):
            for workers in counts:
                folder = root / f"w{workers}-{r}"
                runs[workers].append(_catalogue(spec_path, folder, workers))
                busy[workers].append(_busy(folder, workers))
                if r == 0 and workers == counts[0]:  # the rerun of the finished catalogue, at once (no cluster)
                    t0 = time.perf_counter()
                    noop = run_catalogue(load_spec(spec_path), folder)
                    resume_s = time.perf_counter() - t0
                    if noop.rendered:
                        raise RuntimeError("bench catalogue: the sources changed during the run (the rerun "
                                           "rendered again); run it on a tree nobody is editing")
        separate = _separate(root, args.separate, args.size)
    return runs, busy, resume_s, separate


def _figures(args: argparse.Namespace, runs: dict[int, list[tuple[float, float, int]]],
             busy: dict[int, list[dict[str, Any]]], resume_s: float, separate: list[float],
             load0: float) -> dict[str, Any]:
    """The benchmark's JSON object from its measurements (:func:`_measure`; ``load0`` the load at the start)."""
    from render.context import render_devices

    counts: list[int] = args.workers
    first = runs[counts[0]][0]
    n = first[2]
    ips = {w: n / float(np.median([s for _, s, _ in runs[w]])) for w in counts}
    with_start = {w: float(np.median([c + s for c, s, _ in runs[w]])) for w in counts}

    def median(w: int, key: str) -> float:
        return float(np.median([b[key] for b in busy[w]]))

    def max_over_min(jobs: list[int]) -> float | None:
        return round(jobs[0] / jobs[-1], 2) if jobs[-1] else None

    worst = {w: max((b["jobs"] for b in busy[w]), key=lambda j: (j[-1] == 0, j[0] / max(j[-1], 1)))
             for w in counts}
    out: dict[str, Any] = {"images": n, "size": f"{args.size}x{args.size}", "mode": "fast", "views": args.views,
                           "workers": counts}
    for w in counts:
        s = "" if w == 1 else "s"
        out[f"images_per_s_{w}_worker{s}"] = round(ips[w], 3)
    for w in counts:
        if 1 in counts and w != 1:
            out[f"scaling_{w}_vs_1"] = round(ips[w] / ips[1], 3)
    if 1 in counts and 2 in counts:
        # the same ratio over what the user waits for: the cluster's start (which includes starting the
        # workers' warm-up, catalogue.warmup) and the run
        out["scaling_2_vs_1_with_cluster_start"] = round(with_start[1] / with_start[2], 3)
    for w in counts:
        out.update(spread(f"run_s_{w}_worker{'' if w == 1 else 's'}", [s for _, s, _ in runs[w]]))
    out.update(spread("cluster_start_s", [c for w in counts for c, _, _ in runs[w]]))
    per_image_separate = float(np.median(separate)) if separate else None
    if separate:
        out.update(spread("separate_process_s_per_image", separate))
    else:
        out["separate_process_s_per_image"] = None
    if 1 in counts:
        out["catalogue_s_per_image_1_worker"] = round(1.0 / ips[1], 3)
    for w in counts:
        # work done by all workers together (Σ job seconds) and in their first (cold) jobs: what a further
        # worker adds (its own start-up and lighting set-ups) against what it can take off the others
        out[f"worker_busy_s_{w}_worker{'' if w == 1 else 's'}"] = round(median(w, "busy"), 2)
    for w in counts:
        out[f"first_jobs_s_{w}_worker{'' if w == 1 else 's'}"] = round(median(w, "first"), 2)
    out.update({
        "images_per_s": {w: round(ips[w], 3) for w in counts},
        "scaling_vs_1": {w: round(ips[w] / ips[1], 3) for w in counts} if 1 in counts else None,
        "jobs_per_worker": {w: busy[w][0]["jobs"] for w in counts},
        "max_over_min_jobs": {w: max_over_min(worst[w]) for w in counts},
        "first_jobs_s": {w: round(median(w, "first"), 2) for w in counts},
        "first_job_s_max": {w: round(median(w, "first_max"), 2) for w in counts},
        "worker_busy_s": {w: round(median(w, "busy"), 2) for w in counts},
        "speedup_vs_separate_processes": (round(per_image_separate * ips[1], 2)
                                          if per_image_separate is not None and 1 in counts else None),
        "first_run_s_with_cluster_start": round(first[0] + first[1], 2),
        "resume_noop_s": round(resume_s, 3), "resume_noop_ratio": round(resume_s / (first[0] + first[1]), 4),
        "repeats": args.repeats, "cpu_count": os.cpu_count(), "egl_devices": len(render_devices()),
        "load_avg_start": round(load0, 2), "load_avg_end": round(os.getloadavg()[0], 2),
    })
    return out
