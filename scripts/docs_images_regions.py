"""Rebuild the docs' images of the looks' regions and the lips' finishes: the red-lip look in fast mode,
close-ups of the lips and eyes (bare and made up), and the red lipstick's finishes side by side.

    .venv/bin/python scripts/docs_images_regions.py [--out docs/images]

Writes ``render_red-lip_fast.png`` (1280×720, the renderer's default view and lights) and
``regions_red-lip_before_after.png`` (four 640×350 close-ups with captions and the head's credit) and
``finishes_lips.png`` (five 330×165 close-ups of the lips: each red finish filled 20 µm into the lips region,
and the bare lips). Rendered headless (standalone EGL), in the fast mode, with the studio's default lights.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

#: Close-ups: (caption, look or None for the bare head, landmark aimed at, distance in mm).
PANELS = (
    ("bare lips", None, "lip_centre", 75.0),
    ("red-lip: the lips region, 0.5 mm feather", "red-lip", "lip_centre", 75.0),
    ("red-lip: foundation off the lids and brows", "red-lip", "nasion", 125.0),
    ("evening: eyeshadow lid -> crease, liner on the lash line", "evening", "nasion", 125.0),
)
PANEL = (640, 350)
#: The lips' finishes: (caption, material or None for the bare lips), each filled 20 µm into the lips region.
FINISHES = (
    ("matte", "Lipstick Red Matte"),
    ("satin", "Lipstick Red Satin"),
    ("gloss", "Lipstick Red Gloss"),
    ("sheer (satin)", "Lipstick Sheer Red"),
    ("bare", None),
)
FINISH_PANEL = (330, 165)
CREDIT = "Head: Infinite, 3D Head Scan by Lee Perry-Smith, CC BY 3.0 (triplegangers.com)"


def _render(ctx: object, head: object, look: str | None, size: tuple[int, int],
            aim: tuple[str, float] | None, lipstick: str | None = None) -> np.ndarray:
    """One fast-mode frame of ``head`` with ``look`` (None: bare) or ``lipstick`` (a material filled 20 µm into
    the lips region), aimed at a landmark from a distance (mm)."""
    from painting import Document
    from painting.looks import apply_look
    from render import DocumentBinding, Renderer

    doc = Document(head, resolution=2048)
    if look is not None:
        apply_look(doc, look)
    if lipstick is not None:
        doc.fill_region(doc.add_layer(lipstick), "lips", 20.0)
    renderer = Renderer(ctx, head, layout=doc.layout)  # type: ignore[arg-type]
    binding = DocumentBinding(doc, renderer)
    try:
        binding.flush()
        renderer.settings.mode = "fast"
        if aim is not None:
            name, mm = aim
            cam = renderer.camera
            cam.target = np.asarray(head.metadata.landmarks[name], dtype=float)  # type: ignore[attr-defined]
            cam.distance = mm / head.metadata.mm_per_unit  # type: ignore[attr-defined]
        return renderer.render_image(size)
    finally:
        binding.close()
        renderer.release()


def _caption(img: np.ndarray, text: str, bottom: bool = False) -> np.ndarray:
    from PIL import Image, ImageDraw

    pil = Image.fromarray(img)
    draw = ImageDraw.Draw(pil)
    w = int(draw.textlength(text)) + 10
    y = pil.height - 18 if bottom else 0
    draw.rectangle((0, y, w, y + 17), fill=(0, 0, 0))
    draw.text((5, y + 3), text, fill=(255, 255, 255))
    return np.asarray(pil)


def main(argv: list[str] | None = None) -> int:
    """Render and write the images (see the module docstring)."""
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=Path, default=REPO / "docs" / "images")
    args = p.parse_args(argv)

    from PIL import Image

    from painting.head import load_head
    from render.context import standalone_context

    head = load_head(None)
    ctx = standalone_context()
    try:
        full = _render(ctx, head, "red-lip", (1280, 720), None)
        Image.fromarray(_caption(full, CREDIT, bottom=True)).save(args.out / "render_red-lip_fast.png")
        tiles = [_caption(_render(ctx, head, look, PANEL, (lm, mm)), text) for text, look, lm, mm in PANELS]
        finishes = [_caption(_render(ctx, head, None, FINISH_PANEL, ("lip_centre", 75.0), material), text)
                    for text, material in FINISHES]
    finally:
        ctx.release()
    grid = np.concatenate([np.concatenate(tiles[:2], axis=1), np.concatenate(tiles[2:], axis=1)], axis=0)
    Image.fromarray(_caption(grid, CREDIT, bottom=True)).save(args.out / "regions_red-lip_before_after.png")
    Image.fromarray(np.concatenate(finishes, axis=1)).save(args.out / "finishes_lips.png")
    print(f"wrote {args.out / 'render_red-lip_fast.png'}, {args.out / 'regions_red-lip_before_after.png'} "
          f"and {args.out / 'finishes_lips.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
