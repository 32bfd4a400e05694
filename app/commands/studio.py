"""``sheer studio [--head PATH] [--look NAME] [--project FILE]``: the desktop studio (the default command)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import argparse

    from app.commands import Subcommands


def register(sub: Subcommands) -> None:
    """Add ``sheer studio`` (the default command) to the sub-command parsers ``sub``."""
    p = sub.add_parser("studio", help="start the studio (the default)", description=__doc__)
    p.add_argument("--head", help="head mesh (default: the sample head)")
    p.add_argument("--look", default="natural", help="look to start with (default: natural)")
    p.add_argument("--project", help="project file to open")
    p.add_argument("--resolution", type=int, default=None,
                   help="thickness map resolution (texels; default: the project's, else "
                        "app.settings.DEFAULT_RESOLUTION)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the studio until its window closes; returns the exit status."""
    from app.studio.launch import run_studio

    return run_studio(head=args.head, look=args.look, project=args.project, resolution=args.resolution)
