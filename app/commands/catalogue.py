"""``sheer catalogue SPEC.toml --out DIR``: render every shade × face × light × view of a spec on Dask.

The spec (TOML; see ``docs/CATALOGUE.md``) is checked whole before anything runs (exit 2 with the key
at fault). By default an embedded Dask ``LocalCluster`` of ``--workers`` processes (one thread each:
every worker owns one headless GL context and its caches) renders the jobs; ``--scheduler
tcp://HOST:8786`` runs them on an existing Dask cluster instead (workers started with ``dask worker``
where Sheer is installed, seeing the same files at the same paths). Outputs are named by a hash of what
determines their pixels: a rerun renders only what is missing or changed (``--force``: everything).
``--dry-run`` prints the expansion, the count and an estimate of the time. Exit status: 0 when every
output is there, 1 when some job failed (listed in ``DIR/failed.json``), 2 for bad input.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import TYPE_CHECKING, TextIO

if TYPE_CHECKING:
    from app.commands import Subcommands


def _positive(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = 0
    if not 1 <= n <= 256:
        raise argparse.ArgumentTypeError(f"must be a whole number from 1 to 256, got {text!r}")
    return n


def register(sub: Subcommands) -> None:
    """Add the ``catalogue`` command to ``sheer``'s sub-commands."""
    p = sub.add_parser("catalogue", help="render a catalogue (shades × faces × lights × views) on Dask",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("spec", metavar="SPEC.toml", help="the catalogue spec")
    p.add_argument("--out", metavar="DIR", help="output folder (created); required unless --dry-run")
    p.add_argument("--workers", type=_positive, metavar="N", help="local worker processes (default: the cores)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler, e.g. tcp://host:8786")
    p.add_argument("--dry-run", action="store_true", help="print the jobs, their count and an estimate; render nothing")
    p.add_argument("--force", action="store_true", help="render every image again")
    p.set_defaults(func=run)


class ProgressBar:
    """A one-line progress bar with rate and ETA on a terminal, a line per tenth otherwise.

    Hand-written: distributed's own ``progress`` shows neither rate nor ETA, and tqdm is not a dependency.
    """

    def __init__(self, stream: TextIO | None = None, width: int = 30) -> None:
        self.stream, self.width = stream or sys.stderr, width
        self.tty = self.stream.isatty()
        self.t0 = time.monotonic()
        self.first: tuple[float, int] | None = None  # (time, rendered) when the first output came
        self.last_tenth = -1

    def __call__(self, done: int, total: int, rendered: int, failed: int) -> None:
        """Show ``done`` of ``total`` outputs (``rendered`` by this run, ``failed`` for good)."""
        now = time.monotonic()
        if rendered and self.first is None:
            self.first = (now, rendered)
        rate = eta = None
        if self.first is not None and rendered > self.first[1] and now > self.first[0]:
            rate = (rendered - self.first[1]) / (now - self.first[0])
            eta = (total - done) / rate
        frac = done / total if total else 1.0
        bar = "█" * round(frac * self.width) + "·" * (self.width - round(frac * self.width))
        text = (f"[{bar}] {done}/{total}" + (f"  {rate:.2f} img/s" if rate else "")
                + (f"  ETA {_hms(eta)}" if eta is not None else "") + (f"  {failed} failed" if failed else "")
                + f"  {_hms(now - self.t0)}")
        if self.tty:
            self.stream.write("\r" + text + "\033[K")
            self.stream.flush()
        elif int(frac * 10) != self.last_tenth or done == total:
            self.last_tenth = int(frac * 10)
            print(text, file=self.stream, flush=True)

    def close(self) -> None:
        """End the bar's line."""
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


def _hms(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


def run(args: argparse.Namespace) -> int:
    """Check the spec, then dry-run or render it (see the module docstring); returns the exit status."""
    from pathlib import Path

    from catalogue import estimate_seconds, expand, load_spec, run_catalogue
    from core.errors import SheerError

    spec = load_spec(args.spec)
    jobs = expand(spec)
    if args.dry_run:
        return _dry_run(spec, jobs, args, estimate_seconds)
    if not args.out:
        raise SheerError("--out DIR is required (the folder the catalogue is written to)")
    bar = ProgressBar()
    try:
        result = run_catalogue(spec, args.out, jobs=jobs, workers=args.workers, scheduler=args.scheduler,
                               force=args.force, on_progress=bar,
                               on_dashboard=lambda url: print(f"Dask dashboard: {url}", file=sys.stderr))
    finally:
        bar.close()
    rate = f", {result.rendered / result.seconds:.2f} img/s" if result.rendered and result.seconds else ""
    print(f"{spec.name}: {result.total} outputs: {result.rendered} rendered, {result.skipped} already there, "
          f"{len(result.failed)} failed in {result.seconds:.1f} s{rate}; manifest: {result.manifest}")
    if result.failed:
        print(f"sheer: {len(result.failed)} job(s) failed (each tried twice); see "
              f"{Path(args.out) / 'failed.json'}:", file=sys.stderr)
        for rec in result.failed[:5]:
            print(f"  {rec['file']}: {rec['error']}", file=sys.stderr)
        return 1
    return 0


def _dry_run(spec: object, jobs: list, args: argparse.Namespace, estimate: object) -> int:
    """Print the expansion: the axes, every output (first 50), what is already there and an estimate."""
    import os
    from pathlib import Path

    s = spec  # catalogue.spec.Spec
    axes = (f"{len(s.heads)} head(s) × {len(s.looks)} look(s) × {max(len(s.products), 1)} product(s) × "  # type: ignore[attr-defined]
            f"{len(s.lights)} light(s) × {len(s.views)} view(s)")  # type: ignore[attr-defined]
    there = sum((Path(args.out) / j.out).exists() for j in jobs) if args.out and not args.force else 0
    workers = args.workers or os.cpu_count() or 1
    todo = [j for j in jobs if not (args.out and not args.force and (Path(args.out) / j.out).exists())]
    for j in jobs[:50]:
        print(f"{j.key[:16]}  {j.out}")
    if len(jobs) > 50:
        print(f"… and {len(jobs) - 50} more")
    print(f"{s.name}: {axes} = {len(jobs)} output(s) ({s.size[0]}×{s.size[1]}, {s.mode}); "  # type: ignore[attr-defined]
          f"{there} already there, {len(todo)} to render; estimate ≈ {estimate(todo, 1 if args.scheduler else workers):.0f} s "  # type: ignore[operator]
          f"on {'the cluster' if args.scheduler else f'{workers} local worker(s)'}")
    return 0
