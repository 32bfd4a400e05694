"""``sheer bench catalogue --json``: a 24-image catalogue on 1 and 2 local Dask workers.

Compared with one ``sheer render`` process per image, and the no-op rerun of a finished catalogue.

The catalogue: red-lip on the sample head, 4 lipsticks × 3 lightings × 2 views, 640×640, fast mode. Each
repeat starts a new ``LocalCluster`` (its start is timed apart: ``cluster_start_s``) and renders into a
new folder, so every worker starts cold (context, head, look, shaders) as in a real run. Keys:

- ``images_per_s_1_worker``, ``images_per_s_2_workers``: images / wall time of ``run_catalogue`` (cluster
  already up; the workers' warm-up, :mod:`catalogue.warmup`, starts with them and may still be running),
  median over the repeats; ``scaling_2_vs_1``: their ratio (the issue asks ≥ 1.6);
  ``scaling_2_vs_1_with_cluster_start``: the ratio of cluster start + run (the whole wait).
- ``speedup_vs_separate_processes``: seconds per image of ``sheer render`` processes (one per image, run
  one after another) over seconds per image of the 1-worker catalogue (≥ 3).
- ``resume_noop_s``: a rerun of the finished catalogue (no cluster is started), and ``resume_noop_ratio``
  over the first run's wall time including the cluster's start (≤ 0.05).
- ``worker_busy_s_*``: the job seconds of every worker added up (from the manifest), ``first_jobs_s_*``
  those of each worker's first, cold job: what a second worker duplicates.
- ``load_avg_start``/``_end``: the machine's 1-minute load average (other work on the 2 cores shows).
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

import numpy as np

from bench.stats import spread

SPEC = """
name = "bench"
size = [640, 640]
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
[[views]]
name = "front"
[[views]]
name = "three-quarter"
yaw = 30
"""


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


def _busy(folder: Path) -> tuple[float, float]:
    """(Σ job seconds over every worker, Σ of each worker's first job) from a run's manifest."""
    images = json.loads((folder / "manifest.json").read_text(encoding="utf-8"))["images"]
    first: dict[str, float] = {}
    for e in images:
        first.setdefault(e["worker"], e["seconds"])
    return sum(e["seconds"] for e in images), sum(first.values())


def _separate(folder: Path, n: int) -> list[float]:
    """Seconds of ``n`` ``sheer render`` processes, one image each, 640×640 fast, red-lip."""
    times = []
    for i in range(n):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "app.cli", "render", "--look", "red-lip", "--size", "640x640",
                        "--yaw", str(10 * i), "--out", str(folder / f"sep{i}.png")], check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
    return times


def main(argv: list[str]) -> int:
    """Run the benchmark and print its JSON (see the module docstring)."""
    p = argparse.ArgumentParser(prog="sheer bench catalogue", description=__doc__)
    p.add_argument("--json", action="store_true", help="print JSON (the only format)")
    p.add_argument("--repeats", type=int, default=2, help="catalogue runs per worker count (default 2)")
    p.add_argument("--separate", type=int, default=6, help="sheer render processes timed (default 6)")
    args = p.parse_args(argv)
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="sheer-bench-catalogue-") as tmp:
        root = Path(tmp)
        spec_path = root / "bench.toml"
        spec_path.write_text(SPEC, encoding="utf-8")
        from catalogue import load_spec, run_catalogue

        runs: dict[int, list[tuple[float, float, int]]] = {1: [], 2: []}
        busy: dict[int, list[tuple[float, float]]] = {1: [], 2: []}
        resume_s = 0.0
        for r in range(max(args.repeats, 1)):
            for workers in (1, 2):
                runs[workers].append(_catalogue(spec_path, root / f"w{workers}-{r}", workers))
                busy[workers].append(_busy(root / f"w{workers}-{r}"))
                if r == 0 and workers == 1:  # the rerun of the finished catalogue, at once (no cluster)
                    t0 = time.perf_counter()
                    noop = run_catalogue(load_spec(spec_path), root / "w1-0")
                    resume_s = time.perf_counter() - t0
                    if noop.rendered:
                        raise RuntimeError("bench catalogue: the sources changed during the run (the rerun "
                                           "rendered again); run it on a tree nobody is editing")
        first = runs[1][0]
        separate = _separate(root, args.separate)
    n = first[2]
    ips = {w: n / float(np.median([s for _, s, _ in runs[w]])) for w in (1, 2)}
    per_image_catalogue = 1.0 / ips[1]
    per_image_separate = float(np.median(separate))
    out = {
        "images": n, "size": "640x640", "mode": "fast",
        "images_per_s_1_worker": round(ips[1], 3), "images_per_s_2_workers": round(ips[2], 3),
        "scaling_2_vs_1": round(ips[2] / ips[1], 3),
        # the same ratio over what the user waits for: the cluster's start (which includes starting the
        # workers' warm-up, catalogue.warmup) and the run
        "scaling_2_vs_1_with_cluster_start": round(float(np.median([c + s for c, s, _ in runs[1]]))
                                                   / float(np.median([c + s for c, s, _ in runs[2]])), 3),
        **spread("run_s_1_worker", [s for _, s, _ in runs[1]]), **spread("run_s_2_workers", [s for _, s, _ in runs[2]]),
        **spread("cluster_start_s", [c for c, _, _ in runs[1] + runs[2]]),
        **spread("separate_process_s_per_image", separate),
        "catalogue_s_per_image_1_worker": round(per_image_catalogue, 3),
        # work done by all workers together (Σ job seconds) and in their first (cold) jobs: what a second
        # worker adds (its own start-up and lighting set-ups) against what it can take off the first
        "worker_busy_s_1_worker": round(float(np.median([b for b, _ in busy[1]])), 2),
        "worker_busy_s_2_workers": round(float(np.median([b for b, _ in busy[2]])), 2),
        "first_jobs_s_1_worker": round(float(np.median([f for _, f in busy[1]])), 2),
        "first_jobs_s_2_workers": round(float(np.median([f for _, f in busy[2]])), 2),
        "speedup_vs_separate_processes": round(per_image_separate / per_image_catalogue, 2),
        "first_run_s_with_cluster_start": round(first[0] + first[1], 2),
        "resume_noop_s": round(resume_s, 3), "resume_noop_ratio": round(resume_s / (first[0] + first[1]), 4),
        "repeats": max(args.repeats, 1), "cpu_count": os.cpu_count(),
        "load_avg_start": round(load0, 2), "load_avg_end": round(os.getloadavg()[0], 2),
    }
    print(json.dumps(out, indent=1))
    return 0
