"""The photograph's focal length, as its file carries it (EXIF), in pixels for :func:`capture.camera.calibrate`.

A face's landmarks are nearly planar and seen almost orthographically, so they cannot tell the focal
length from the distance: without it :func:`capture.camera.calibrate` falls back on a weak portrait-lens
prior, and the rotation compensates a wrong distance (issue 14: on the bench's 45 scenes the calibrated
focal was 0.37–1.34 × the true one). A camera writes it into the file:

- **FocalLengthIn35mmFilm** (tag 0xA405, whole millimetres): the 35 mm-equivalent focal length. Taken,
  as CIPA DC-008 defines the equivalence, over the diagonal: f_px = F35 · √(w² + h²) / √(36² + 24²)
  for a w × h photograph (the image as stored; a crop changes the field and is not detected).
- otherwise **FocalLength** (0x920A, mm) with **FocalPlaneXResolution** (0xA20E) and
  **FocalPlaneResolutionUnit** (0xA210: 2 inch, 3 cm, 4 mm, 5 µm): the sensor's pixels per unit at
  **ExifImageWidth** (0xA002, else the image's width), so f_px = FocalLength · pixels per mm · w / that
  width.

Pillow reads the tags from JPEG, PNG (eXIf chunk) and TIFF files. A tag that is there but unusable (not
a number, zero, negative, or a focal length outside :data:`FOCAL_35MM_RANGE`) is **ignored with a
warning**: the photograph is still a photograph, and the capture then calibrates as it does without a
focal length. ``sheer capture --focal-mm F35`` gives the 35 mm-equivalent focal length by hand (and
overrides the file's).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from capture.errors import CaptureError

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

#: The 35 mm-equivalent focal lengths accepted (mm): a 4 mm fisheye-ish phone lens to an 2,000 mm
#: super-telephoto; anything outside is a corrupt tag (or a typo on the command line).
FOCAL_35MM_RANGE = (4.0, 2000.0)
#: The 35 mm frame's diagonal (mm): √(36² + 24²).
FRAME_DIAGONAL_MM = math.hypot(36.0, 24.0)
#: FocalPlaneResolutionUnit → millimetres per unit (EXIF 2.3: 2 inch, 3 cm; 4 mm and 5 µm are common
#: extensions).
_UNIT_MM = {2: 25.4, 3: 10.0, 4: 1.0, 5: 0.001}
_EXIF_IFD = 0x8769
_FOCAL_35 = 0xA405
_FOCAL = 0x920A
_PLANE_X_RES = 0xA20E
_PLANE_UNIT = 0xA210
_EXIF_WIDTH = 0xA002


def focal_px_from_35mm(focal_35mm: float, width: int, height: int) -> float:
    """The focal length in pixels of a ``width`` × ``height`` photograph whose 35 mm equivalent is ``focal_35mm`` (mm).

    Raises :class:`CaptureError` (one line) for a value that is not a number in :data:`FOCAL_35MM_RANGE`.
    """
    lo, hi = FOCAL_35MM_RANGE
    if not (isinstance(focal_35mm, (int, float)) and lo <= focal_35mm <= hi):  # NaN fails too
        raise CaptureError(f"the 35 mm-equivalent focal length must be {lo:g}–{hi:g} mm, got {focal_35mm}")
    return float(focal_35mm) * math.hypot(width, height) / FRAME_DIAGONAL_MM


def focal_35mm_from_px(focal_px: float, width: int, height: int) -> float:
    """The 35 mm-equivalent focal length (mm, unrounded) of a focal length ``focal_px`` (pixels) at ``width`` × ``height``."""
    return float(focal_px) * FRAME_DIAGONAL_MM / math.hypot(width, height)


def _number(value: object) -> float | None:
    """A tag's value as a finite float, or None (Pillow gives IFDRational, int, or a tuple for some writers)."""
    if isinstance(value, tuple) and len(value) == 2:  # (numerator, denominator)
        value = value[0] / value[1] if value[1] else None
    try:
        out = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, ZeroDivisionError):
        return None
    return out if math.isfinite(out) else None


def exif_focal_px(path: str | Path, warn: Callable[[str], None] | None = None) -> float | None:
    """The photograph's focal length in pixels from its EXIF (see the module docstring), or None.

    None when the file has no EXIF focal length, or when the tag is unusable (then ``warn`` is called
    with one line saying which tag and why). Raises :class:`CaptureError` only if the file cannot be
    opened as an image.
    """
    from PIL import Image, UnidentifiedImageError

    def ignored(msg: str) -> None:
        if warn is not None:
            warn(f"{path}: {msg}; the focal length is not used")

    try:
        with Image.open(path) as im:
            width, height = im.size
            try:
                exif = im.getexif()
                sub = dict(exif.get_ifd(_EXIF_IFD))
            except Exception as exc:  # noqa: BLE001 - Pillow raises many kinds on a corrupt EXIF block
                ignored(f"unreadable EXIF ({type(exc).__name__})")
                return None
    except FileNotFoundError:
        raise CaptureError(f"{path}: photo not found") from None
    except (UnidentifiedImageError, OSError, Image.DecompressionBombError) as exc:
        raise CaptureError(f"{path}: cannot read the image: {exc}") from None
    tags = {**dict(exif), **sub}
    lo, hi = FOCAL_35MM_RANGE
    if _FOCAL_35 in tags:
        f35 = _number(tags[_FOCAL_35])
        if f35 is None or not lo <= f35 <= hi:
            ignored(f"EXIF FocalLengthIn35mmFilm is {tags[_FOCAL_35]!r}, not {lo:g}–{hi:g} mm")
            return None
        return focal_px_from_35mm(f35, width, height)
    if _FOCAL in tags and _PLANE_X_RES in tags:
        focal = _number(tags[_FOCAL])
        res = _number(tags[_PLANE_X_RES])
        unit_mm = _UNIT_MM.get(int(_number(tags.get(_PLANE_UNIT, 2)) or 0))
        ref_width = _number(tags.get(_EXIF_WIDTH, width)) or 0.0
        if focal is None or res is None or unit_mm is None or focal <= 0 or res <= 0 or ref_width <= 0:
            ignored("EXIF FocalLength / FocalPlaneXResolution / FocalPlaneResolutionUnit are not usable numbers")
            return None
        f_px = focal * res / unit_mm * width / ref_width
        if not lo <= focal_35mm_from_px(f_px, width, height) <= hi:
            ignored(f"EXIF FocalLength {focal:g} mm on that sensor is not {lo:g}–{hi:g} mm in 35 mm terms")
            return None
        return f_px
    return None
