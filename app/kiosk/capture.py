"""The capture behind the kiosk's "Try it on me", without Qt (the bench times it too).

:func:`prepare_shopper` turns her photograph into her face folder (:func:`capture.auto.capture_auto`,
with the kiosk's calibrated light from :func:`capture_probe`) and her document with the look on screen.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from app.kiosk.config import KioskConfig, KioskLook
    from app.session import Session
    from capture.probe import ProbeAnalysis
    from km.library import Library
    from painting import Document
    from shade.photo import PhotoSkin

log = logging.getLogger("sheer.kiosk")

#: The largest thickness-map resolution of her document (texels per side): her face in a camera frame is a few
#: hundred pixels across, and replaying a look costs about 4x more at 1024 (2.4 s measured).
SHOPPER_RESOLUTION = 512
#: The side of her detail texture (texels): her face fills at most a screen's height.
SHOPPER_TEXTURE = 512


def warm_up() -> None:
    """Load what the capture needs (its modules, MediaPipe's face detector) before the first shopper.

    Run once in the background when a kiosk that offers "Try it on me" starts: measured here, a try-on
    in a fresh process takes ~12.5 s from the shutter, one after this ~5.5 s (imports 1.3 s, the
    detector's first call, and first-use costs in the capture).
    """
    import importlib

    from capture.auto import warm_up as warm_up_capture
    from capture.landmarks import detect_faces

    warm_up_capture()  # the capture's own: MediaPipe's detector, the canonical topology, its libraries
    for name in ("capture.quality", "painting.looks", "painting.transfer", "render.mirror"):
        importlib.import_module(name)
    detect_faces(np.zeros((64, 64, 3), np.uint8))  # the detector's first call


def capture_probe(config: KioskConfig) -> ProbeAnalysis | None:
    """The light the capture assumes: the kiosk's calibrated light, or None (a white flash on the axis)."""
    return config.probe()


@dataclass
class Shopper:
    """Her capture, in memory and in the session's private folder.

    Attributes:
        face: her captured face (``capture.face.Face``); head: her head; session: her document.
        photo: her photograph as shot (uint8 sRGB (H, W, 3), its own resolution: the camera frame, not the
            reduced copy the capture may have fitted the face on).
        folder: the face folder (inside the private folder).
        timings: seconds per step ("capture_s", "document_s", "look_s").
        skin: her skin read from her photograph, (linear sRGB, note), once read (``()``: unreadable).
    """

    face: Any
    head: Any
    session: Session
    photo: np.ndarray
    folder: Path
    timings: dict[str, float] = field(default_factory=dict)
    skin: tuple[Any, ...] | None = None


def look_to_replay(looks: Sequence[KioskLook], key: str) -> str:
    """The ``look`` :func:`prepare_shopper` takes for the kiosk look ``key`` among ``looks``.

    A built-in look's name (replayed on her head), or "" for a project's look, whichever its key (its layers
    are carried onto her head from the document on screen); ``key`` itself when it is none of ``looks``.
    """
    shown = next((lk for lk in looks if lk.key == key), None)
    return key if shown is None else shown.builtin


def prepare_shopper(photo: np.ndarray, folder: Path, *, probe: ProbeAnalysis | None, library: Library,
                    resolution: int, look: str, source_doc: Document | None = None,
                    progress: Callable[[str], None] | None = None) -> Shopper:
    """Capture her face from ``photo`` into ``folder`` and make her document with ``look`` on it.

    Args:
        photo: uint8 sRGB (H, W, 3).
        folder: the face folder to write (inside a private folder; it must not exist yet).
        probe: the kiosk's light, or None.
        library: the kiosk's materials.
        resolution: texels per side of her thickness maps.
        look: a built-in look name to replay, or "project" to transfer ``source_doc``'s layers.
        source_doc: the document on screen (for "project", and when a look cannot be replayed on her head).
        progress: called with one line per step.

    Raises:
        capture.quality.QualityError: the photo is refused (its ``issues`` say why, kindly).
        core.errors.SheerError: anything else that went wrong, in one line.
    """
    from app.session import Session
    from capture.auto import capture_auto
    from core.errors import SheerError
    from painting import Document

    timings: dict[str, float] = {}
    t = time.perf_counter()
    face = capture_auto(photo, folder, probe=probe, progress=progress, texture_size=SHOPPER_TEXTURE, full_head=True)
    timings["capture_s"] = time.perf_counter() - t
    t = time.perf_counter()
    head = face.load_head()
    # her photograph itself, at its own resolution: the capture fits a reduced copy when her face is large
    # (face.json ``downscale``), the mirror view and Save Photo draw on the original
    shot = np.ascontiguousarray(np.asarray(photo, dtype=np.uint8)[..., :3])
    doc = Document(head, resolution=resolution, library=library)
    session = Session(library, doc)
    timings["document_s"] = time.perf_counter() - t
    t = time.perf_counter()
    if look in ("", "project") and source_doc is not None:
        from painting.transfer import transfer_layers

        transfer_layers(source_doc, doc)
        doc.clear_history()
    elif look:
        try:
            session.apply_look(look)
        except SheerError as exc:
            if source_doc is None:
                raise
            log.warning("kiosk: the look %s could not be replayed on her face (%s); transferring it", look, exc)
            from painting.transfer import transfer_layers

            transfer_layers(source_doc, doc)
            doc.clear_history()
    timings["look_s"] = time.perf_counter() - t
    return Shopper(face, head, session, shot, Path(folder), timings)


def shopper_skin(face: Any) -> PhotoSkin | None:
    """Her skin colour read from her photograph (:func:`capture.skin.skin_from_face`), or None.

    The reading ``sheer shade match --photo`` makes too: the band across both cheeks at the height of her
    ``left_cheek`` / ``right_cheek`` landmarks, colour-corrected when a ColorChecker is in the frame. None
    when the face folder has no photograph or landmarks, or the photograph cannot be read (logged; the
    caller then uses the fitted diffuse colour).
    """
    from capture.skin import skin_from_face
    from shade.photo import PhotoError

    try:
        return skin_from_face(face)
    except PhotoError as exc:
        log.warning("kiosk: her skin could not be read from her photograph (%s)", exc)
        return None
