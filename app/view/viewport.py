"""The 3D viewport: a QOpenGLWindow running the real renderer through moderngl.

The GL surface is a ``QOpenGLWindow`` embedded with ``QWidget.createWindowContainer``: it draws straight
to its own native window and swaps it, so a frame does not pay ``QOpenGLWidget``'s extra composition of
the whole top-level window (≈ 20–25 ms a frame on llvmpipe at 1280×720 in a 1980×920 studio, measured by
``sheer bench studio``: frame interval minus paintGL). :class:`Viewport` is the QWidget the windows lay
out; its surface forwards input to it, and it draws the frame-time overlay and notices over the frame
with a ``QPainter`` (widgets cannot be stacked over a native window).

The renderer is ``render.Renderer`` inside :class:`render.view.ViewRenderer` (kept frame, brush ring,
before/after split, lightweight mode).

- The moderngl context is created in ``initializeGL``; every ``paintGL`` draws into
  ``ctx.detect_framebuffer(self.defaultFramebufferObject())``; GL objects are released while the context
  is current, on ``aboutToBeDestroyed``.
- Frames are drawn on demand: every change calls ``update()``, which Qt coalesces into one ``paintGL`` per
  pass of the event loop, so a burst of mouse moves or dabs costs one frame, never a backlog. Document
  changes are queued by the document's :class:`render.binding.DocumentBinding` (dirty 64² tiles merged
  per layer, or one full re-evaluation) and flushed at the start of the next ``paintGL``, so a dab's
  tiles are in the very next frame. There is no timer and no busy loop.
- Mouse and tablet (:mod:`app.view.input`): left drag on the head paints, off the head orbits; pan,
  zoom, Ctrl+left drag moves the key light; hovering shows the brush ring. Picking reads the depth of the
  last frame the renderer drew (the current view).
- Progressive refinement (:mod:`render.progressive`): while the user orbits, pans, zooms, moves the key
  light or paints (every such input calls :meth:`Viewport.note_input`), frames are *interactive*: fast
  mode at the internal scale that holds the frame budget (:attr:`Viewport.refine`), upscaled. When a
  drag's button is released, or other input (wheel, keys, the kiosk's turns) stops for
  :data:`SETTLE_MS`, the view *settles*: one full-resolution frame in fast mode, then, in the reference
  mode, the reference frame. A dab's tiles are flushed before every frame, interactive or not.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np
from PySide6.QtCore import QEvent, Qt, QTimer, Signal
from PySide6.QtGui import QColor, QPainter
from PySide6.QtWidgets import QApplication, QVBoxLayout, QWidget

from app.view.camera import Lighting, ViewCamera
from app.view.gl_surface import Caption, GLSurface, attach_moderngl
from app.view.input import ViewportInput

if TYPE_CHECKING:
    from collections.abc import Callable

    import moderngl
    from PySide6.QtGui import QImage, QOpenGLContext

    from capture.face import Face
    from km.library import Library
    from painting import Document
    from painting.head import Head
    from painting.layout import UVLayout
    from render.binding import DocumentBinding
    from render.view import ViewRenderer

_PRELOAD: dict[str, Any] = {"task": None, "waiting": []}

#: Quiet time after the last input before the view settles to its full-resolution frame (ms). Long
#: enough that the pauses between a hand's mouse events (≤ ~50 ms) do not settle mid-drag, short enough
#: that the full frame (≈ 60–70 ms here) is on screen within 300 ms of the hand stopping.
SETTLE_MS = 120


def renderer_modules_loaded() -> bool:
    """The renderer is imported and its spectral → RGB matrix is at hand (see render.view.preload_renderer)."""
    import sys

    if "render.renderer" not in sys.modules:
        return False
    from km.cache import spectral_rgb_matrix_ready
    from render.km_pass import default_wavelengths

    return spectral_rgb_matrix_ready(default_wavelengths())


def preload_renderer_modules(then: Callable[[], None] | None = None) -> None:
    """Import the renderer's modules in a worker, then call ``then`` on the GUI thread.

    Done once (colour-science takes seconds on a loaded machine); start it early (the studio does before
    building its document).
    """
    if renderer_modules_loaded() and _PRELOAD["task"] is None:
        if then is not None:
            then()
        return
    if then is not None:
        _PRELOAD["waiting"].append(then)
    if _PRELOAD["task"] is not None:
        return
    from app.workers import run_task
    from render.view import preload_renderer

    def done(_result: object = None) -> None:
        _PRELOAD["task"] = None
        waiting, _PRELOAD["waiting"] = _PRELOAD["waiting"], []
        for fn in waiting:
            fn()

    _PRELOAD["task"] = run_task(None, "Starting the renderer", preload_renderer, done, done, show_progress=False)


#: How far down from the top of a head :func:`face_box` reaches, in mm: the sample head's crown to below
#: its chin (4.6 of its units at 52.5 mm per unit).
FACE_FRAME_MM = 4.6 * 52.5


def face_box(head: Head) -> tuple[np.ndarray, np.ndarray]:
    """The box (low and high corners, mesh units) the F key frames.

    The front of the head from its top down :data:`FACE_FRAME_MM`, in millimetres, so a head of any scale
    is framed whole (a captured head, at 10 mm per unit, was framed on its forehead and eyes when this was
    4.6 mesh units).
    """
    v = np.asarray(head.vertices)
    top = v[:, 1].max()
    depth = FACE_FRAME_MM / float(head.mm_per_unit)
    face = v[(v[:, 1] > top - depth) & (v[:, 2] > v[:, 2].min() + 0.3 * np.ptp(v[:, 2]))]
    if len(face) == 0:
        face = v
    return face.min(axis=0), face.max(axis=0)


class Viewport(ViewportInput, QWidget):
    """The studio's (and the kiosk's) 3D view of a document's head and layers (see the module docstring)."""

    frameSwapped = Signal()  # (QOpenGLWidget's name: a frame is on screen)
    stroke_begin = Signal(object, float)
    stroke_move = Signal(object, float)
    stroke_end = Signal()
    light_moved = Signal(float, float)
    frame_drawn = Signal(float)
    gl_failed = Signal(str)
    renderer_ready = Signal()
    #: a left click picked this surface point (mesh units) while :attr:`Viewport.pick_next` was armed
    surface_picked = Signal(object)

    def __init__(self, head: Head, layout: UVLayout | None = None, parent: QWidget | None = None) -> None:
        from render.progressive import AdaptiveScale

        super().__init__(parent)
        self.surface = GLSurface(self)
        self.surface.frameSwapped.connect(self.frameSwapped)
        self.container: QWidget | None = QWidget.createWindowContainer(self.surface, self)
        self._shut = False  # the GL window was deleted (shutdown)
        self.container.setFocusPolicy(Qt.FocusPolicy.NoFocus)
        box = QVBoxLayout(self)
        box.setContentsMargins(0, 0, 0, 0)
        box.addWidget(self.container)
        self.setMouseTracking(True)
        self.setFocusPolicy(Qt.FocusPolicy.StrongFocus)
        self.setMinimumSize(200, 150)
        self.head = head
        self.layout_uv = layout
        self.camera = ViewCamera()
        self.frame_head()
        self.lighting = Lighting()
        self.split = 0.0
        self.debug = 0
        self.mode = "fast"  # fast | reference | lightweight (render.view.RENDER_MODES)
        self.face: Face | None = None  # a captured face for the lightweight mode
        self.debug_layer_index = 0  # the document layer the thickness view shows
        self.brush_radius_units = 0.2
        self.paint_enabled = True
        self.pick_next = False  # the next left click on the head picks a point (surface_picked), no stroke
        self.after_frame: Callable[[Any], None] | None = None  # drawn over each frame, e.g. the Regions overlay
        self.environment = "none"
        #: the document shown (see :meth:`set_document`) and the library its materials come from
        self.document: Document | None = None
        self.library: Library | None = None
        self.binding: DocumentBinding | None = None  # the document → GPU path, while the renderer is up
        self.ctx: moderngl.Context | None = None
        self.renderer: ViewRenderer | None = None
        self.renderer_error: str | None = None  # the renderer failed in a frame (reported; the view stays empty)
        self.init_input()
        self.frame_ms = 0.0
        self.render_ms = 0.0  # the last frame the renderer drew (not a ring-only redraw), finished
        self.flush_ms = 0.0  # the last paintGL's share spent pushing document changes (dirty tiles' KM)
        self.frames = 0  # paintGL calls that drew the head (full frames and ring-only redraws)
        self.renderer_frames = 0  # frames the renderer drew
        self.first_frame_time: float | None = None
        self.gl_error_at_release: str | None = None
        self.full_quality_ready = False
        #: progressive refinement: the interactive frames' scale, and where the view is in settling
        #: ("interactive" while input goes on, "settle" for the full fast frame, "final" once settled)
        self.refine = AdaptiveScale()
        self.stage = "final"
        self.settled_frames = 0  # full-resolution frames drawn after input stopped (settle + final)
        self.last_frame_interactive = False  # the last frame paintGL drew was an interactive one
        self.last_input_time: float | None = None  # perf_counter of the last input (bench: settle time)
        self._settle_timer = QTimer(self)
        self._settle_timer.setSingleShot(True)
        self._settle_timer.setInterval(SETTLE_MS)
        self._settle_timer.timeout.connect(self._settle)
        self.overlay = Caption("#e8e8e8", QColor(0, 0, 0, 120))
        self.notice = Caption("#ffe9a8", QColor(0, 0, 0, 150))

    # ------------------------------------------------------------------ the GL surface
    def makeCurrent(self) -> None:  # (QOpenGLWidget's API)
        """Make the surface's GL context current."""
        if not self._shut:
            self.surface.makeCurrent()

    def doneCurrent(self) -> None:
        """Release the surface's GL context."""
        if not self._shut:
            self.surface.doneCurrent()

    def context(self) -> QOpenGLContext | None:
        """The surface's GL context (None before it is shown)."""
        return self.surface.context()

    def defaultFramebufferObject(self) -> int:
        """The surface's framebuffer (0: the window's own)."""
        return int(self.surface.defaultFramebufferObject())

    def grabFramebuffer(self) -> QImage:  # (QOpenGLWidget's API)
        """The view as an image: a frame drawn for it (without the captions) and read back.

        ``QOpenGLWindow.grabFramebuffer`` only reads the back buffer, which a swap leaves undefined, so the
        frame is drawn again first (the kept frame makes that a copy unless the view changed).
        """
        from PySide6.QtGui import QImage

        if self._shut or not self.surface.isValid():
            return QImage()
        self.surface.makeCurrent()
        try:
            self.paintGL()
            return self.surface.grabFramebuffer()
        finally:
            self.surface.doneCurrent()

    def update(self) -> None:  # type: ignore[override]
        """Ask for a frame (Qt coalesces requests into one per pass of the event loop)."""
        if not self._shut:
            self.surface.update()

    def repaint(self) -> None:  # type: ignore[override]
        """Draw a frame now, if the surface is on screen (else at its next exposure)."""
        if self._shut:
            return
        if self.surface.isExposed():
            QApplication.sendEvent(self.surface, QEvent(QEvent.Type.UpdateRequest))
        else:
            self.surface.update()

    def devicePixelRatioF(self) -> float:
        """Device pixels per logical pixel of the surface."""
        return float(self.surface.devicePixelRatio())

    def paint_captions(self, device: GLSurface) -> None:
        """The overlay (top left) and the notice (bottom left) over the frame just drawn."""
        if not (self.overlay.isVisible() or self.notice.isVisible()):
            return
        painter = QPainter(device)
        try:
            if self.overlay.isVisible():
                self.overlay.draw(painter, 6, 6)
            if self.notice.isVisible():
                self.notice.draw(painter, 6, self.height() - 6, bottom=True)
        finally:
            painter.end()

    # ------------------------------------------------------------------ GL life cycle
    def initializeGL(self) -> None:
        """Create the moderngl context on the widget's; the renderer follows once its modules are loaded."""
        import moderngl

        try:
            self.ctx = attach_moderngl(moderngl, self.context())
        except Exception as exc:  # shown by the window as a message, never a traceback
            self.gl_failed.emit(f"OpenGL could not start: {exc}")
            return
        self.context().aboutToBeDestroyed.connect(self.release_gl)
        # the renderer's imports load in a worker (started early by the window); the window is up meanwhile
        preload_renderer_modules(self._attach_renderer)

    def _attach_renderer(self) -> None:
        """Create the renderer (GUI thread, our context current)."""
        from render.view import ViewRenderer

        if self.ctx is None or self.renderer is not None:
            return
        self.makeCurrent()
        try:
            self.renderer = ViewRenderer(self.ctx, self.head, self.layout_uv)
        except Exception as exc:
            self.renderer = None
            self.gl_failed.emit(f"The renderer could not start: {exc}")
            return
        finally:
            self.doneCurrent()
        self._bind()
        self.full_quality_ready = True
        self.renderer_ready.emit()
        # the first frame refines too: an interactive one at once, the full one after the settle time
        self.stage = "interactive"
        self._settle_timer.start()
        self.update()

    def release_gl(self) -> None:
        """Release every GL object while our context is current."""
        if self.renderer is None and self.ctx is None:
            return
        self.makeCurrent()
        try:
            if self.ctx is not None:
                self.gl_error_at_release = str(self.ctx.error)
            if self.binding is not None:
                self.binding.close()
                self.binding = None
            if self.renderer is not None:
                self.renderer.release()
        finally:
            self.renderer = None
            if self.ctx is not None:
                self.ctx.release()
            self.ctx = None
            self.doneCurrent()

    def shutdown(self) -> None:
        """Release GL and delete the GL window now (the window closing for good).

        A ``QOpenGLWindow`` left for Python's finaliser is destroyed after Qt's platform integration and
        crashes the process at exit; deleting it while the application runs is clean. The view draws
        nothing afterwards.
        """
        import shiboken6

        self.release_gl()
        if self._shut:
            return
        self._shut = True
        self._settle_timer.stop()
        container, self.container = self.container, None
        if container is not None and shiboken6.isValid(container):
            shiboken6.delete(container)  # deletes the embedded surface with it

    def pixel_size(self) -> tuple[int, int]:
        """The widget's size in device pixels (the size frames are rendered at)."""
        r = self.devicePixelRatioF()
        return max(int(self.width() * r), 1), max(int(self.height() * r), 1)

    # ------------------------------------------------------------------ the document
    def set_document(self, doc: Document, library: Library | None = None) -> None:
        """Show ``doc``'s layers (materials looked up in ``library`` first, see render.binding.layer_inputs).

        Its changes reach the renderer through one :class:`render.binding.DocumentBinding`, flushed at the
        start of every ``paintGL``.
        """
        self.document, self.library = doc, library
        self._bind()

    def _bind(self) -> None:
        """(Re)create the binding of the document to the renderer, when both are there."""
        if self.binding is not None:
            self.binding.close()
            self.binding = None
        if self.document is not None and self.renderer is not None:
            self.binding = self.renderer.bind_document(self.document, self.library, on_change=self.update)
        self.update()

    def apply_layer_changes(self) -> bool:
        """Push the document's queued changes to the renderer (call with our context current).

        Returns:
            True if anything was pushed.
        """
        return self.binding is not None and self.binding.flush()

    def reload_layers(self) -> None:
        """Read every layer again in the next frame: a library material changed (the document says nothing)."""
        if self.binding is not None:
            self.binding.invalidate()
        self.update()

    @property
    def pending_changes(self) -> bool:
        """Document changes are waiting for the next frame (or for the renderer to start)."""
        if self.document is None:
            return False
        return self.binding is None or self.binding.pending

    def paintGL(self) -> None:
        """Draw the view: the document's queued changes first, then a new frame or the kept one."""
        if self.ctx is None:
            return
        fbo = self.ctx.detect_framebuffer(self.defaultFramebufferObject())
        fbo.use()  # before any GL object is created (see ViewportRenderer.render)
        if self.renderer is None or self.renderer_error is not None:
            fbo.clear(0.11, 0.11, 0.12, 1.0)
            return
        from render.ring import BrushRing

        t0 = time.perf_counter()
        self.apply_layer_changes()
        self.flush_ms = (time.perf_counter() - t0) * 1000.0  # the document's changes (KM of dirty tiles)
        self.renderer.environment = self.environment
        self.renderer.layer_index = self.debug_layer_index
        ring = None
        if self.brush_ring is not None and self.paint_enabled:
            ring = BrushRing((float(self.brush_ring[0]), float(self.brush_ring[1]), float(self.brush_ring[2])),
                             float(self.brush_radius_units))
        if self.renderer.face is not self.face:
            self.renderer.set_face(self.face)
        mode = self.mode if (self.mode != "lightweight" or self.face is not None) else "fast"
        interactive = self.stage == "interactive" and self.debug == 0
        frame_mode = "fast" if self.stage == "settle" and mode == "reference" else mode
        scale = self.refine.scale
        # the settle frame after a relight draws on the direct path; the lighting cache is rebuilt just after
        # it, before the next input's frames (render.Renderer.defer_cache)
        self.renderer.defer_cache = self.stage == "settle"
        try:
            drew = self.renderer.render(fbo, self.pixel_size(), self.camera, self.lighting.key_light(),
                                        split=self.split, debug=self.debug, mode=frame_mode, ring=ring,
                                        interactive=interactive, scale=scale)
            if self.after_frame is not None:  # (app.studio.region_picker's Regions overlay, issue #16)
                self.after_frame(fbo)
        except Exception as exc:  # never a traceback: say so once; another mode falls back to fast
            import logging

            logging.getLogger("sheer.app").exception("viewport frame failed")
            if mode != "fast":
                self.mode = "fast"
                self.gl_failed.emit(f"The {mode} mode could not draw ({exc}); back to the fast mode.")
                self.update()
            else:
                self.renderer_error = str(exc)
                self.gl_failed.emit(f"The renderer could not draw the view: {exc}")
            return
        # Qt composes the frame right after paintGL anyway: finishing here costs nothing and makes the
        # frame time true (it is what the kiosk's fallback to the lightweight engine decides on)
        self.ctx.finish()
        self.frame_ms = (time.perf_counter() - t0) * 1000.0
        if drew:
            self.render_ms = self.frame_ms
            if interactive and self.renderer.scale < 1.0:
                self.refine.update(self.frame_ms, self.renderer.scale)
            elif not interactive:
                self.settled_frames += 1
        self.last_frame_interactive = interactive and drew
        if self.stage == "settle":  # the full fast frame is drawn: the reference frame (if any) next
            self.stage = "final"
            self.renderer.defer_cache = False
            QTimer.singleShot(0, self._build_deferred_cache)
            if mode == "reference":
                QTimer.singleShot(0, self.update)
        self.frames += 1
        self.renderer_frames += int(drew)
        if self.first_frame_time is None:
            self.first_frame_time = time.perf_counter()
        self._show_notice(self.renderer.debug_hidden)
        if self.overlay.isVisible():
            self.overlay.setText(self.overlay_text(drew, frame_mode))
        self.frame_drawn.emit(self.frame_ms)

    def overlay_text(self, drew: bool, mode: str) -> str:
        """The frame-time overlay's text: the frame's time, interactive or settled, scale and budget."""
        r = self.refine
        kind = "ring only" if not drew else (
            f"interactive {self.renderer.scale if self.renderer else 1.0:.2f}×" if self.last_frame_interactive
            else "settled 1.00×")
        text = (f"{self.frame_ms:5.1f} ms ({1000.0 / max(self.frame_ms, 1e-3):4.0f} fps)  {mode} · {kind}\n"
                f"budget {r.budget_ms:.0f} ms · scale cap {r.max_scale:.2f}")
        if r.over_budget:
            text += f"\nover budget at the smallest scale ({r.min_scale:.2f}): the frame cannot be cheaper"
        return text

    # ------------------------------------------------------------------ progressive refinement
    @property
    def settled(self) -> bool:
        """Input has stopped and the last frame drawn is the full-resolution frame of the current mode."""
        return self.stage == "final" and not self.last_frame_interactive and not self._settle_timer.isActive()

    def note_input(self, drag: bool = False) -> None:
        """An input that changes the view or the makeup: draw interactive frames until it stops.

        ``drag``: it comes from a mouse drag, whose button's release ends it
        (:meth:`~app.view.input.ViewportInput.mouseReleaseEvent` settles at once); other inputs (the
        wheel, keys, the kiosk's turns) settle after :data:`SETTLE_MS`.
        """
        self.last_input_time = time.perf_counter()
        self.drag_moved = drag
        self.stage = "interactive"
        self._settle_timer.start()
        self.update()

    def _settle(self) -> None:
        """Input stopped: the full-resolution frame next (then the reference one in that mode)."""
        if self.drag == "paint":  # the pen rests on the head mid-stroke: keep the stroke's frames cheap
            self._settle_timer.start()
            return
        quiet_ms = (time.perf_counter() - (self.last_input_time or 0.0)) * 1000.0
        if quiet_ms < SETTLE_MS:  # the timer came due behind a slow frame: wait out the rest
            self._settle_timer.start(max(int(SETTLE_MS - quiet_ms), 1))
            return
        self.stage = "settle"
        self.update()

    def settle_after_quiet(self) -> None:
        """Settle :data:`SETTLE_MS` after the last input, unless the settle timer already runs."""
        if not self._settle_timer.isActive():
            self._settle_timer.start()

    def settle_now(self) -> None:
        """The input has provably ended (a button released): the full-resolution frame next, no wait.

        Exactly one full frame follows (the settle timer is stopped, so it adds none), then the reference
        frame in that mode, as after :data:`SETTLE_MS` of quiet.
        """
        self._settle_timer.stop()
        self.stage = "settle"
        self.update()

    def _build_deferred_cache(self) -> None:
        """Rebuild the lighting cache the settle frame left out of date (between frames, context current)."""
        if self.renderer is None or self.ctx is None or self._shut:
            return
        self.makeCurrent()
        try:
            self.renderer.build_deferred_cache()
        except Exception:  # the next full frame rebuilds it anyway; never a traceback here
            import logging

            logging.getLogger("sheer.app").exception("lighting cache rebuild failed")
        finally:
            self.doneCurrent()

    def _show_notice(self, hidden: bool) -> None:
        if hidden:
            self.notice.setText("Thickness view: the selected layer is hidden (show it to see its thickness)")
        self.notice.setVisible(hidden)

    # ------------------------------------------------------------------ inputs from the window
    def refresh(self) -> None:
        """Draw a new frame even if the view did not change (e.g. a material was edited)."""
        if self.renderer is not None:
            self.renderer.invalidate()
        self.update()

    def frame_head(self) -> None:
        """Frame the face from the front (the F key; :func:`face_box`)."""
        self.camera.frame_box(*face_box(self.head))
        self.update()

    def set_overlay(self, on: bool) -> None:
        """Show or hide the frame-time overlay."""
        self.overlay.setVisible(on)
        self.update()
