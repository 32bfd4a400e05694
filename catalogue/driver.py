"""The Dask driver: a catalogue's jobs on an embedded ``LocalCluster`` or an existing Dask cluster.

:func:`run_catalogue` checks the output folder, expands the spec, skips what is already rendered (names
carry content hashes), and submits runs of jobs (:func:`catalogue.jobs.chunks`) to Dask distributed, each
worker its even share with stealing at the end (:mod:`catalogue.balance`), a run or two in flight at a
time per worker: by default a ``LocalCluster`` of worker *processes* with one thread each (each owns one
headless GL context and its caches, :mod:`catalogue.worker`), or the scheduler at ``scheduler`` (workers
started with ``dask worker``). A worker that dies has its tasks rescheduled by Dask, and a rescheduled run skips the
images already written. A job that fails is submitted once more on its own, then recorded in
``failed.json``. At the end: ``manifest.json`` and ``manifest.csv`` (every output with its parameters, hash
and timing) and a contact sheet per product and view (:mod:`catalogue.sheets`), all written atomically.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from catalogue.balance import Balancer
from catalogue.errors import CatalogueError
from catalogue.jobs import chunks, expand, renderer_version

if TYPE_CHECKING:
    from collections.abc import Iterator

    from catalogue.jobs import Job
    from catalogue.spec import Spec

#: ``on_progress(done, total, rendered, failed)``: outputs finished (including those already there), all
#: outputs, rendered by this run, failed for good.
Progress = Callable[[int, int, int, int], None]
MANIFEST_SCHEMA_VERSION = 1
#: Balanced runs in flight per worker: one running and one waiting at the worker, so it never idles for a
#: round trip to the driver (one alone once fewer runs are left than workers: the end evens out).
IN_FLIGHT = 2
#: The queue of a cluster that had no worker when the run started: its runs go to any worker.
ANY_WORKER = ""
CSV_FIELDS = ("file", "kind", "hash", "status", "head", "look", "product", "light", "view", "yaw", "pitch",
              "width", "height", "mode", "seconds", "worker")


@dataclass
class RunResult:
    """What a run did.

    Attributes:
        total: outputs in the catalogue. rendered: written by this run. skipped: already there.
        failed: the failed jobs' records (as in ``failed.json``). seconds: wall-clock time of the run.
        manifest: the manifest's path. dashboard: the Dask dashboard's URL, if there was one.
        cancelled: the run was cancelled before it finished.
    """

    total: int = 0
    rendered: int = 0
    skipped: int = 0
    failed: list[dict[str, Any]] = field(default_factory=list)
    seconds: float = 0.0
    manifest: Path | None = None
    dashboard: str | None = None
    cancelled: bool = False


def check_output(out: str | Path) -> Path:
    """Create the output folder if needed and prove it writable with a real (atomic) write.

    Raises:
        CatalogueError: a file in the way, no permission, a full or read-only disk (one line, named).
    """
    from core.atomicio import atomic_write_bytes

    folder = Path(out).absolute()
    if folder.exists() and not folder.is_dir():
        raise CatalogueError(f"{out}: not a folder (a file is in the way)")
    probe = folder / ".sheer-write-test"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(probe, b"\0" * 65536)  # a PNG's worth: a nearly full disk shows now
        probe.unlink()
    except OSError as exc:
        raise CatalogueError(f"{out}: cannot write the catalogue here: {exc.strerror or exc}") from None
    return folder


@contextlib.contextmanager
def dask_client(workers: int | None = None, scheduler: str | None = None) -> Iterator[Any]:
    """A Dask ``Client``: on the scheduler at ``scheduler``, else on a new ``LocalCluster`` of processes.

    Args:
        workers: worker processes of the local cluster (default: the machine's cores), one thread each.
        scheduler: e.g. ``tcp://host:8786``.

    Raises:
        CatalogueError: the scheduler cannot be reached.
    """
    from distributed import Client, LocalCluster

    if scheduler is not None:
        _probe(scheduler)
        try:
            client = Client(scheduler, timeout="20s")
        except OSError as exc:
            raise CatalogueError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
        try:
            yield client
        finally:
            client.close()
        return
    from catalogue.warmup import PRELOAD

    check_device_variable()
    n = workers or os.cpu_count() or 1
    # ":0": the scheduler's HTTP server (and dashboard, with bokeh) on a free port, never a clash on 8787;
    # the preload warms each worker (GL context, shaders) while the cluster starts (catalogue.warmup) and
    # gives worker i (LocalCluster names its workers 0, 1, …) EGL device i mod the devices present
    with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=":0", silence_logs=logging.ERROR, preload=[PRELOAD],
                      env=worker_environment(n)) as cluster, Client(cluster) as client:
        yield client


def check_device_variable() -> None:
    """Refuse a bad ``SHEER_EGL_DEVICE`` here, once, before a local cluster's workers inherit it.

    Raises:
        CatalogueError: not an integer, or no EGL device has that index (one line, naming the variable).
    """
    from render.context import pinned_device
    from render.errors import RenderError

    try:
        pinned_device()
    except RenderError as exc:
        raise CatalogueError(str(exc)) from None


def worker_environment(workers: int) -> dict[str, str]:
    """Environment of the local cluster's worker processes: the machine's cores shared between them.

    Mesa's llvmpipe starts one rasteriser thread per core in every process (``LP_NUM_THREADS``), so N
    workers on C cores would run N × C threads; each worker gets C // N (at least 1) instead, as Dask gives
    each worker its share of threads. A value the user set in the environment is kept.
    """
    if "LP_NUM_THREADS" in os.environ:
        return {}
    return {"LP_NUM_THREADS": str(max(1, (os.cpu_count() or 1) // max(workers, 1)))}


def _probe(address: str) -> None:
    """Fail at once, with the reason, when nothing listens at a ``tcp://host:port`` scheduler address."""
    import socket
    from urllib.parse import urlsplit

    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    if parts.scheme != "tcp":
        return  # other transports (tls, inproc, ucx): Dask's own connection error says what went wrong
    try:
        port = parts.port or 8786
        with socket.create_connection((parts.hostname or "127.0.0.1", port), timeout=5):
            pass
    except (OSError, ValueError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc)
        raise CatalogueError(f"cannot reach the Dask scheduler at {address}: {reason}") from None


def _has_bokeh() -> bool:
    import importlib.util

    return importlib.util.find_spec("bokeh") is not None


def dashboard_link(client: Any) -> str | None:
    """The Dask dashboard's URL, when the scheduler serves one.

    The scheduler's HTTP server always runs; the dashboard's pages need ``bokeh`` where the scheduler runs.
    """
    try:
        if "dashboard" in client.scheduler_info().get("services", {}) and client.run_on_scheduler(_has_bokeh):
            return str(client.dashboard_link)
    except Exception:
        return None
    return None


def run_catalogue(spec: Spec, out: str | Path, *, jobs: list[Job] | None = None, workers: int | None = None,
                  scheduler: str | None = None, client: Any = None, force: bool = False,
                  on_progress: Progress | None = None, on_dashboard: Callable[[str], None] | None = None,
                  cancelled: Callable[[], bool] | None = None) -> RunResult:
    """Render every job of ``spec`` into ``out`` that is not there yet (see the module docstring).

    Args:
        spec: the checked spec (:func:`catalogue.spec.load_spec`).
        out: the output folder (created).
        jobs: the expansion of ``spec`` if already made.
        workers: local worker processes (ignored with ``scheduler`` or ``client``).
        scheduler: a Dask scheduler address to run on instead of a local cluster.
        client: an existing ``distributed.Client`` (tests and benchmarks reuse one cluster).
        force: render everything again.
        on_progress: called as outputs finish.
        on_dashboard: called with the dashboard URL once connected, if there is one.
        cancelled: polled; True stops the run (what is written stays; the manifest lists it).

    Returns:
        What the run did; failures are in ``failed`` (and ``failed.json``), never raised.
    """
    t0 = time.time()
    folder = check_output(out)
    jobs = expand(spec) if jobs is None else jobs
    result = RunResult(total=len(jobs))
    todo = [j for j in jobs if force or not (folder / j.out).exists()]
    result.skipped = len(jobs) - len(todo)
    if todo and client is None and scheduler is None:
        check_device_variable()  # before any work or progress: the local workers would inherit it
    records: dict[str, dict[str, Any]] = {}
    failed: dict[str, dict[str, Any]] = {}
    if on_progress is not None:
        on_progress(result.skipped, len(jobs), 0, 0)
    outs = {j.out for j in todo}

    def run_on(cl: Any) -> None:
        _run_jobs(cl, todo, folder, t0 if force else None, result, records, failed, on_progress, on_dashboard,
                  cancelled)
        result.failed = list(failed.values())
        _write_outputs(spec, folder, jobs, outs, records, result, sheets_on=cl)

    try:
        if todo and client is not None:
            run_on(client)
        elif todo:
            with dask_client(workers, scheduler) as own:
                run_on(own)
        else:
            _write_outputs(spec, folder, jobs, outs, records, result, sheets_on=None)
    except KeyboardInterrupt:  # Ctrl-C: the manifest still lists what is there, then the interrupt goes on
        result.cancelled = True
        result.failed = list(failed.values())
        _write_outputs(spec, folder, jobs, outs, records, result, sheets=False)
        raise
    result.seconds = time.time() - t0
    return result


def _run_jobs(client: Any, todo: list[Job], folder: Path, force_before: float | None, result: RunResult,
              records: dict[str, dict[str, Any]], failed: dict[str, dict[str, Any]], on_progress: Progress | None,
              on_dashboard: Callable[[str], None] | None, cancelled: Callable[[], bool] | None) -> None:
    """Run ``todo`` in balanced runs (:mod:`catalogue.balance`), retry each failure once on its own.

    Fills ``records`` (each output's outcome) and ``failed`` (the jobs that failed twice).
    """
    from distributed import wait

    from catalogue.worker import render_chunk

    result.dashboard = dashboard_link(client)
    if result.dashboard and on_dashboard is not None:
        on_dashboard(result.dashboard)
    # no worker yet (a cluster still starting): one queue for whichever comes, stolen from by the others
    workers = _same_version_workers(client, todo[0].version) or {ANY_WORKER}
    # runs of at most ceil(jobs / (6 × workers)) jobs, about six per worker: small enough to even out the
    # end, and a worker's runs follow each other in its share, so its caches stay warm across them
    balancer = Balancer(chunks(todo, 2 * len(workers)), sorted(workers))
    by_out = {j.out: j for j in todo}
    attempts: dict[str, int] = dict.fromkeys(by_out, 0)
    run_id = uuid.uuid4().hex[:8]
    pending: dict[Any, list[Job]] = {}
    placed: dict[Any, str] = {}  # the worker each balanced task was pinned to
    in_flight: dict[str, int] = {}

    def submit(chunk: list[Job], worker: str | None = None) -> Any:
        for j in chunk:
            attempts[j.out] += 1
        # pinned loosely: if that worker is gone, Dask runs the task on another one
        fut = client.submit(render_chunk, chunk, str(folder), force_before, pure=False,
                            key=f"sheer-catalogue-{run_id}-{uuid.uuid4().hex[:12]}",
                            workers=[worker] if worker else None, allow_other_workers=bool(worker))
        pending[fut] = chunk
        if worker is not None:
            placed[fut] = worker
            in_flight[worker] = in_flight.get(worker, 0) + 1
        return fut

    def feed(worker: str) -> None:
        """Keep ``worker`` busy: a run running and one waiting, or one alone once little is left."""
        window = IN_FLIGHT if balancer.remaining() >= len(workers) else 1
        while worker in workers and in_flight.get(worker, 0) < window:
            run = balancer.next_for(worker)
            if run is None:
                return
            submit(list(run), worker)

    is_cancelled = cancelled or (lambda: False)
    if is_cancelled():
        result.cancelled = True
        return
    for w in sorted(workers):
        feed(w)
    done = result.skipped
    seen = time.monotonic()
    while pending:
        try:  # wake up at least every 0.25 s to see a Cancel
            finished = wait(list(pending), timeout=0.25, return_when="FIRST_COMPLETED").done
        except TimeoutError:
            finished = set()
        if is_cancelled():
            result.cancelled = True
            client.cancel(list(pending))
            return
        if balancer.remaining() and time.monotonic() - seen > 1.0:  # workers that joined or left meanwhile
            seen = time.monotonic()
            with contextlib.suppress(Exception):
                now = set(client.scheduler_info()["workers"])
                balancer.add_workers(sorted(now - workers))
                workers = now
        for fut in finished:
            done += _collect(fut, pending.pop(fut), by_out, attempts, records, failed, submit)
            worker = placed.pop(fut, None)
            if worker is not None:
                in_flight[worker] -= 1
        for w in sorted(workers):
            feed(w)
        while not pending and (run := balancer.next_for(ANY_WORKER)) is not None:  # no worker left to feed
            submit(list(run))
        if finished and on_progress is not None:
            on_progress(done, result.total, sum(r["status"] == "rendered" for r in records.values()), len(failed))


def _same_version_workers(client: Any, expected: str) -> set[str]:
    """The cluster's workers (addresses), once each is known to run this Sheer (renderer version ``expected``).

    Asked before any work, as every worker must draw what the names say: :class:`CatalogueError` otherwise.
    """
    from catalogue.worker import worker_version

    versions = client.run(worker_version)
    other = {addr: v for addr, v in versions.items() if v != expected}
    if other:
        addr, v = next(iter(other.items()))
        raise CatalogueError(f"{len(other)} of {len(versions)} Dask worker(s) run another Sheer (e.g. {addr}: "
                             f"renderer version {v[:12]}, this one {expected[:12]}); install the same Sheer "
                             "everywhere (or restart workers started before an update)")
    return set(versions)


def _collect(fut: Any, chunk: list[Job], by_out: dict[str, Job], attempts: dict[str, int],
             records: dict[str, dict[str, Any]], failed: dict[str, dict[str, Any]],
             submit: Callable[[list[Job]], Any]) -> int:
    """Record a finished task's outcomes; a job failing for the first time is submitted again on its own.

    Returns:
        How many outputs are settled (rendered, found, or failed for good).
    """
    try:
        outcomes = fut.result()
    except Exception as exc:  # the task itself died (e.g. KilledWorker after repeated worker deaths)
        reason = f"{type(exc).__name__}: {exc}".splitlines()[0]
        outcomes = [{"key": j.key, "out": j.out, "status": "failed", "seconds": None, "error": reason,
                     "worker": None} for j in chunk]
    settled = 0
    for res in outcomes:
        job = by_out[res["out"]]
        if res["status"] == "failed" and attempts[job.out] < 2:
            submit([job])  # retried once, on its own (maybe on another worker)
            continue
        if res["status"] == "failed":
            failed[job.out] = {"file": job.out, "hash": job.key, **job.params(), "error": res["error"],
                               "attempts": attempts[job.out], "worker": res["worker"]}
        records[job.out] = res
        settled += 1
    return settled


def _write_outputs(spec: Spec, folder: Path, jobs: list[Job], todo: set[str], records: dict[str, dict[str, Any]],
                   result: RunResult, sheets: bool = True, sheets_on: Any = None) -> None:
    """manifest.json, manifest.csv, failed.json (or its removal) and the contact sheets, atomically.

    Sets ``result.rendered``: the outputs this run wrote (``todo`` are those it set out to write). The
    sheets are drawn by the Dask workers of ``sheets_on`` (a client; they are independent), else here.
    """
    import csv
    import io

    from catalogue.sheets import sheet_groups, write_sheet
    from core.atomicio import atomic_write_text

    old = _previous_manifest(folder)
    images = []
    for job in jobs:
        rec = records.get(job.out)
        prev = old.get(job.out, {}) if old.get(job.out, {}).get("hash") == job.key else {}
        if rec is None:  # there before the run, or never reported (cancelled)
            exists = (folder / job.out).exists()
            status = "skipped" if exists else ("cancelled" if result.cancelled else "missing")
            seconds, worker = prev.get("seconds"), prev.get("worker")
            if exists and job.out in todo:  # written by a task still running when the run was cancelled
                status, seconds, worker = "rendered", None, None
        elif rec["status"] == "exists":  # written by this run before its worker died; the rerun kept it
            status, seconds, worker = "rendered", None, None
        else:
            status, seconds, worker = rec["status"], rec["seconds"], rec["worker"]
        images.append({"file": job.out, "hash": job.key, **job.params(), "status": status, "seconds": seconds,
                       "worker": worker})
    result.rendered = sum(e["status"] == "rendered" for e in images)
    if not result.cancelled:
        _remove_stale_temporaries(folder, jobs)
    manifest = {"schema_version": MANIFEST_SCHEMA_VERSION, "name": spec.name, "spec": str(spec.path.absolute()),
                "renderer_version": jobs[0].version if jobs else renderer_version(), "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                "total": len(jobs), "rendered": result.rendered, "skipped": result.skipped,
                "failed": len(result.failed), "images": images}
    try:
        atomic_write_text(folder / "manifest.json", json.dumps(manifest, indent=1))
        buf = io.StringIO()
        writer = csv.DictWriter(buf, fieldnames=CSV_FIELDS, extrasaction="ignore", lineterminator="\n")
        writer.writeheader()
        writer.writerows(images)
        atomic_write_text(folder / "manifest.csv", buf.getvalue())
        failed_path = folder / "failed.json"
        if result.failed:
            atomic_write_text(failed_path, json.dumps({"failed": result.failed}, indent=1))
        else:
            failed_path.unlink(missing_ok=True)
        if spec.contact_sheets and sheets:
            groups = sheet_groups(folder, jobs, only_if_changed=result.rendered == 0 and not result.failed)
            if sheets_on is not None and groups:
                sheets_on.gather(sheets_on.map(write_sheet, [folder] * len(groups), list(groups),
                                               list(groups.values()), pure=False))
            else:
                for path, items in groups.items():
                    write_sheet(folder, path, items)
    except OSError as exc:
        raise CatalogueError(f"{folder}: cannot write the manifest: {exc.strerror or exc}") from None
    result.manifest = folder / "manifest.json"


def _remove_stale_temporaries(folder: Path, jobs: list[Job]) -> None:
    """Delete the temporary files a killed worker left beside this catalogue's outputs.

    They are ``.<name>.<random>.tmp`` (:mod:`core.atomicio`); the outputs themselves are never half-written.
    """
    names: dict[Path, set[str]] = {}
    for job in jobs:
        target = folder / job.out
        names.setdefault(target.parent, set()).add(target.name)
    for parent, outs in names.items():
        for tmp in parent.glob(".*.tmp") if parent.is_dir() else ():
            if tmp.name[1:].rsplit(".", 2)[0] in outs:
                tmp.unlink(missing_ok=True)


def _previous_manifest(folder: Path) -> dict[str, dict[str, Any]]:
    """The previous run's manifest entries by file (for the timings of skipped images), or {}."""
    try:
        data = json.loads((folder / "manifest.json").read_text(encoding="utf-8"))
        return {e["file"]: e for e in data.get("images", []) if isinstance(e, dict) and "file" in e}
    except (OSError, ValueError, TypeError, AttributeError):
        return {}
