"""Where "Try it on me" gets the shopper's picture: a camera (OpenCV) or a watched folder.

- :class:`CameraSource`: a live camera through OpenCV's ``VideoCapture`` — a device index ("0"), a device
  path ("/dev/video2") or anything else OpenCV opens (a video file stands in for a camera in tests and
  demonstrations). QtMultimedia would be the Qt way, but PySide6-Essentials (what Sheer installs) has no
  QtMultimedia module; OpenCV is already a dependency (``colour-checker-detection``, MediaPipe).
  A camera that stops giving frames (unplugged, a video file at its end) raises :class:`CameraGone`.
- :class:`FolderSource`: a kiosk without a camera: the photo is the newest image file written into the
  watched folder after the source opened (by a tethered camera's software, a phone's upload…). The file
  is read, then **deleted**: the shopper's photograph is kept in memory only.

Frames are uint8 sRGB (H, W, 3), at most :data:`MAX_SIDE` pixels on the long side (a 10-megapixel photo
is reduced; a grey-scale or CMYK file converted to RGB; a truncated one refused with a one-line message).

The configured camera is checked when it is stored and when the kiosk starts: :func:`check_camera_setting`
refuses what can never be a camera (a word that is no device and no file, a missing file, a still image, a
file OpenCV cannot read a frame from), :func:`probe_camera` opens it and reads a frame, and
:func:`camera_at_start` says whether the camera gives pictures when the kiosk opens (a device unplugged
since is the kiosk's to report, not a reason not to start).
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import numpy as np

from core.errors import SheerError

if TYPE_CHECKING:
    from collections.abc import Iterator

log = logging.getLogger("sheer.kiosk")

#: The longest side (pixels) of a frame or photo handed to the capture; larger ones are reduced.
MAX_SIDE = 1600
#: The largest photo file a watched folder accepts (bytes).
MAX_PHOTO_BYTES = 64 * 1024 * 1024
#: Image files the watched folder takes (lower-case suffixes).
PHOTO_SUFFIXES: tuple[str, ...] = (".jpg", ".jpeg", ".png", ".tif", ".tiff", ".bmp", ".webp")
#: Consecutive failed reads after which a camera counts as gone.
GONE_AFTER_FAILED_READS = 3


class CameraError(SheerError):
    """No camera could be opened, or a photo could not be read."""


class CameraGone(CameraError):
    """The camera stopped giving frames during the preview (unplugged, switched off, at its end)."""


class CameraSettingError(CameraError):
    """The configured camera can never give pictures: no device and no file, a still image, not a video."""


class FrameSource(Protocol):
    """What the try-on screen reads pictures from."""

    live: bool  #: a live preview (a camera) rather than a photo that arrives once (a folder)

    def read(self) -> np.ndarray | None:
        """The newest picture (uint8 sRGB (H, W, 3)) or None when there is none yet."""

    def close(self) -> None:
        """Release the device (idempotent)."""


def fit_frame(rgb: np.ndarray) -> np.ndarray:
    """``rgb`` (uint8 (H, W, 3)) reduced so its long side is at most :data:`MAX_SIDE` (area averaging)."""
    h, w = rgb.shape[:2]
    scale = MAX_SIDE / max(h, w)
    if scale >= 1.0:
        return np.ascontiguousarray(rgb)
    import cv2

    return np.ascontiguousarray(cv2.resize(rgb, (max(1, round(w * scale)), max(1, round(h * scale))),
                                           interpolation=cv2.INTER_AREA))


def read_photo_file(path: Path) -> np.ndarray:
    """A photo file as uint8 sRGB (H, W, 3).

    Grey-scale, palette, CMYK and alpha are converted, the EXIF orientation applied, and the photo
    reduced by :func:`fit_frame`.

    Raises:
        CameraError: not an image, truncated, or too large — the message names the file.
    """
    import io

    from PIL import Image

    from core.files import read_bounded
    from core.photos import upright

    data = read_bounded(path, MAX_PHOTO_BYTES, "photo", CameraError)
    try:
        with Image.open(io.BytesIO(data)) as im:
            im.load()
            rgb = upright(im).convert("RGB")
    except (OSError, ValueError, SyntaxError, Image.DecompressionBombError) as exc:
        raise CameraError(f"{path}: not a readable photo ({exc})") from None
    return fit_frame(np.asarray(rgb, dtype=np.uint8))


class CameraSource:
    """A camera through OpenCV (see the module docstring).

    Args:
        device: "auto" (device 0), a device index ("0", "1"…), or a path OpenCV opens.

    Raises:
        CameraError: the camera could not be opened or gives no first frame.
    """

    live = True

    def __init__(self, device: str = "auto") -> None:
        import cv2

        self.device = device
        spec: int | str = 0 if device in ("", "auto") else int(device) if device.isdigit() else device
        with _quiet_stderr():  # OpenCV and FFmpeg print their own lines about a device they cannot open
            self._cap = cv2.VideoCapture(spec)
        self._failed = 0
        self._last: np.ndarray | None = None
        if not self._cap.isOpened():
            self._cap.release()
            raise CameraError(f"no camera could be opened at {device!r} (camera in the kiosk configuration; "
                              f"'off' disables it)")
        if self.read() is None:
            self.close()
            raise CameraError(f"the camera {device!r} opened but gives no picture")

    def read(self) -> np.ndarray | None:
        """The camera's next frame (uint8 sRGB).

        Raises:
            CameraGone: after :data:`GONE_AFTER_FAILED_READS` reads in a row gave no frame.
        """
        if self._cap is None:
            raise CameraGone("the camera was closed")
        ok, bgr = self._cap.read()
        if not ok or bgr is None:
            self._failed += 1
            if self._failed >= GONE_AFTER_FAILED_READS:
                self.close()
                raise CameraGone(f"the camera {self.device!r} stopped giving pictures")
            return self._last
        self._failed = 0
        if bgr.ndim == 2:
            bgr = np.repeat(bgr[:, :, None], 3, axis=2)
        self._last = fit_frame(np.ascontiguousarray(bgr[:, :, 2::-1]))
        return self._last

    def close(self) -> None:
        """Release the device."""
        if self._cap is not None:
            self._cap.release()
            self._cap = None
        self._last = None


class FolderSource:
    """The newest photo written into ``folder`` after this source opened (read once, then deleted).

    Args:
        folder: the watched folder (made if missing).
        settle_s: a file must be unchanged (size and time) for this long (s) before it is read, so a photo
            still being written is not taken half-written.
    """

    live = False

    def __init__(self, folder: str | Path, settle_s: float = 0.3) -> None:
        self.folder = Path(folder)
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise CameraError(f"{folder}: the watched folder cannot be used ({exc.strerror or exc})") from None
        self.settle_s = settle_s
        self.since = time.time()
        self._seen: dict[Path, tuple[int, float, float]] = {}  # path → (size, mtime, first seen unchanged)

    def _newest(self) -> Path | None:
        now = time.time()
        best: tuple[float, Path] | None = None
        try:
            entries = list(self.folder.iterdir())
        except OSError:
            return None
        for p in entries:
            if p.suffix.lower() not in PHOTO_SUFFIXES or p.name.startswith("."):
                continue
            try:
                st = p.stat()
            except OSError:
                continue
            if st.st_mtime < self.since - 1.0:
                continue  # there before the shopper's session: not hers
            key = (st.st_size, st.st_mtime)
            seen = self._seen.get(p)
            if seen is None or seen[:2] != key:
                self._seen[p] = (*key, now)
                continue
            if now - seen[2] >= self.settle_s and (best is None or st.st_mtime > best[0]):
                best = (st.st_mtime, p)
        return best[1] if best else None

    def read(self) -> np.ndarray | None:
        """The photo once one has arrived and settled (then deleted from the folder), else None.

        Raises:
            CameraError: the file is not a readable photo (it is deleted too: it is the shopper's).
        """
        path = self._newest()
        if path is None:
            return None
        try:
            return read_photo_file(path)
        finally:
            self._seen.pop(path, None)
            try:
                path.unlink()
            except OSError as exc:
                log.warning("kiosk: could not delete the shopper's photo %s (%s)", path.name, exc)

    def close(self) -> None:
        """Nothing to release (the folder stays)."""
        self._seen.clear()


def camera_present(camera: str) -> bool:
    """Whether the configured camera can be there at all, without opening it.

    "auto": a ``/dev/video*`` device exists; an index N: ``/dev/videoN``; a path: the file exists; "off":
    False. (Opening a camera takes it from whoever else uses it; the kiosk only opens it on "Try it on me".)
    """
    spec = camera.strip()
    if spec.lower() == "off":
        return False
    if spec in ("", "auto"):
        return any(Path("/dev").glob("video*"))
    if spec.isdigit():
        return Path(f"/dev/video{spec}").exists()
    return Path(spec).exists()


#: What a camera setting may be, for the messages that refuse one.
CAMERA_CHOICES = "auto, off, a device index (0, 1…), a device path (/dev/video2) or a video file"


@contextlib.contextmanager
def _quiet_stderr() -> Iterator[None]:
    """Send file descriptor 2 to /dev/null for the block (OpenCV and FFmpeg write there from C)."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):  # no real standard error: nothing to quieten
        yield
        return
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _is_still_image(path: Path) -> bool:
    """Whether ``path`` is a still image (by its suffix, or a picture Pillow recognises)."""
    if path.suffix.lower() in PHOTO_SUFFIXES:
        return True
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            return getattr(im, "n_frames", 1) == 1
    except (UnidentifiedImageError, OSError, ValueError):
        return False


def is_device(camera: str) -> bool:
    """Whether the camera setting names a video device: an index ("0") or a path under ``/dev``."""
    spec = camera.strip()
    return spec.isdigit() or spec.startswith("/dev/")


def check_camera_setting(camera: str) -> str:
    """The camera setting ``camera``, checked and normalised (a video file's path made absolute).

    "auto" (also ""), "off" and a device (an index, a path under ``/dev``) are taken as they are: a
    device is opened by :func:`probe_camera`. Anything else is a video file: it must exist, not be a
    still image (the watched folder takes photos), and give a frame.

    Raises:
        CameraSettingError: one line naming the setting and what is wrong.
    """
    spec = camera.strip()
    if spec.lower() in ("", "auto", "off"):
        return spec.lower() or "auto"
    if is_device(spec):
        return str(int(spec)) if spec.isdigit() else spec
    path = Path(spec).expanduser()
    if not path.exists():
        raise CameraSettingError(f"camera {spec!r}: no such device or file; the camera is {CAMERA_CHOICES}")
    if path.is_dir():
        raise CameraSettingError(f"camera {spec!r}: is a folder, not a camera; a folder the photo is taken from "
                                 f"is set with --watch-dir DIR")
    if _is_still_image(path):
        raise CameraSettingError(f"camera {spec!r}: is a still image, not a camera or a video; to take the "
                                 f"shopper's photo from image files, use a watched folder "
                                 f"(sheer kiosk --camera off --watch-dir DIR)")
    try:
        probe_camera(str(path.resolve()))
    except CameraError:
        raise CameraSettingError(f"camera {spec!r}: not a video OpenCV can read a frame from") from None
    return str(path.resolve())


def probe_camera(camera: str) -> None:
    """Open the camera ``camera`` (a device or a video file), read one frame and release it.

    Raises:
        CameraError: one line naming the camera and what is wrong (no such device, no picture).
    """
    spec = camera.strip()
    if spec.isdigit() and not Path(f"/dev/video{int(spec)}").exists():
        raise CameraError(f"camera {spec}: there is no video device /dev/video{int(spec)}")
    if spec.startswith("/dev/") and not Path(spec).exists():
        raise CameraError(f"camera {spec}: no such device")
    CameraSource(spec).close()


def camera_at_start(camera: str) -> tuple[bool, str]:
    """Whether the configured camera gives pictures as the kiosk starts, and why not.

    Returns:
        (works, why): ``why`` is "" when it works or when none is configured ("off", or "auto" on a
        machine with no video device); else what is wrong, in one line, for the log.
    """
    spec = camera.strip()
    if spec.lower() == "off":
        return False, ""
    if spec.lower() in ("", "auto"):
        if not any(Path("/dev").glob("video*")):
            return False, ""
        spec = "auto"
    try:
        if spec == "auto":
            CameraSource("auto").close()
        elif is_device(spec):
            probe_camera(spec)
        else:
            check_camera_setting(spec)  # a video file: there, and giving a frame
    except CameraError as exc:
        return False, str(exc)
    return True, ""


def open_source(camera: str, watch_dir: str) -> FrameSource:
    """The picture source a kiosk configuration names: its camera unless "off", else its watched folder.

    A configured camera that cannot be opened falls back to the watched folder when there is one.

    Raises:
        CameraError: neither a camera nor a watched folder can be used.
    """
    if camera.strip().lower() != "off":
        try:
            return CameraSource(camera.strip())
        except CameraError as exc:
            if not watch_dir:
                raise
            log.warning("kiosk: %s; taking photos from the watched folder %s", exc, watch_dir)
    if not watch_dir:
        raise CameraError("the camera is off in the kiosk configuration and there is no watched folder")
    return FolderSource(watch_dir)
