"""``sheer bench NAME [options]``: benchmarks that print one JSON object on stdout.

Each benchmark is a function ``main(argv: list[str]) -> int`` in its own module, which parses its own
options (``--json`` is accepted by all of them and is the only output format).
"""

from __future__ import annotations

import argparse
import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from app.commands import Subcommands

#: benchmark name -> "module:function"
BENCHMARKS: dict[str, str] = {
    "km": "bench.km:main",
    "render": "bench.render:main",
    "paint": "bench.paint:main",
    "lightweight": "bench.lightweight:main",
    "studio": "bench.studio:main",
    "fuzz": "bench.fuzz_importers:main",  # --importers N, else bench.fuzz
    "project": "bench.project:main",
    "catalogue": "bench.catalogue:main",
    "shade": "bench.shade:main",
    "capture": "bench.capture:main",
    "soak": "bench.soak:main",
}


def register(sub: Subcommands) -> None:
    """Add ``sheer bench NAME [options]`` to the sub-command parsers ``sub``."""
    p = sub.add_parser("bench", help="run a benchmark and print JSON", description=__doc__)
    p.add_argument("name", choices=sorted(BENCHMARKS), help="which benchmark")
    p.add_argument("options", nargs=argparse.REMAINDER, help="the benchmark's own options")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the benchmark ``args.name`` with its own options; returns its exit status.

    Raises:
        core.errors.SheerError: the benchmark's module is not in this build.
    """
    from core.errors import SheerError

    module_name, func_name = BENCHMARKS[args.name].split(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name == module_name:
            raise SheerError(f"benchmark '{args.name}' is not available in this build") from exc
        raise
    return int(getattr(module, func_name)(list(args.options)) or 0)
