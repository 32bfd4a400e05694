#!/usr/bin/env python3
"""Build ``resources/heads/<head>.regions.png``: the sample head's facial regions (issue #16).

The regions are derived by :func:`painting.region_shapes.derive_regions` from the head's landmarks and
geometry (the paint atlas's per-texel 3D positions at 2048², averaged down to 1024²), the lips and brows refined by the albedo's
colour edges, and stored as one deterministic 8-bit PNG (:func:`painting.regions.encode_regions`): the
masks stacked top to bottom, names, feathers and sources in a text chunk. Running this script again
gives the same bytes. Usage::

    python scripts/build_head_regions.py            # rewrite resources/heads/lee-perry-smith.regions.png
    python scripts/build_head_regions.py --check    # exit 1 if the file is not what this builds
    python scripts/build_head_regions.py --head path/to/head.glb --out X.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def build(head_path: str | None) -> tuple[bytes, Path]:
    """The encoded regions of the head at ``head_path`` (None: the sample head) and their default file."""
    from painting.atlas import bake
    from painting.head import find_sidecar, load_head
    from painting.layout import build_layout
    from painting.region_shapes import derive_regions
    from painting.regions import REGION_RESOLUTION, encode_regions, regions_file

    head = load_head(head_path)
    layout = build_layout(head)
    # derived at 2× and averaged down: the outlines get sub-texel (smooth) edges
    atlas = bake(layout, 2 * REGION_RESOLUTION, cache=False)
    regions = derive_regions(head, atlas, head_uv=layout.source == "mesh")
    sidecar = find_sidecar(head.path)
    if sidecar is None:
        raise SystemExit(f"{head.path}: the head has no sidecar to store regions beside")
    if regions.missing:
        print(regions.missing_message(), file=sys.stderr)
    return encode_regions(regions), regions_file(sidecar)


def main(argv: list[str] | None = None) -> int:
    """Write (or ``--check``) the region file; returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--head", default=None, help="the head's mesh (default: the sample head)")
    parser.add_argument("--out", type=Path, default=None, help="where to write (default: beside the sidecar)")
    parser.add_argument("--check", action="store_true", help="exit 1 if the file differs from what this builds")
    args = parser.parse_args(argv)
    blob, default = build(args.head)
    out = args.out or default
    if args.check:
        same = out.is_file() and out.read_bytes() == blob
        print(f"{out}: {'up to date' if same else 'differs from what this script builds'}")
        return 0 if same else 1
    from core.atomicio import atomic_write_bytes

    atomic_write_bytes(out, blob)
    print(f"wrote {out} ({len(blob):,} bytes)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
