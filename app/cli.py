"""The ``sheer`` command line.

Each command lives in its own module under ``app/commands/`` and exposes ``register(subparsers)``, which
adds an ``argparse`` sub-parser whose ``func(args) -> int`` runs it. Command modules import only the
standard library at import time (heavy imports go inside ``func``), so ``sheer --help`` is instant and
headless commands never load Qt.

Errors: a :class:`core.errors.SheerError` (bad input) or an ``OSError`` is printed as one line on stderr
and exits with status 2; so is a malformed option (``sheer CMD: error: …; see 'sheer CMD --help'``, without
argparse's usage block). Any other exception is an internal error (status 70), reported without a
traceback unless ``SHEER_DEBUG=1``. A reader that stops reading (``sheer … | head``) ends the command
quietly with status 141, as a Unix tool killed by SIGPIPE does.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import traceback
from typing import TYPE_CHECKING, NoReturn

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


#: The exit status of a command whose reader closed its output (128 + SIGPIPE, what a shell reports for a
#: Unix tool killed by it).
BROKEN_PIPE_STATUS = 141


class _Parser(argparse.ArgumentParser):
    """``argparse``'s parser, whose errors are one line: what is wrong, and where the help is.

    argparse's own ``error`` prints the whole usage block first; the line that matters is then the last of
    ten. Every sub-command's parser is of this class (``add_subparsers`` makes its parsers of the parent's
    class).
    """

    def error(self, message: str) -> NoReturn:
        """Print ``PROG: error: MESSAGE; see 'PROG --help'`` on stderr and exit with status 2."""
        self.exit(2, f"{self.prog}: error: {message}; see '{self.prog} --help'\n")


def build_parser() -> argparse.ArgumentParser:
    """Build the full argument parser from every available command module."""
    parser = _Parser(
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


def _output_gone() -> None:
    """The reader of standard output has gone (``sheer … | head``): send what is left nowhere.

    Without this the interpreter, flushing standard output at exit, would fail again and print a
    traceback-like "Exception ignored" message.
    """
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # replaced by a non-file (a test's capture): nothing to do
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, fd)
    finally:
        os.close(devnull)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit status."""
    from core.errors import SheerError

    args_list = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    if not args_list or args_list[0].startswith(("--project", "--look", "--head", "--resolution")):  # the studio's
        args_list = ["studio", *args_list]
    try:
        args = parser.parse_args(args_list)
    except SystemExit as exc:  # argparse printed the help, or one line (_Parser.error)
        return int(exc.code or 0)
    func = getattr(args, "func", None)
    try:
        if func is None:
            parser.print_help()
            status = 0
        else:
            status = int(func(args) or 0)
        sys.stdout.flush()  # a reader that went away is seen here, not at the interpreter's exit
        return status
    except BrokenPipeError:
        _output_gone()
        return BROKEN_PIPE_STATUS
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
