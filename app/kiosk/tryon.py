"""The kiosk's "Try it on me": from the camera (or a watched folder) to the shopper's own made-up face.

The flow (:class:`TryOn`, one per kiosk):

1. **Camera screen** (:class:`app.kiosk.camera_page.CameraPage`): live preview, framing oval, the quality
   gate's messages as prompts, a countdown, the shutter.
2. **Capture** in the thread pool (:func:`prepare_shopper`): :func:`capture.auto.capture_auto` builds her
   head and face folder in the session's private folder (``core.cache.PrivateCache``: mode 0700 under the
   temporary directory, removed when the session ends), with the kiosk's calibrated light
   (:func:`capture_probe`) or the flash-on-axis default; then a document on her head with the look on
   screen replayed (built-in looks are strokes at landmarks) or, for a project, transferred
   (:func:`painting.transfer.transfer_layers`). A refusal by the quality gate goes back to the camera
   screen with its friendly message; anything else back to the start screen.
3. **Her face** on the try-on screen, in place of the sample head: the mirror view (her photograph
   with the makeup) or the relit view (turnable, under the light presets), drawn by
   :class:`app.kiosk.shopper.ShopperRenderer`; the looks, product swaps, foundation finder, light presets
   and before/after act on her document. The mirror view is at her photograph's own resolution and
   shown flipped left–right, as a mirror shows her. Done or the idle timeout ends the session: her views,
   document, photograph and private folder are dropped. Only Save Photo writes anything: her made-up
   photograph at its full resolution as a camera shows her (not flipped, no before/after line), and with
   the before/after slider on, the pair side by side in a second file (:meth:`TryOn.save_image`).

:attr:`TryOn.timings` records ``tryon_first_frame_s``: the shutter to her first made-up frame on screen.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

import numpy as np
from PySide6.QtCore import QObject, Qt, Signal
from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget

from app.kiosk.camera_page import PRIVACY_LINE, CameraPage
from app.kiosk.capture import (
    SHOPPER_RESOLUTION,
    Shopper,
    capture_probe,
    look_to_replay,
    prepare_shopper,
    shopper_skin,
    warm_up,
)
from app.kiosk.shopper import FrameRequest, ShopperRenderer, ShopperView, snapshot_layers

log = logging.getLogger("sheer.kiosk")


def face_box(face: Any, shape: tuple[int, ...]) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) pixels of her face in her photograph: her landmarks' box, a fifth wider each way."""
    h, w = shape[:2]
    try:
        pts = np.array(list(face.data["landmarks"]["standard"].values()), dtype=float).reshape(-1, 2)
    except (KeyError, TypeError, ValueError):
        return 0, 0, w, h
    (ax, ay), (bx, by) = pts.min(axis=0), pts.max(axis=0)
    px, py = 0.2 * (bx - ax), 0.2 * (by - ay)
    x0, y0 = max(0, int(ax - px)), max(0, int(ay - py))
    x1, y1 = min(w, int(np.ceil(bx + px))), min(h, int(np.ceil(by + py)))
    return (x0, y0, x1, y1) if x1 - x0 > 4 and y1 - y0 > 4 else (0, 0, w, h)

def _write_png(path: Path, rgb: np.ndarray) -> None:
    """Write uint8 (H, W, 3) ``rgb`` to ``path`` as a PNG, atomically (``OSError`` if it cannot be written)."""
    import io

    from PIL import Image

    from core.atomicio import atomic_write_bytes

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgb)).save(buf, format="PNG")
    atomic_write_bytes(path, buf.getvalue())


#: What the start screen says when the camera stops or cannot be opened.
CAMERA_TROUBLE = "Sorry, the camera is not working right now. Please ask a member of staff."
#: What the start screen says when the photo from the watched folder cannot be read.
PHOTO_TROUBLE = "Sorry, that photo could not be read. Touch the screen to start again."


class _BusyPage(QWidget):
    """"Making your try-on…" while the capture runs."""

    def __init__(self) -> None:
        super().__init__()
        self.label = QLabel("Making your try-on…")
        self.label.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.label.setStyleSheet("font-size: 40px;")
        self.step = QLabel("")
        self.step.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.step.setWordWrap(True)
        privacy = QLabel(PRIVACY_LINE)
        privacy.setWordWrap(True)
        privacy.setAlignment(Qt.AlignmentFlag.AlignCenter)
        privacy.setStyleSheet("color: #b8b0a8; font-size: 16px;")
        lay = QVBoxLayout(self)
        lay.addStretch(1)
        lay.addWidget(self.label)
        lay.addWidget(self.step)
        lay.addStretch(1)
        lay.addWidget(privacy)


class _Progress(QObject):
    line = Signal(str)


#: The capture's progress lines (technical) as the shopper reads them: (words in the line, what she sees).
FRIENDLY_STEPS: tuple[tuple[str, str], ...] = (
    ("face found", "Found you!"),
    ("head", "Shaping your face in 3D…"),
    ("skin mask", "Finding your skin…"),
    ("probe", "Reading the light…"),
    ("Phong fit", "Reading your skin tone…"),
    ("detail texture", "Adding the fine detail…"),
    ("wrote", "Putting on the look…"),
)


def friendly_step(line: str) -> str | None:
    """What the busy screen says for a capture progress line (None: keep what it says)."""
    return next((words for key, words in FRIENDLY_STEPS if key in line), None)


class TryOn(QObject):
    """"Try it on me" for one kiosk window (see the module docstring).

    Attributes:
        shopper: her capture while her session lasts, else None.
        view: "mirror" or "relight".
        light: the light preset of the relit view (None: the photograph's light).
        timings: the last try-on's seconds: ``tryon_first_frame_s`` (shutter → first made-up frame shown),
            and the capture's steps.
        last_refusal: the quality gate's last message after a shutter ("" for none).
    """

    def __init__(self, kiosk: Any) -> None:  # an app.kiosk.window.KioskWindow (which imports this module)
        super().__init__()
        self.kiosk = kiosk
        self.camera_page = CameraPage()
        self.camera_page.shot.connect(kiosk.guard(self.captured))
        self.camera_page.failed.connect(kiosk.guard(self.camera_failed))
        self.camera_page.unreadable.connect(kiosk.guard(lambda detail: kiosk.fail(detail, message=PHOTO_TROUBLE)))
        self.camera_page.cancelled.connect(kiosk.guard(self.cancel))
        # in front of the camera, and while her try-on is made, she is not idle
        self.camera_page.present.connect(kiosk.guard(kiosk.activity))
        self.busy_page = _BusyPage()
        self.shopper_view = ShopperView()
        self.shopper_view.turned.connect(kiosk.guard(lambda _y, _p: self.refresh(layers=False)))
        self.shopper: Shopper | None = None
        self.renderer: ShopperRenderer | None = None
        self.view = "mirror"
        self.light: dict[str, Any] | None = None
        self.timings: dict[str, float] = {}
        self.last_refusal = ""
        self.previews_shown = 0
        self._shutter: float | None = None
        self._task: Any = None
        self._progress = _Progress()
        self._progress.line.connect(self._step)
        if kiosk.config.can_try_on:
            from app.workers import run_task

            run_task(None, "", lambda _p, _c: warm_up(), lambda _r: None,
                     lambda m: log.warning("kiosk: warming up the capture failed: %s", m), show_progress=False)

    def _step(self, line: str) -> None:
        words = friendly_step(line)
        if words:
            self.busy_page.step.setText(words)

    @property
    def active(self) -> bool:
        """Her face is on the try-on screen."""
        return self.shopper is not None

    # ------------------------------------------------------------------ the camera
    def start(self) -> None:
        """Open the camera (or the watched folder) and show the camera screen; a private session starts."""
        from app.camera_source import CameraError, open_source

        cfg = self.kiosk.config
        try:
            source = open_source(cfg.camera, cfg.watch_dir)
        except CameraError as exc:
            self.camera_failed(str(exc))
            return
        self.kiosk.begin_private_session()
        self.kiosk.activity()
        self.kiosk.stack.setCurrentWidget(self.camera_page)
        self.camera_page.start(source)

    def camera_failed(self, detail: str) -> None:
        """The camera is missing or went away: log it, end the session, the start screen says so kindly."""
        log.error("kiosk: camera: %s", detail)
        self.kiosk.fail(detail, message=CAMERA_TROUBLE)

    def cancel(self) -> None:
        """Cancel on the camera screen: back to the start screen, nothing kept."""
        self.kiosk.show_start()

    # ------------------------------------------------------------------ the capture
    def captured(self, photo: np.ndarray) -> None:
        """The shutter: capture her face in the thread pool, then show it."""
        from app.workers import run_task

        self._shutter = time.perf_counter()
        self.timings = {}
        self.kiosk.activity()
        root = self.kiosk.begin_private_session()
        folder = Path(root) / f"face-{int(time.time() * 1000)}"
        kiosk = self.kiosk
        probe = capture_probe(kiosk.config)
        resolution = min(int(kiosk.config.resolution), SHOPPER_RESOLUTION)
        look = look_to_replay(kiosk.looks, kiosk.look)
        source_doc = kiosk.stock_doc
        self.busy_page.step.setText("")
        kiosk.stack.setCurrentWidget(self.busy_page)
        emit = self._progress.line.emit

        def job(_progress: Any, _cancelled: Any) -> Shopper | Exception:
            from capture.quality import QualityError

            try:
                return prepare_shopper(photo, folder, probe=probe, library=kiosk.library, resolution=resolution,
                                       look=look, source_doc=source_doc, progress=emit)
            except QualityError as exc:
                return exc

        self._task = run_task(None, "", job, kiosk.guard(self._prepared), kiosk.guard(self._prepare_failed),
                              show_progress=False)

    def _prepare_failed(self, message: str) -> None:
        self._task = None
        self.kiosk.fail(message)

    def _prepared(self, result: Shopper | Exception) -> None:
        self._task = None
        if self.kiosk.stack.currentWidget() is not self.busy_page:  # the session ended meanwhile
            if isinstance(result, Shopper):
                result.photo = np.zeros((0, 0, 3), np.uint8)
            self.kiosk.end_private_session()
            return
        if isinstance(result, Exception):  # the quality gate refused the photo: try again
            issues = getattr(result, "issues", [])
            self.last_refusal = issues[0].message if issues else str(result)
            self.start()
            self.camera_page.say(self.last_refusal)
            return
        self.timings.update(result.timings)
        self.kiosk.activity()
        self.shopper = result
        self.view = "mirror"  # before her controls are shown: the Mirror button is the one checked
        self.light = None
        self.shopper_view.yaw = self.shopper_view.pitch = 0.0
        self.kiosk.wear_shopper(result.session)
        self.renderer = ShopperRenderer(result.head, result.face, result.photo)
        self.shopper_view.limits = self.renderer.turn_limits  # as far as her photograph supports
        self.renderer.frame.connect(self.kiosk.guard(self._frame))
        self.renderer.previewed.connect(self.kiosk.guard(self._previewed))
        self.renderer.failed.connect(self.kiosk.guard(self.kiosk.fail))
        self.refresh()

    # ------------------------------------------------------------------ her face on screen
    def _frame(self, image: np.ndarray, ms: float, req: FrameRequest) -> None:
        if self.shopper is None:
            return
        self.shopper_view.show_image(image)
        if self._shutter is not None:
            self.timings["tryon_first_frame_s"] = time.perf_counter() - self._shutter
            self.timings["first_frame_ms"] = ms
            log.info("kiosk: try-on: shutter to her first made-up frame %.2f s", self.timings["tryon_first_frame_s"])
            self._shutter = None

    def refresh(self, layers: bool = True) -> None:
        """Ask for a frame of her face as the kiosk's controls say (``layers``: the document changed)."""
        if self.renderer is None:
            return
        from render.binding import layer_inputs

        kiosk = self.kiosk
        self.shopper_view.turnable = self.view == "relight"
        self.renderer.request(FrameRequest(
            view=self.view,
            layers=snapshot_layers(layer_inputs(kiosk.doc, kiosk.library)) if layers else None,
            light=self.light, yaw=self.shopper_view.yaw if self.view == "relight" else 0.0,
            pitch=self.shopper_view.pitch if self.view == "relight" else 0.0,
            split=kiosk.split.value() / 100.0))

    def her_skin(self) -> tuple[np.ndarray, str] | None:
        """Her skin read from her photograph (linear sRGB, the reading's note), or None.

        None without a shopper or a reading (the finder then uses the fitted diffuse colour). Read once
        per shopper, in the finder's worker (it only reads her face folder).
        """
        shopper = self.shopper
        if shopper is None:
            return None
        if shopper.skin is None:
            read = shopper_skin(shopper.face)
            shopper.skin = (read.linear_rgb, read.note) if read is not None else ()
        return shopper.skin or None

    def preview_shades(self, names: list[str]) -> None:
        """Draw her face wearing each foundation of ``names`` for the finder's buttons.

        Each on the look's foundation layer, in the mirror view, cropped to her face.
        """
        if self.renderer is None:
            return
        from render.binding import layer_inputs

        kiosk = self.kiosk
        base = layer_inputs(kiosk.doc, kiosk.library)
        found = [i for i, lay in enumerate(base) if lay.material.category == "foundation"]
        if not found:
            return
        previews = []
        for name in names:
            layers = snapshot_layers(base)
            layers[found[0]].material = kiosk.library.get(name)
            previews.append(layers)
        self.renderer.request(FrameRequest(
            view=self.view, layers=None, light=self.light, yaw=self.shopper_view.yaw if self.view == "relight" else 0.0,
            pitch=self.shopper_view.pitch if self.view == "relight" else 0.0, split=kiosk.split.value() / 100.0,
            previews=previews))

    def _previewed(self, images: list[np.ndarray]) -> None:
        if self.shopper is None:
            return
        from PySide6.QtGui import QImage

        x0, y0, x1, y1 = face_box(self.shopper.face, images[0].shape)
        for i, img in enumerate(images):
            crop = np.ascontiguousarray(img[y0:y1, x0:x1][:, ::-1])  # as the mirror view shows her: flipped
            h, w = crop.shape[:2]
            self.kiosk.foundation_finder.set_preview(i, QImage(crop.data, w, h, 3 * w,
                                                               QImage.Format.Format_RGB888).copy())
        self.previews_shown = len(images)

    def set_view(self, view: str) -> None:
        """Show the mirror ("mirror") or the relit ("relight") view."""
        self.view = view
        self.refresh(layers=False)

    def set_light(self, preset: dict[str, Any] | None) -> None:
        """Light her relit face with a preset (None: the photograph's light); shows the relit view."""
        self.light = preset
        self.view = "relight"
        self.refresh(layers=False)

    def save_image(self, path: Path) -> list[Path]:
        """Write her made-up photograph (PNG) to ``path``; returns the files written.

        The mirror view drawn offscreen at her photograph's own resolution, as a camera shows her (not
        flipped as on screen), with no before/after line, whichever view is on screen. With the
        before/after slider on, a second file, ``<name>-before-after.png``: her photograph without and
        with the makeup side by side (twice her photograph's width).

        Raises:
            OSError: it could not be written; SheerError: her try-on is not on screen yet.
        """
        from core.errors import SheerError

        if self.renderer is None or self.shopper_view.image is None:
            raise SheerError("her try-on is not on screen yet")
        after, before = self.renderer.still()
        paths = [path]
        _write_png(path, after)
        if self.kiosk.split.value() > 0:
            paths.append(path.with_name(f"{path.stem}-before-after.png"))
            _write_png(paths[1], np.concatenate([before, after], axis=1))
        return paths

    def end(self) -> None:
        """Drop everything of hers: the camera, the views (GPU), the document and the photograph."""
        self.camera_page.stop()
        if self._task is not None:
            self._task.cancel()
        if self.renderer is not None:
            self.renderer.close()
            self.renderer.deleteLater()
            self.renderer = None
        self.shopper_view.clear_image()
        if self.shopper is not None:
            self.shopper.photo = np.zeros((0, 0, 3), np.uint8)
            self.shopper = None
        self._shutter = None
        # the next shopper starts in the mirror view, in her photograph's light, facing forward
        self.view = "mirror"
        self.light = None
        from render.mirror import TurnLimits

        self.shopper_view.yaw = self.shopper_view.pitch = 0.0
        self.shopper_view.limits = TurnLimits()
        self.shopper_view.turnable = False
        self.previews_shown = 0
        self.last_refusal = ""
        self.busy_page.step.setText("")
