"""The ``sheer`` command line.

Each command lives in its own module under ``app/commands/`` and exposes ``register(subparsers)``, which
adds an ``argparse`` sub-parser whose ``func(args) -> int`` runs it. Command modules import only the
standard library at import time (heavy imports go inside ``func``), so ``sheer --help`` is instant and
headless commands never load Qt.

Errors: a :class:`core.errors.SheerError` (bad input) or an ``OSError`` is printed as one line on stderr
and exits with status 2; any other exception is an internal error (status 70), reported without a
traceback unless ``SHEER_DEBUG=1``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import traceback
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Sequence

#: Command modules, in the order ``sheer --help`` lists them. A module that does not exist yet is skipped.
COMMAND_MODULES: tuple[str, ...] = (
    "app.commands.studio",
    "app.commands.kiosk",
    "app.commands.materials",
    "app.commands.render",
    "app.commands.catalogue",
    "app.commands.project",
    "app.commands.capture",
    "app.commands.head",
    "app.commands.look",
    "app.commands.shade",
    "app.commands.cache",
    "app.commands.doctor",
    "bench.cli",
)


def build_parser() -> argparse.ArgumentParser:
    """Build the full argument parser from every available command module."""
    parser = argparse.ArgumentParser(
        prog="sheer",
        description="Sheer: a physically based makeup design studio. Without a command, starts the studio.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name == name:
                continue
            raise
        module.register(sub)
    return parser


def _report(message: str) -> None:
    print(f"sheer: error: {message}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit status."""
    from core.errors import SheerError

    args_list = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    if not args_list or args_list[0].startswith(("--project", "--look", "--head", "--resolution")):  # the studio's
        args_list = ["studio", *args_list]
    try:
        args = parser.parse_args(args_list)
    except SystemExit as exc:  # argparse prints its own usage message
        return int(exc.code or 0)
    func = getattr(args, "func", None)
    if func is None:
        parser.print_help()
        return 0
    try:
        return int(func(args) or 0)
    except SheerError as exc:
        _report(str(exc))
        return 2
    except OSError as exc:
        where = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
        _report(f"{exc.strerror or exc}{where}")
        return 2
    except KeyboardInterrupt:
        _report("interrupted")
        return 130
    except Exception as exc:  # an internal error: say so, never show a traceback unless asked
        if os.environ.get("SHEER_DEBUG"):
            traceback.print_exc()
        _report(f"internal error: {type(exc).__name__}: {exc} (set SHEER_DEBUG=1 for details)")
        return 70


if __name__ == "__main__":
    sys.exit(main())
