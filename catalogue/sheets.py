"""Contact sheets: one PNG per product and view, faces (head × look) down, lights across.

A merchandiser checks a range at a glance: every cell is a thumbnail of the rendered image (at most
:data:`CELL` pixels a side) under a caption; a missing or failed image is a grey cell saying so.
"""

from __future__ import annotations

import functools
from typing import IO, TYPE_CHECKING, Any

if TYPE_CHECKING:
    from pathlib import Path

    from catalogue.jobs import Job

#: Largest thumbnail side, pixels; caption height, pixels.
CELL, CAPTION = 192, 16


def sheet_groups(folder: Path, jobs: list[Job], only_if_changed: bool = False) -> dict[Path, list[Job]]:
    """The contact sheets of a catalogue: ``sheets/<product>-<view>.png`` → its image jobs.

    Args:
        folder: the output folder.
        jobs: the catalogue's jobs (GLB jobs are ignored).
        only_if_changed: leave out sheets that already exist (nothing was rendered since they were made).
    """
    from catalogue.jobs import sheet_name

    groups: dict[Path, list[Job]] = {}
    for job in jobs:
        if job.kind == "image" and job.view is not None:
            groups.setdefault(folder / "sheets" / sheet_name(job), []).append(job)
    return {path: items for path, items in groups.items() if not (only_if_changed and path.exists())}


def write_sheet(folder: Path, path: Path, items: list[Job]) -> Path:
    """Draw one contact sheet of ``items`` (faces down, lights across) from the images in ``folder``.

    Runs anywhere that sees ``folder`` (the driver, or a Dask worker: sheets are independent). Written
    atomically.

    Returns:
        ``path``.
    """
    from PIL import Image, ImageDraw

    from core.atomicio import atomic_write_with

    rows = list(dict.fromkeys((j.head.name, j.look.name) for j in items))
    cols = list(dict.fromkeys(j.light.name for j in items if j.light is not None))
    w, h = items[0].size
    scale = CELL / max(w, h)
    cw, ch = max(1, round(w * scale)), max(1, round(h * scale))
    sheet = Image.new("RGB", (len(cols) * cw, len(rows) * (ch + CAPTION)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for job in items:
        assert job.light is not None
        r, c = rows.index((job.head.name, job.look.name)), cols.index(job.light.name)
        x, y = c * cw, r * (ch + CAPTION)
        try:
            with Image.open(folder / job.out) as im:
                sheet.paste(im.convert("RGB").resize((cw, ch), Image.Resampling.LANCZOS), (x, y + CAPTION))
        except OSError:
            draw.rectangle((x, y + CAPTION, x + cw - 1, y + CAPTION + ch - 1), fill=(200, 200, 200))
            draw.text((x + 4, y + CAPTION + 4), "missing or failed", fill=(120, 0, 0))
        draw.text((x + 3, y + 2), f"{job.head.name} · {job.look.name} · {job.light.name}"[:40], fill=(0, 0, 0))
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_with(path, functools.partial(_save_png, sheet))
    return path


def _save_png(image: Any, fh: IO[bytes]) -> None:
    image.save(fh, format="PNG")
