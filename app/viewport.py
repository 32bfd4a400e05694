"""The 3D viewport: a QOpenGLWidget running the renderer through moderngl.

- The moderngl context is created in ``initializeGL``; every ``paintGL`` draws into
  ``ctx.detect_framebuffer(self.defaultFramebufferObject())``; frames are requested with ``update()``
  (no busy loop); GL objects are released while the context is current, on ``aboutToBeDestroyed``.
- Mouse: left drag on the head paints (signals to the window, which owns the document), left drag off
  the head or right drag orbits, middle (or Shift+right) drag pans, the wheel zooms, Ctrl+left drag moves
  the key light. Hovering shows the brush ring on the surface. Tablet pressure is read from
  ``QTabletEvent`` and applied to the mouse events Qt synthesises from it.
- While the view moves or a stroke is painted, frames are rendered at ``interactive_scale`` (default
  0.5) of the widget's resolution into an offscreen target and scaled up; 250 ms after the last change a
  full-resolution frame is drawn. Picking uses the last frame's resolution.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from PySide6.QtCore import QPointF, Qt, QTimer, Signal
from PySide6.QtGui import QMouseEvent, QSurfaceFormat, QTabletEvent, QWheelEvent
from PySide6.QtOpenGLWidgets import QOpenGLWidget
from PySide6.QtWidgets import QLabel, QWidget

from app.camera import OrbitCamera
from app.preview_renderer import Lighting

_BLIT_VERT = """
#version 330
out vec2 v_uv;
void main() {
    vec2 p = vec2(gl_VertexID & 1, gl_VertexID >> 1);
    v_uv = p;
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
"""

_BLIT_FRAG = """
#version 330
uniform sampler2D u_src;
in vec2 v_uv;
out vec4 f_color;
void main() { f_color = texture(u_src, v_uv); }
"""


def default_surface_format() -> QSurfaceFormat:
    fmt = QSurfaceFormat()
    fmt.setVersion(4, 1)
    fmt.setProfile(QSurfaceFormat.OpenGLContextProfile.CoreProfile)
    fmt.setDepthBufferSize(24)
    fmt.setSwapInterval(0)
    return fmt


class Viewport(QOpenGLWidget):
    stroke_begin = Signal(object, float)
    stroke_move = Signal(object, float)
    stroke_end = Signal()
    light_moved = Signal(float, float)
    frame_drawn = Signal(float)
    gl_failed = Signal(str)
    renderer_ready = Signal()

    def __init__(self, head: Any, resolution: int, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setFormat(default_surface_format())
        self.setMouseTracking(True)
        self.setFocusPolicy(Qt.FocusPolicy.StrongFocus)
        self.setMinimumSize(200, 150)
        self.head = head
        self.resolution = resolution
        self.camera = OrbitCamera()
        self.frame_head()
        self.lighting = Lighting()
        self.split = 0.0
        self.debug = 0
        self.reference = False
        self.roughness = 0.4
        self.brush_radius_units = 0.2
        self.paint_enabled = True
        self.ctx: Any = None
        self.renderer: Any = None
        self._pending_layers: tuple[list[Any], list[tuple[int, int]] | None] | None = None
        self._pending_thick: tuple[np.ndarray | None, float, int] | None = None
        self.environment = "none"
        self._ring: np.ndarray | None = None
        self._drag: str | None = None
        self._last = QPointF()
        self._pressure = 1.0
        self._tablet = False
        self.frame_ms = 0.0
        self.frames = 0
        self.interactive_scale = 0.5
        self._interacting = False
        self._last_scale = 1.0
        self._off: Any = None
        self._blit: Any = None
        self._settle = QTimer(self)
        self._settle.setSingleShot(True)
        self._settle.setInterval(250)
        self._settle.timeout.connect(self._settled)
        self.first_frame_time: float | None = None
        self.gl_error_at_release: str | None = None
        self.full_quality_ready = False
        self.full_quality_time: float | None = None
        self.overlay = QLabel(self)
        self.overlay.setStyleSheet("color: #e8e8e8; background: rgba(0,0,0,120); padding: 3px;")
        self.overlay.move(6, 6)
        self.overlay.hide()

    # ------------------------------------------------------------------ GL life cycle
    def initializeGL(self) -> None:
        import moderngl

        from app import seams

        try:
            self.ctx = moderngl.create_context()
            self.renderer = seams.create_renderer(self.ctx, self.head, self.resolution, lazy=True)
        except Exception as exc:  # shown by the window as a message, never a traceback
            self.renderer = None
            self.gl_failed.emit(f"OpenGL could not start: {exc}")
            return
        self.context().aboutToBeDestroyed.connect(self.release_gl)
        if getattr(self.renderer, "real", True) is None:
            from app.render_adapter import preload_real_renderer
            from app.workers import run_task

            run_task(None, "Starting the renderer", preload_real_renderer, lambda _r: self._attach_real(),
                     lambda msg: self._attach_real(), show_progress=False)
        else:
            self.full_quality_ready = True

    def _attach_real(self) -> None:
        """Create the full renderer (GUI thread, our context current) once its imports are loaded."""
        import logging

        from app.render_adapter import RealViewportRenderer

        if self.renderer is None or self.ctx is None:
            return
        self.makeCurrent()
        try:
            self.renderer.attach_real(RealViewportRenderer(self.ctx, self.head, self.resolution))
        except Exception as exc:
            logging.getLogger("sheer.app").warning("the full renderer could not start (%s); preview only", exc)
        finally:
            self.doneCurrent()
        self.full_quality_ready = True
        self.full_quality_time = time.perf_counter()
        self.renderer_ready.emit()
        self.update()

    def _offscreen(self, size: tuple[int, int]) -> Any:
        """A colour + depth target of ``size`` for interactive (reduced-resolution) frames."""
        if self._off is None or self._off.size != size:
            self._release_offscreen()
            self._off = self.ctx.framebuffer([self.ctx.texture(size, 4)], self.ctx.depth_renderbuffer(size))
            self._off.color_attachments[0].filter = (self.ctx.LINEAR, self.ctx.LINEAR)
        return self._off

    def _upscale(self, fbo: Any, full: tuple[int, int]) -> None:
        if self._blit is None:
            prog = self.ctx.program(vertex_shader=_BLIT_VERT, fragment_shader=_BLIT_FRAG)
            self._blit = (prog, self.ctx.vertex_array(prog, []))
        prog, vao = self._blit
        fbo.use()
        self.ctx.viewport = (0, 0, *full)
        self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.BLEND)
        self._off.color_attachments[0].use(0)
        prog["u_src"].value = 0
        vao.render(self.ctx.TRIANGLE_STRIP, vertices=4)

    def _release_offscreen(self) -> None:
        if self._off is not None:
            self.ctx.detect_framebuffer(self.defaultFramebufferObject()).use()
            for a in (*self._off.color_attachments, self._off.depth_attachment):
                a.release()
            self._off.release()
            self._off = None

    def begin_interaction(self) -> None:
        """Render at ``interactive_scale`` until the view has been still for a moment, then at full size."""
        if self.interactive_scale < 1.0:
            self._interacting = True
            self._settle.start()

    def _settled(self) -> None:
        self._interacting = False
        self.update()

    def release_gl(self) -> None:
        """Release every GL object while our context is current."""
        if self.renderer is None and self.ctx is None:
            return
        self.makeCurrent()
        try:
            self._release_offscreen()
            if self._blit is not None:
                for o in reversed(self._blit):
                    o.release()
                self._blit = None
            if self.ctx is not None:
                self.gl_error_at_release = str(self.ctx.error)
            if self.renderer is not None:
                self.renderer.release()
        finally:
            self.renderer = None
            if self.ctx is not None:
                self.ctx.release()
            self.ctx = None
            self.doneCurrent()

    def pixel_size(self) -> tuple[int, int]:
        r = self.devicePixelRatioF()
        return max(int(self.width() * r), 1), max(int(self.height() * r), 1)

    def paintGL(self) -> None:
        if self.renderer is None:
            return
        t0 = time.perf_counter()
        if self._pending_layers is not None:
            layers, tiles = self._pending_layers
            self._pending_layers = None
            self.renderer.set_layers(layers, tiles)
        if self._pending_thick is not None:
            self.renderer.set_debug_thickness(*self._pending_thick)
            self._pending_thick = None
        if hasattr(self.renderer, "environment"):
            self.renderer.environment = self.environment
        fbo = self.ctx.detect_framebuffer(self.defaultFramebufferObject())
        ring = None
        if self._ring is not None and self.paint_enabled:
            ring = (*self._ring.tolist(), self.brush_radius_units)
        full = self.pixel_size()
        scale = self.interactive_scale if self._interacting else 1.0
        size = (max(int(full[0] * scale), 1), max(int(full[1] * scale), 1)) if scale < 1.0 else full
        target = fbo if size == full else self._offscreen(size)
        if hasattr(self.renderer, "interactive"):
            self.renderer.interactive = self._interacting
        self.renderer.render(target, size, self.camera, self.lighting, split=self.split,
                             debug=self.debug, reference=self.reference, roughness=self.roughness,
                             brush=ring)
        self._last_scale = size[0] / full[0]
        if target is not fbo:
            self._upscale(fbo, full)
        if self.overlay.isVisible():
            self.ctx.finish()
        self.frame_ms = (time.perf_counter() - t0) * 1000.0
        self.frames += 1
        if self.first_frame_time is None:
            self.first_frame_time = time.perf_counter()
        if self.overlay.isVisible():
            self.overlay.setText(f"{self.frame_ms:5.1f} ms  ({1000.0 / max(self.frame_ms, 1e-3):4.0f} fps)  "
                                 f"{self.renderer.name}")
            self.overlay.adjustSize()
        self.frame_drawn.emit(self.frame_ms)

    # ------------------------------------------------------------------ inputs from the window
    def set_layers(self, layers: list[Any], tiles: list[tuple[int, int]] | None) -> None:
        """Queue a texture-space update (applied in the next paintGL, with our context current)."""
        if self._pending_layers is not None:
            old_tiles = self._pending_layers[1]
            tiles = None if (tiles is None or old_tiles is None) else sorted(set(old_tiles) | set(tiles))
        self._pending_layers = (layers, tiles)
        self.update()

    def set_thickness_view(self, thickness: np.ndarray | None, tmax: float, index: int = 0) -> None:
        self._pending_thick = (None if thickness is None else thickness.copy(), tmax, index)
        self.update()

    def frame_head(self) -> None:
        v = self.head.vertices
        top = v[:, 1].max()
        face = v[(v[:, 1] > top - 4.6) & (v[:, 2] > v[:, 2].min() + 0.3 * np.ptp(v[:, 2]))]
        if len(face) == 0:
            face = v
        self.camera.frame(face.min(axis=0), face.max(axis=0))
        self.update()

    def set_overlay(self, on: bool) -> None:
        self.overlay.setVisible(on)
        self.update()

    # ------------------------------------------------------------------ picking
    def pick(self, pos: QPointF) -> np.ndarray | None:
        if self.renderer is None:
            return None
        r = self.devicePixelRatioF() * self._last_scale
        w, h = self.pixel_size()
        size = (max(int(w * self._last_scale), 1), max(int(h * self._last_scale), 1))
        self.makeCurrent()
        try:
            return self.renderer.pick(int(pos.x() * r), int(pos.y() * r), size, self.camera)
        finally:
            self.doneCurrent()

    # ------------------------------------------------------------------ events
    def tabletEvent(self, event: QTabletEvent) -> None:
        self._pressure = float(event.pressure()) if event.pressure() > 0 else 1.0
        self._tablet = event.type() != QTabletEvent.Type.TabletRelease
        event.ignore()  # Qt then synthesises the mouse events, which carry our pressure

    def _pressure_now(self) -> float:
        return self._pressure if self._tablet else 1.0

    def mousePressEvent(self, event: QMouseEvent) -> None:
        pos = event.position()
        self._last = pos
        mods = event.modifiers()
        btn = event.button()
        if btn == Qt.MouseButton.LeftButton and mods & Qt.KeyboardModifier.ControlModifier:
            self._drag = "light"
        elif btn == Qt.MouseButton.LeftButton and self.paint_enabled:
            hit = self.pick(pos)
            if hit is not None:
                self._drag = "paint"
                self._ring = hit
                self.stroke_begin.emit(hit, self._pressure_now())
            else:
                self._drag = "orbit"
        elif btn == Qt.MouseButton.LeftButton:
            self._drag = "orbit"
        elif btn == Qt.MouseButton.MiddleButton or (
                btn == Qt.MouseButton.RightButton and mods & Qt.KeyboardModifier.ShiftModifier):
            self._drag = "pan"
        elif btn == Qt.MouseButton.RightButton:
            self._drag = "orbit"
        event.accept()

    def mouseMoveEvent(self, event: QMouseEvent) -> None:
        pos = event.position()
        dx, dy = pos.x() - self._last.x(), pos.y() - self._last.y()
        self._last = pos
        if self._drag is not None:
            self.begin_interaction()
        if self._drag == "orbit":
            self.camera.orbit(-dx * 0.4, dy * 0.4)
        elif self._drag == "pan":
            h = max(self.height(), 1)
            self.camera.pan(dx / h, dy / h)
        elif self._drag == "light":
            az = self.lighting.azimuth + dx * 0.5
            el = float(np.clip(self.lighting.elevation - dy * 0.5, -80.0, 85.0))
            self.lighting.azimuth = (az + 180.0) % 360.0 - 180.0
            self.lighting.elevation = el
            self.light_moved.emit(self.lighting.azimuth, el)
        elif self._drag == "paint":
            hit = self.pick(pos)
            if hit is not None:
                self._ring = hit
                self.stroke_move.emit(hit, self._pressure_now())
        elif self.paint_enabled:
            # hovering moves the brush ring: quick frames while the mouse moves, a full one when it rests
            ring = self.pick(pos)
            if ring is None and self._ring is None:
                return
            self._ring = ring
            self.begin_interaction()
        else:
            return  # nothing on screen depends on a hover (the kiosk)
        self.update()

    def mouseReleaseEvent(self, event: QMouseEvent) -> None:
        if self._drag == "paint":
            self.stroke_end.emit()
        self._drag = None
        self.update()

    def leaveEvent(self, event: Any) -> None:
        self._ring = None
        self.update()

    def wheelEvent(self, event: QWheelEvent) -> None:
        self.begin_interaction()
        steps = event.angleDelta().y() / 120.0
        self.camera.zoom(math.pow(0.9, steps))
        self.update()

    def orbit_by(self, dyaw: float, dpitch: float = 0.0) -> None:
        self.begin_interaction()
        self.camera.orbit(dyaw, dpitch)
        self.update()
