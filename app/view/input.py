"""The viewport's pointer input: painting, orbiting, panning, moving the key light, zooming, picking.

Mixed into :class:`app.view.viewport.Viewport` (its GL surface hands it every input event):

- Left drag on the head paints (signals to the window, which owns the document), left drag off the head
  or right drag orbits, middle (or Shift+right) drag pans, the wheel zooms, Ctrl+left drag moves the key
  light. Hovering shows the brush ring on the surface (a ring-only redraw reuses the last frame).
- Tablet pressure is read from ``QTabletEvent`` and applied to the mouse events Qt synthesises from it.
- Picking reads the depth of the last frame the renderer drew (the current view).
- Every input that changes the view or the makeup calls :meth:`Viewport.note_input` (interactive frames);
  a drag's release settles the view at once (:meth:`Viewport.settle_now`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from PySide6.QtCore import QEvent, QPointF, Qt
from PySide6.QtGui import QMouseEvent, QTabletEvent, QWheelEvent

if TYPE_CHECKING:
    import moderngl
    from PySide6.QtCore import SignalInstance

    from app.view.camera import Lighting, ViewCamera
    from app.view.gl_surface import GLSurface
    from render.view import ViewRenderer


class ViewportInput:
    """Pointer input of :class:`app.view.viewport.Viewport` (a mixin: the widget holds the view's state)."""

    # what the viewport provides (see app.view.viewport.Viewport)
    ctx: moderngl.Context | None
    camera: ViewCamera
    lighting: Lighting
    surface: GLSurface
    renderer: ViewRenderer | None
    paint_enabled: bool
    pick_next: bool
    stage: str
    stroke_begin: SignalInstance
    stroke_move: SignalInstance
    stroke_end: SignalInstance
    light_moved: SignalInstance
    surface_picked: SignalInstance

    def init_input(self) -> None:
        """The pointer's state: no drag, no ring, full pressure (the viewport calls it once, when made)."""
        #: the brush ring's centre on the surface (mesh units), or None (hidden); the pointer moves it
        self.brush_ring: np.ndarray | None = None
        #: the drag in progress: "paint", "orbit", "pan" or "light" while a button is down, else None
        self.drag: str | None = None
        #: the current drag has moved the view, a light or the makeup (set by :meth:`note_input`)
        self.drag_moved = False
        self._last = QPointF()
        self._pressure = 1.0
        self._tablet = False

    if TYPE_CHECKING:  # what the viewport implements (never defined here: they would shadow QWidget's)
        def update(self) -> None: ...  # noqa: D102
        def note_input(self, drag: bool = False) -> None: ...  # noqa: D102
        def settle_now(self) -> None: ...  # noqa: D102
        def settle_after_quiet(self) -> None: ...  # noqa: D102
        def makeCurrent(self) -> None: ...  # noqa: D102, N802
        def doneCurrent(self) -> None: ...  # noqa: D102, N802
        def devicePixelRatioF(self) -> float: ...  # noqa: D102, N802
        def height(self) -> int: ...  # noqa: D102

    # ------------------------------------------------------------------ picking
    def pick(self, pos: QPointF) -> np.ndarray | None:
        """The surface point under ``pos`` (widget coordinates) in the last frame, or None."""
        if self.renderer is None or self.ctx is None:
            return None
        r = self.devicePixelRatioF()
        self.makeCurrent()
        try:
            return self.renderer.pick(int(pos.x() * r), int(pos.y() * r), self.camera)
        finally:

            self.doneCurrent()

    # ------------------------------------------------------------------ events
    def tabletEvent(self, event: QTabletEvent) -> None:
        """Keep the pen's pressure (0..1) for the mouse events Qt synthesises from it."""
        self._pressure = float(event.pressure()) if event.pressure() > 0 else 1.0
        self._tablet = event.type() != QTabletEvent.Type.TabletRelease
        event.ignore()  # Qt then synthesises the mouse events, which carry our pressure

    def _pressure_now(self) -> float:
        return self._pressure if self._tablet else 1.0

    def mousePressEvent(self, event: QMouseEvent) -> None:
        """Start a drag: paint on the head, orbit, pan or move the light (see the module docstring)."""
        pos = event.position()
        self._last = pos
        self.drag_moved = False
        mods = event.modifiers()
        btn = event.button()
        if btn == Qt.MouseButton.LeftButton and self.pick_next:
            hit = self.pick(pos)  # a pick for a tool (the Shade Finder's skin), not a stroke
            if hit is not None:
                self.pick_next = False
                self.surface.setCursor(Qt.CursorShape.ArrowCursor)
                self.surface_picked.emit(hit)
            event.accept()
            return
        if btn == Qt.MouseButton.LeftButton and mods & Qt.KeyboardModifier.ControlModifier:
            self.drag = "light"
        elif btn == Qt.MouseButton.LeftButton and self.paint_enabled:
            hit = self.pick(pos)
            if hit is not None:
                self.drag = "paint"
                self.brush_ring = hit
                self.note_input(drag=True)
                self.stroke_begin.emit(hit, self._pressure_now())
            else:
                self.drag = "orbit"
        elif btn == Qt.MouseButton.LeftButton:
            self.drag = "orbit"
        elif btn == Qt.MouseButton.MiddleButton or (
                btn == Qt.MouseButton.RightButton and mods & Qt.KeyboardModifier.ShiftModifier):
            self.drag = "pan"
        elif btn == Qt.MouseButton.RightButton:
            self.drag = "orbit"
        event.accept()

    def mouseMoveEvent(self, event: QMouseEvent) -> None:
        """Continue the drag, or move the brush ring while hovering."""
        pos = event.position()
        dx, dy = pos.x() - self._last.x(), pos.y() - self._last.y()
        self._last = pos
        if self.drag == "orbit":
            self.camera.orbit(-dx * 0.4, dy * 0.4)
            self.note_input(drag=True)
        elif self.drag == "pan":
            h = max(self.height(), 1)
            self.camera.pan(dx / h, dy / h)
            self.note_input(drag=True)
        elif self.drag == "light":
            az = self.lighting.azimuth + dx * 0.5
            el = float(np.clip(self.lighting.elevation - dy * 0.5, -80.0, 85.0))
            self.lighting.azimuth = (az + 180.0) % 360.0 - 180.0
            self.lighting.elevation = el
            self.note_input(drag=True)
            self.light_moved.emit(self.lighting.azimuth, el)
        elif self.drag == "paint":
            hit = self.pick(pos)
            if hit is not None:
                self.brush_ring = hit
                self.note_input(drag=True)
                self.stroke_move.emit(hit, self._pressure_now())
        elif self.paint_enabled:
            # hovering moves the brush ring: quick frames while the mouse moves, a full one when it rests
            ring = self.pick(pos)
            if ring is None and self.brush_ring is None:
                return
            self.brush_ring = ring
        else:
            return  # nothing on screen depends on a hover (the kiosk)
        self.update()

    def mouseReleaseEvent(self, event: QMouseEvent) -> None:
        """End the drag (a stroke ends here); a drag that moved the view or the makeup settles at once.

        Releasing the button is the end of the drag's input, known for certain: waiting out
        :data:`app.view.viewport.SETTLE_MS` would only delay the full frame (the timer stays for the wheel, keys
        and the kiosk's turns, whose end cannot be seen).
        """
        was, moved = self.drag, self.drag_moved
        self.drag, self.drag_moved = None, False
        if was == "paint":
            self.stroke_end.emit()
        if moved and self.stage == "interactive":
            self.settle_now()
        elif was is not None and self.stage == "interactive":
            self.settle_after_quiet()  # (from the last move: releasing the button is no movement)
        self.update()

    def leaveEvent(self, event: QEvent) -> None:
        """Hide the brush ring when the pointer leaves."""
        self.brush_ring = None
        self.update()

    def wheelEvent(self, event: QWheelEvent) -> None:
        """Zoom: each notch scales the camera distance by 0.9 (in) or 1/0.9 (out)."""
        steps = event.angleDelta().y() / 120.0
        self.camera.zoom(math.pow(0.9, steps))
        self.note_input()

    def orbit_by(self, dyaw: float, dpitch: float = 0.0) -> None:
        """Turn the view (the kiosk's attract mode): an input like a drag (interactive frames, then settle)."""
        self.camera.orbit(dyaw, dpitch)
        self.note_input()
