"""``sheer doctor [--full] [--json]``: is this machine ready for Sheer? One line per check.

Checks, in order (:mod:`app.diagnostics`): the GL context Sheer's headless commands use (vendor, renderer,
version, EGL), its maximum texture size against the largest texture Sheer allocates, whether every shader
program builds (the compiler's messages located as ``file.glsl:line: message`` when one does not), the
sample assets found, the cache folder and its size, the main dependencies' versions, Python and the OS.

Each line starts with ``ok``, ``warn``, ``FAIL`` or ``skip``. Exit status 0 when no line failed, 1
otherwise. Headless: it needs no display and never loads Qt.

Shader levels (``render.programs``): ``quick`` (the default) builds the extremes of each program family,
279 programs in 0.5-0.7 s here with Mesa's shader cache warm, 2.3 s with it disabled; ``--full`` builds
every variant the renderer can ask for, 2835 programs in 8-9 s warm, 36 s disabled (Mesa llvmpipe,
2 cores, 2026-11-28; the counts grow with the renderer's variants).
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from app.commands import Subcommands


def register(sub: Subcommands) -> None:
    """Add ``sheer doctor`` to the sub-command parsers ``sub``."""
    p = sub.add_parser("doctor", help="check the GL driver, shaders, assets, cache and dependencies",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--full", action="store_true",
                   help="build every shader program variant (8-9 s here, 36 s with Mesa's shader cache "
                        "cold) instead of the quick set (0.5-0.7 s here, 2.3 s cold)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of lines")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run every check and print the report; returns 0 when all is well, 1 when a check failed."""
    import json

    from app.diagnostics import collect

    report = collect("full" if args.full else "quick")
    if args.json:
        print(json.dumps(report.as_json(), indent=2))
    else:
        print(report.text())
    return 0 if report.ok else 1
