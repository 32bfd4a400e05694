"""``sheer cache info [--json]`` and ``sheer cache clear [--kind KIND]``: the cache folder, listed and cleared.

The cache (:mod:`core.cache`) holds derived data that is slow to make and safe to delete: atlas bakes and
their texel indexes, UV layouts, painted looks, render data, colour matrices and parsed meshes. ``info``
prints its location, its size and entries per kind and its cap (and where the cap comes from:
``SHEER_CACHE_MAX_MB``, the studio's settings, or automatic); ``clear`` deletes every entry, or those of
one kind, and the private session folders a killed kiosk left in the temporary folder (those of processes
that no longer run). Sheer makes again whatever it needs.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import argparse

    from app.commands import Subcommands

#: The kinds ``--kind`` accepts (core.cache.KINDS; repeated here so that ``sheer --help`` imports nothing).
_KINDS = ("atlas", "index", "layout", "looks", "render", "colour", "mesh")


def register(sub: Subcommands) -> None:
    """Add ``sheer cache`` and its sub-commands to the sub-command parsers ``sub``."""
    from app.commands import command_group

    csub = command_group(sub, "cache", "show or clear the cache folder", __doc__)
    i = csub.add_parser("info", help="location, size and entries per kind, and the cap")
    i.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    i.set_defaults(func=run_info)
    c = csub.add_parser("clear", help="delete every entry (or those of one kind)")
    c.add_argument("--kind", choices=_KINDS, help="only this kind of cache")
    c.set_defaults(func=run_clear)


def _apply_settings() -> None:
    """Apply the studio's cache cap setting, as the studio does (``SHEER_CACHE_MAX_MB`` still wins)."""
    from PySide6.QtCore import QSettings

    from app.settings import APPLICATION, ORGANISATION, load_settings

    load_settings(QSettings(ORGANISATION, APPLICATION))


def _mib(n: int) -> str:
    return f"{n / 2**20:.1f} MiB"


def run_info(args: argparse.Namespace) -> int:
    """Print the cache's location, size and entries per kind, and its cap; returns 0."""
    import json

    from core import cache

    _apply_settings()
    root = cache.cache_root()
    found = cache.entries(root)
    total = sum(e.size for e in found)
    cap = cache.cache_cap(root, total)
    kinds = sorted({*cache.KINDS, *(e.kind for e in found)})
    per_kind = {k: {"entries": sum(1 for e in found if e.kind == k), "bytes": sum(e.size for e in found if e.kind == k)}
                for k in kinds}
    if args.json:
        print(json.dumps({"location": str(root), "bytes": total, "entries": len(found), "cap_bytes": cap.bytes,
                          "cap_source": cap.source, "kinds": per_kind}, indent=2))
        return 0
    print(f"location: {root}")
    print(f"cap:      {_mib(cap.bytes)} ({cap.source})")
    print(f"{'kind':<8} {'entries':>8} {'size':>14}")
    for k, row in per_kind.items():
        print(f"{k:<8} {row['entries']:>8} {_mib(row['bytes']):>14}")
    print(f"{'total':<8} {len(found):>8} {_mib(total):>14}")
    return 0


def run_clear(args: argparse.Namespace) -> int:
    """Delete every cache entry, or those of ``--kind``, and dead kiosks' private folders; returns 0."""
    from core import cache

    root = cache.cache_root()
    count, freed = cache.clear(args.kind, root)
    noun = "entry" if count == 1 else "entries"
    print(f"removed {count} {args.kind + ' ' if args.kind else ''}{noun} ({_mib(freed)}) from {root}")
    swept = cache.sweep_private_caches()
    if swept:
        print(f"removed {len(swept)} private session folder(s) left by a kiosk that did not close normally")
    return 0
