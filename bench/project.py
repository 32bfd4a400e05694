"""``sheer bench project``: how long saving and opening a ``.sheer`` project takes.

The project has ``--layers`` layers (default 4) of ``--side``² texels (default 2048², the studio's
resolution) holding smooth thickness (0-60 µm) over about half of each map and 0 elsewhere, as painted
makeup does, stored as ``--encoding`` (default ``exr-float32``, the studio's); its head is a small
mesh written beside it and referenced (its checksums are verified on every open), not embedded.
Each of ``--repeats`` rounds saves it with :func:`project.io.save_project` (encode, validate, write a
temporary file, fsync, keep ``.bak``, rename, fsync the folder) and opens it with
:func:`project.io.open_project` (every check of ``docs/FORMAT.md``, maps decoded); one warm-up round
first is not counted.

Prints one JSON object: ``save_ms`` and ``open_ms`` (medians, ms) each with ``_p90`` (90th percentile)
and ``_max`` beside it, ``file_mb`` (the file's size, MiB), ``layers``, ``side``, ``encoding``,
``repeats``.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench.fuzz import tiny_material, write_tiny_head
from bench.stats import spread
from core.errors import SheerError
from painting.maps_io import png16_um_per_count
from project.heads import make_head_ref
from project.io import open_project, save_project
from project.model import ENCODINGS, Project, ProjectLayer


def smooth_thickness(side: int, seed: int) -> np.ndarray:
    """A float32 (side, side) thickness map in µm: smooth bumps up to 60 µm over about half the texels.

    Random values on a coarse grid (one per 64 texels), interpolated bilinearly, of which the part
    above the median is kept (the rest 0).
    """
    from PIL import Image

    coarse = np.random.default_rng(seed).random((max(side // 64, 2), max(side // 64, 2))).astype(np.float32)
    field = np.asarray(Image.fromarray(coarse, mode="F").resize((side, side), Image.Resampling.BILINEAR))
    return (np.clip(field - np.median(field), 0.0, None) * 120.0).astype(np.float32)


def bench_project(folder: Path, layers: int, side: int, encoding: str) -> Project:
    """The benchmark's project (see the module docstring), its head written into ``folder``."""
    materials = {"Foundation F": tiny_material("Foundation F"), "Blush B": tiny_material("Blush B", 2.0)}
    return Project(
        name="bench", head=make_head_ref(write_tiny_head(folder / "head")), resolution=side,
        layers=[ProjectLayer(name=f"Layer {i}", material=sorted(materials)[i % 2],
                             thickness=smooth_thickness(side, seed=i), max_thickness_um=60.0, encoding=encoding)
                for i in range(layers)],
        materials=materials,
    )


def main(argv: list[str]) -> int:
    """Run the benchmark (``argv``: its options, see ``--help``), print one JSON object; returns 0."""
    parser = argparse.ArgumentParser(prog="sheer bench project", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--layers", type=int, default=4, help="layers in the project (default 4)")
    parser.add_argument("--side", type=int, default=2048,
                        help="texels per side of each map, a multiple of 64 in 64..8192 (default 2048)")
    parser.add_argument("--encoding", choices=ENCODINGS, default="exr-float32", help="how the maps are stored")
    parser.add_argument("--repeats", type=int, default=7, help="timed save + open rounds (default 7)")
    parser.add_argument("--folder", default=None, help="where to write the project (default: a temporary folder)")
    parser.add_argument("--json", action="store_true", help="print JSON (the only format)")
    args = parser.parse_args(argv)
    if args.repeats < 1 or args.layers < 0:
        parser.error("--repeats must be at least 1 and --layers at least 0")

    save_ms: list[float] = []
    open_ms: list[float] = []
    with tempfile.TemporaryDirectory(dir=args.folder) as tmp:
        project = bench_project(Path(tmp), args.layers, args.side, args.encoding)
        path = Path(tmp) / "bench.sheer"
        for round_ in range(args.repeats + 1):  # round 0 warms up (imports, the schema, page cache)
            t0 = time.perf_counter()
            save_project(project, path, clear_recovery=False)
            t1 = time.perf_counter()
            opened = open_project(path)
            t2 = time.perf_counter()
            if round_:
                save_ms.append((t1 - t0) * 1000.0)
                open_ms.append((t2 - t1) * 1000.0)
        for saved, back in zip(project.layers, opened.layers, strict=True):  # PNG: within one count
            step = png16_um_per_count(saved.thickness) if saved.encoding == "png16" else 0.0
            if not np.allclose(saved.thickness, back.thickness, rtol=0.0, atol=step):
                raise SheerError(f"{path}: layer {saved.name!r} opened is not the layer saved")
        file_mb = path.stat().st_size / 1024**2
    result = {**spread("save_ms", save_ms, 1), **spread("open_ms", open_ms, 1), "file_mb": round(file_mb, 2),
              "layers": args.layers, "side": args.side, "encoding": args.encoding, "repeats": args.repeats}
    json.dump(result, sys.stdout, indent=2)
    print()
    return 0
