"""A portrait's skin colour: the one reading behind ``sheer shade match --photo`` and the kiosk's *Find my foundation*.

The skin is read on a band across both cheeks: from the left to the right ``*_cheek`` landmark (the apples,
level with the nose's tip: :data:`capture.landmarks.STANDARD_LANDMARKS`) and between their heights,
widened on every side by :data:`CHEEK_PAD` of the eyes' distance. Its colour is
:func:`shade.photo.skin_from_photo`'s: the median of the pixels between the 20th and 80th luminance
percentiles (the nose's highlight and the shadows drop out), colour-corrected with a ColorChecker when the
photograph holds one.

- :func:`skin_from_portrait`: a photograph file; MediaPipe finds the face (:func:`capture.landmarks.detect_faces`,
  the largest when there are several); no face is a :class:`shade.photo.PhotoError` that says so.
- :func:`skin_from_face`: a face folder of the automatic capture (the kiosk's shopper), from the landmarks
  face.json holds and the photograph it was captured from.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

    from shade.photo import PhotoSkin

__all__ = ["CHEEK_PAD", "cheek_band", "skin_from_landmarks", "skin_from_portrait", "skin_from_face"]

#: The band's margin around the cheek landmarks, as a fraction of the eyes' distance.
CHEEK_PAD = 0.15
#: The band's smallest side (pixels) that is read.
MIN_BAND_PX = 4


def cheek_band(standard: Mapping[str, Sequence[float]], width: int, height: int) -> tuple[int, int, int, int] | None:
    """The cheek band (x, y, w, h pixels, inside the photograph) of a face's standard landmarks, or None.

    ``standard``: name → (x, y) pixels (:meth:`capture.landmarks.FaceLandmarks.standard`, or face.json's
    ``landmarks.standard``); None when a landmark is missing or the band is under :data:`MIN_BAND_PX` a side.
    """
    try:
        (lx, ly), (rx, ry) = (tuple(float(v) for v in standard[k]) for k in ("left_cheek", "right_cheek"))
        (ex1, ey1), (ex2, ey2) = (tuple(float(v) for v in standard[k]) for k in ("left_eye", "right_eye"))
    except (KeyError, TypeError, ValueError):
        return None
    pad = CHEEK_PAD * float(np.hypot(ex1 - ex2, ey1 - ey2))
    x0, x1 = max(0, int(min(lx, rx) - pad)), min(int(width), int(np.ceil(max(lx, rx) + pad)))
    y0, y1 = max(0, int(min(ly, ry) - pad)), min(int(height), int(np.ceil(max(ly, ry) + pad)))
    if x1 - x0 < MIN_BAND_PX or y1 - y0 < MIN_BAND_PX:
        return None
    return x0, y0, x1 - x0, y1 - y0


def skin_from_landmarks(photo: str | Path, standard: Mapping[str, Sequence[float]], width: int, height: int, *,
                        use_checker: bool = True) -> PhotoSkin:
    """The skin on the cheek band of ``standard`` (landmarks in pixels of ``photo``, ``width`` × ``height``).

    Raises:
        shade.photo.PhotoError: the photograph cannot be read, or the landmarks give no band to read.
    """
    from shade.photo import PhotoError, skin_from_photo

    band = cheek_band(standard, width, height)
    if band is None:
        raise PhotoError(f"{photo}: the face's cheeks are too small or not found to read the skin on")
    return skin_from_photo(photo, band, use_checker=use_checker, source="face")


def skin_from_portrait(path: str | Path, *, use_checker: bool = True) -> PhotoSkin:
    """The skin of the largest face in a photograph file (module docstring).

    Raises:
        shade.photo.PhotoError: an unreadable photograph, or no face in it (the message offers ``--region``).
        capture.landmarks.LandmarkError: MediaPipe is missing or cannot start.
    """
    from capture.landmarks import detect_faces
    from shade.photo import PhotoError, read_photo

    encoded = read_photo(path)
    faces = detect_faces(np.round(encoded * 255.0).astype(np.uint8)) if min(encoded.shape[:2]) >= 32 else []
    if not faces:
        raise PhotoError(f"{path}: no face found in the photograph; give the skin's region with --region x,y,w,h "
                         "(pixels)")
    face = faces[0]
    return skin_from_landmarks(path, face.standard(), face.width, face.height, use_checker=use_checker)


def skin_from_face(face: Any, *, use_checker: bool = True) -> PhotoSkin | None:
    """The skin of a captured face (:class:`capture.face.Face`) from its photograph, or None.

    None when face.json holds no landmarks or camera, or names no photograph that exists (the caller then
    uses the fitted diffuse colour); a photograph that cannot be read raises, as :func:`skin_from_landmarks`.
    """
    photo = face.photo_path
    landmarks = face.data.get("landmarks")
    if photo is None or not Path(photo).is_file() or not isinstance(landmarks, dict) or not face.has_camera:
        return None
    camera = face.camera()
    if cheek_band(landmarks.get("standard") or {}, camera.width, camera.height) is None:
        return None
    return skin_from_landmarks(photo, landmarks["standard"], camera.width, camera.height, use_checker=use_checker)
