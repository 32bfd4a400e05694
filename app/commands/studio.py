"""``sheer studio [--head PATH] [--look NAME] [--project FILE]``: the desktop studio (the default command)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import argparse

    from app.commands import Subcommands


def register(sub: Subcommands) -> None:
    """Add ``sheer studio`` (the default command) to the sub-command parsers ``sub``."""
    from app.commands import LazyHelp
    from app.settings import DEFAULT_RESOLUTION  # plain Python: no Qt, no numpy

    p = sub.add_parser("studio", help="start the studio (the default)", description=__doc__)
    p.add_argument("--head", help="head mesh (default: the sample head)")
    p.add_argument("--look", default="natural", help=LazyHelp("look to start with: %(looks)s (default: %(default)s)",
                                                              looks=_looks))
    p.add_argument("--project", help="project file to open")
    p.add_argument("--resolution", type=int, default=None,
                   help=f"thickness map resolution (texels; default: the project's, else {DEFAULT_RESOLUTION})")
    p.set_defaults(func=run)


def _looks() -> tuple[str, ...]:
    """The built-in looks (:data:`painting.looks.BUILTIN_LOOKS`; imported when the help is shown)."""
    from painting.looks import BUILTIN_LOOKS

    return BUILTIN_LOOKS


def run(args: argparse.Namespace) -> int:
    """Run the studio until its window closes; returns the exit status (2, in one line, without a display)."""
    from app.application import require_display

    require_display("studio")  # before Qt is imported: its abort is a paragraph and status 134
    from app.studio.launch import run_studio

    return run_studio(head=args.head, look=args.look, project=args.project, resolution=args.resolution)
