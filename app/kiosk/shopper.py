"""The shopper's own face on the kiosk: her photograph with the makeup (mirror) or her face relit (relight).

:class:`ShopperRenderer` owns a GL context of its own (a standalone EGL context, made and used only in
one thread of its own, so it never meets the Qt GL context of the kiosk's viewport) with
:class:`render.mirror.MirrorView` and :class:`render.mirror.RelightView` sharing one KM pass. The GUI
thread asks for frames with :meth:`ShopperRenderer.request` (a :class:`FrameRequest`: the view, the
layers as the document holds them, the light, the turn, the before/after split); requests that pile up
while a frame is drawn are merged (only the newest is drawn) and each frame comes back on the GUI thread
through the ``frame`` signal. :class:`ShopperView` shows the frames, scaled to fit, and turns the relit
face by dragging, as far as her photograph supports (:attr:`ShopperRenderer.turn_limits`,
:func:`render.mirror.turn_limits`: at most ±:data:`render.mirror.MAX_TURN_DEG`, less towards a side her
photograph saw at a grazing angle).

Both views are shown as a mirror shows her: flipped left–right, like the camera screen's live preview, so
switching views keeps her sides where they were (the before/after split is then laid over the flipped
frame, so its left part is still "before"), and a drag to the right turns her relit face the way her
reflection would turn (its front follows the drag). The mirror view is drawn at her photograph's own
resolution. :meth:`ShopperRenderer.still` draws her made-up photograph, and the same without makeup, as a
camera shows her (not flipped, no split line), for Save Photo, whichever view is on screen.

Everything here lives in memory; :meth:`ShopperRenderer.close` releases the GPU objects and the context.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from PySide6.QtCore import QObject, QPointF, Qt, Signal
from PySide6.QtGui import QImage, QPixmap
from PySide6.QtWidgets import QLabel, QSizePolicy

if TYPE_CHECKING:
    from PySide6.QtGui import QMouseEvent, QResizeEvent

    from painting.head import Head
    from render.km_pass import LayerInput

log = logging.getLogger("sheer.kiosk")

#: The two views of the shopper.
VIEWS: tuple[str, ...] = ("mirror", "relight")
#: Degrees of turn per pixel dragged on the relit face.
TURN_DEG_PER_PX = 0.15


@dataclass
class FrameRequest:
    """One frame to draw.

    Attributes:
        view: "mirror" (her photograph, its pose and light) or "relight" (her face under ``light``).
        layers: the cosmetic layers, bottom first (thickness copied: the renderer thread owns them), or
            None to keep the last ones.
        light: a light preset (``app.settings.LIGHT_PRESETS`` value) for the relit view, or None for the
            photograph's own light.
        yaw, pitch: the relit face's turn from the photograph's view, degrees (clamped to the view's
            :class:`render.mirror.TurnLimits`, within ±25; positive yaw shows more of her left cheek).
        split: before/after: the left ``split`` fraction of the frame (0..1) shows her without makeup.
        previews: other sets of layers to draw her with first (mirror view), each returned in the
            ``previewed`` signal (e.g. each of the shades the foundation finder proposes), or None.
    """

    view: str = "mirror"
    layers: list[LayerInput] | None = None
    light: dict[str, Any] | None = None
    yaw: float = 0.0
    pitch: float = 0.0
    split: float = 0.0
    previews: list[list[LayerInput]] | None = None
    made: float = field(default_factory=time.perf_counter)


def snapshot_layers(layers: list[LayerInput]) -> list[LayerInput]:
    """The layers with their thickness copied (the GUI thread may change the document meanwhile)."""
    from render.km_pass import LayerInput

    return [LayerInput(lay.material, np.array(lay.thickness, dtype=np.float32, copy=True), lay.opacity, lay.visible,
                       lay.name) for lay in layers]


def split_frame(before: np.ndarray, after: np.ndarray, split: float) -> np.ndarray:
    """``after`` with its left ``split`` fraction (0..1) taken from ``before`` and a thin divider line."""
    out = after.copy()
    x = int(round(np.clip(split, 0.0, 1.0) * out.shape[1]))
    if x <= 0:
        return out
    out[:, :x] = before[:, :x]
    if x < out.shape[1]:
        out[:, max(0, x - 1):x + 1] = 255
    return out


class ShopperRenderer(QObject):
    """Draws the shopper's face in a thread with its own GL context (see the module docstring).

    Args:
        head: her head (the captured face's mesh).
        face: her captured face (``capture.face.Face``).
        photo: her photograph, uint8 sRGB (H, W, 3), at its own resolution (the capture's size, or the
            original it was reduced from: :class:`render.mirror.MirrorView`).

    Signals:
        frame(image, ms, request): a frame drawn (uint8 (H, W, 3)), its drawing time in ms and its request.
        previewed(images): the request's ``previews`` drawn (uint8 (H, W, 3) each, in order).
        failed(message): the GL context or a view could not be made, or a frame failed.

    Attributes: ``turn_limits`` (the :class:`render.mirror.TurnLimits` her photograph supports, degrees),
    ``frames`` (frames drawn).
    """

    frame = Signal(object, float, object)
    previewed = Signal(list)
    failed = Signal(str)

    def __init__(self, head: Head, face: Any, photo: np.ndarray) -> None:
        super().__init__()
        from render.mirror import turn_limits

        self.head, self.face, self.photo = head, face, photo
        self.turn_limits = turn_limits(head, face.camera())
        self._queue: queue.Queue[FrameRequest | Future[tuple[np.ndarray, np.ndarray]] | None] = queue.Queue()
        self._ahead: list[Future[tuple[np.ndarray, np.ndarray]]] = []  # stills met while merging requests
        self._thread = threading.Thread(target=self._run, name="sheer-shopper-gl", daemon=True)
        self.frames = 0
        self._thread.start()

    def request(self, req: FrameRequest) -> None:
        """Ask for a frame (merged with any still waiting; the newest wins, its layers or an older one's)."""
        self._queue.put(req)

    def close(self, timeout_s: float = 10.0) -> None:
        """Stop the thread and release the GPU objects and the context (idempotent)."""
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join(timeout_s)
        self.photo = np.zeros((0, 0, 3), np.uint8)  # her photograph is not kept a moment longer

    def still(self, timeout_s: float = 60.0) -> tuple[np.ndarray, np.ndarray]:
        """Her made-up photograph and the same without makeup (before), uint8 (H, W, 3) each.

        The mirror view at her photograph's own resolution as a camera shows her (not flipped, no
        before/after split), with the layers of the requests made so far; drawn in the renderer's thread,
        this call waits for it (at most ``timeout_s`` seconds: ``TimeoutError``).

        Raises:
            RuntimeError: the renderer is closed (``concurrent.futures.CancelledError``: it closed meanwhile);
                or whatever drawing raised.
        """
        if not self._thread.is_alive():
            raise RuntimeError("the try-on renderer is closed")
        done: Future[tuple[np.ndarray, np.ndarray]] = Future()
        self._queue.put(done)
        return done.result(timeout_s)

    def _take(self) -> FrameRequest | Future[tuple[np.ndarray, np.ndarray]] | None:
        """The next still, or the newest waiting request with the newest layers any merged request carried.

        None = stop. A still waiting behind a request is kept for the next call (requests after it are
        still merged into this one: a still draws the layers, not a frame).
        """
        if self._ahead:
            return self._ahead.pop(0)
        req = self._queue.get()
        while isinstance(req, FrameRequest):
            try:
                nxt = self._queue.get_nowait()
            except queue.Empty:
                break
            if nxt is None:
                return None
            if isinstance(nxt, Future):
                self._ahead.append(nxt)
                continue
            if nxt.layers is None:
                nxt.layers = req.layers
            if nxt.previews is None:
                nxt.previews = req.previews
            req = nxt
        return req

    def _run(self) -> None:
        from render.context import standalone_context
        from render.mirror import MirrorView, RelightView
        from render.shaders import ShaderLibrary

        ctx = mirror = relight = None
        try:
            ctx = standalone_context()
            shaders = ShaderLibrary()
            mirror = MirrorView(ctx, self.head, self.face, self.photo, shaders=shaders)
            relight = RelightView(ctx, self.head, self.face, shaders=shaders, km=mirror.km)
        except Exception as exc:
            log.exception("kiosk: the shopper's views could not be made")
            self.failed.emit(f"the try-on views could not be made: {exc}")
            self._drain()
            self._release(ctx, mirror, relight)
            return
        main_layers: list[LayerInput] = []
        while True:
            req = self._take()
            if req is None:
                break
            if isinstance(req, Future):
                self._still(mirror, req)
                continue
            try:
                if req.previews:
                    shots = []
                    for layers in req.previews:
                        mirror.set_layers(layers)
                        shots.append(np.asarray(mirror.render_image()))
                    mirror.set_layers(req.layers if req.layers is not None else main_layers)
                    self.previewed.emit(shots)
                if req.layers is not None:
                    main_layers = req.layers
                t = time.perf_counter()
                img = self._draw(mirror, relight, req)
                self.frames += 1
                self.frame.emit(img, (time.perf_counter() - t) * 1000.0, req)
            except Exception as exc:
                log.exception("kiosk: a try-on frame failed")
                self.failed.emit(f"a try-on frame failed: {exc}")
        self._cancel_stills()
        self._release(ctx, mirror, relight)

    @staticmethod
    def _still(mirror: Any, done: Future[tuple[np.ndarray, np.ndarray]]) -> None:
        """Draw :meth:`still`'s pair with ``mirror`` into ``done``."""
        if not done.set_running_or_notify_cancel():
            return
        try:
            mirror.show_makeup = True
            after = np.asarray(mirror.render_image())
            mirror.show_makeup = False
            before = np.asarray(mirror.render_image())
            done.set_result((after, before))
        except Exception as exc:
            log.exception("kiosk: her photo could not be drawn")
            done.set_exception(exc)
        finally:
            mirror.show_makeup = True

    def _drain(self) -> None:
        while (item := self._queue.get()) is not None:
            if isinstance(item, Future):
                item.cancel()
        self._cancel_stills()

    def _cancel_stills(self) -> None:
        """Cancel the stills still waiting (the thread stops): :meth:`still` raises at once, not after its timeout."""
        waiting, self._ahead = self._ahead, []
        while True:
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                break
            if isinstance(item, Future):
                waiting.append(item)
        for done in waiting:
            done.cancel()

    @staticmethod
    def _release(ctx: Any, mirror: Any, relight: Any) -> None:
        for view in (relight, mirror):  # the relit view shares the mirror's KM pass: it goes first
            if view is not None:
                try:
                    view.release()
                except Exception:
                    log.exception("kiosk: releasing a try-on view failed")
        if ctx is not None:
            ctx.release()

    @staticmethod
    def _draw(mirror: Any, relight: Any, req: FrameRequest) -> np.ndarray:
        if req.layers is not None:
            mirror.set_layers(req.layers)
        if req.view == "relight":
            view = relight
            view.yaw, view.pitch = view.limits.clamp(float(req.yaw), float(req.pitch))
            if req.light is None:
                view.use_capture_light()
            else:
                p = req.light
                view.set_preset(p["azimuth"], p["elevation"], p["colour"], p["intensity"], p["ambient"])

        else:
            view = mirror

        def draw() -> np.ndarray:  # either view as a mirror shows her: flipped left-right
            return np.ascontiguousarray(np.asarray(view.render_image())[:, ::-1])
        mirror.show_makeup = relight.show_makeup = True
        after = draw()
        if req.split <= 0.0:
            return after
        mirror.show_makeup = relight.show_makeup = False
        try:
            before = draw()
        finally:
            mirror.show_makeup = relight.show_makeup = True
        return split_frame(before, after, req.split)


class ShopperView(QLabel):
    """Her face, the newest frame scaled to fit; dragging turns the relit face.

    The frames are shown flipped (as a mirror shows her), so a drag to the right turns her as her
    reflection would turn: its front follows the drag (more of her left cheek, positive yaw), a drag down
    looks from above (positive pitch); :data:`TURN_DEG_PER_PX` degrees per pixel.

    Attributes: ``yaw``, ``pitch`` (degrees), ``limits`` (a :class:`render.mirror.TurnLimits` the drag is
    clamped to: her photograph's, set with her renderer; default ±25° each way), ``turnable``.

    Signals:
        turned(yaw, pitch): the drag asks for this turn (degrees, clamped to ``limits``).
    """

    turned = Signal(float, float)

    def __init__(self) -> None:
        super().__init__()
        self.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Ignored)
        self.setMinimumSize(320, 240)
        self.setStyleSheet("background: #000;")
        self.image: np.ndarray | None = None
        from render.mirror import TurnLimits

        self.yaw = self.pitch = 0.0
        self.limits = TurnLimits()
        self.turnable = False
        self._drag: QPointF | None = None
        self._qimage: QImage | None = None

    def show_image(self, rgb: np.ndarray) -> None:
        """Show a frame (uint8 (H, W, 3))."""
        self.image = np.ascontiguousarray(rgb)
        h, w = self.image.shape[:2]
        self._qimage = QImage(self.image.data, w, h, 3 * w, QImage.Format.Format_RGB888)
        self._rescale()

    def clear_image(self) -> None:
        """Forget the frame (her face leaves the screen)."""
        self.image = None
        self._qimage = None
        self.clear()

    def _rescale(self) -> None:
        if self._qimage is None:
            return
        self.setPixmap(QPixmap.fromImage(self._qimage).scaled(
            self.size(), Qt.AspectRatioMode.KeepAspectRatio, Qt.TransformationMode.SmoothTransformation))

    def resizeEvent(self, event: QResizeEvent) -> None:  # noqa: N802
        """Keep the frame fitted to the label."""
        super().resizeEvent(event)
        self._rescale()

    def mousePressEvent(self, event: QMouseEvent) -> None:  # noqa: N802
        """Start a turn (relit view only)."""
        self._drag = event.position() if self.turnable else None

    def mouseMoveEvent(self, event: QMouseEvent) -> None:  # noqa: N802
        """Turn her face with the drag (degrees per pixel: :data:`TURN_DEG_PER_PX`), within :attr:`limits`."""
        if self._drag is None:
            return
        d = event.position() - self._drag
        self._drag = event.position()
        # shown flipped: a drag to the right brings her left cheek (on the screen's left) forward
        self.yaw, self.pitch = self.limits.clamp(self.yaw + d.x() * TURN_DEG_PER_PX,
                                                 self.pitch + d.y() * TURN_DEG_PER_PX)
        self.turned.emit(self.yaw, self.pitch)

    def mouseReleaseEvent(self, event: QMouseEvent) -> None:  # noqa: N802
        """End the turn."""
        self._drag = None
