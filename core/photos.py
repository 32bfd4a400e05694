"""A photograph the way its camera meant it to be seen.

Every reader of a user's photograph calls :func:`upright`, so the capture (automatic, ``--points``, ``--camera``), the mirror-ball probe and
``sheer kiosk --calibrate-light``, ``sheer render --view mirror --photo``, ``sheer shade match --photo`` and
the kiosk's watched folder all see the same pixels.

A phone or camera held sideways stores the sensor's pixels as they came and an EXIF Orientation tag (1–8:
the rotations by 90°, 180°, 270° and their mirror images) that says how to show them; a reader that ignores
it sees the face lying on its side (a landmark detector finds none) or mirrored.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from PIL import Image


def upright(im: Image.Image) -> Image.Image:
    """``im`` with its EXIF orientation applied (the tag then removed), or ``im`` itself when it has none.

    Pillow's :func:`PIL.ImageOps.exif_transpose` does the work; this is the one place Sheer calls it.
    """
    from PIL import ImageOps

    turned = ImageOps.exif_transpose(im)
    return im if turned is None else turned
