"""The viewport's GL window and what it needs from Qt: the surface, moderngl on Qt's context, captions.

:class:`GLSurface` is a ``QOpenGLWindow`` embedded in :class:`app.view.viewport.Viewport` with
``QWidget.createWindowContainer``: it draws straight to its own native window and swaps it (no
``QOpenGLWidget`` composition of the whole top-level window), paints through the viewport and hands it
every input event. :func:`attach_moderngl` puts moderngl on Qt's context whether Qt drives EGL or GLX;
:class:`Caption` is a line of text painted over the frame (widgets cannot stack over a native window).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

from PySide6.QtCore import QEvent, QPointF, QRectF, Qt
from PySide6.QtGui import QColor, QMouseEvent, QPainter, QSurfaceFormat, QTabletEvent, QWheelEvent
from PySide6.QtOpenGL import QOpenGLWindow

if TYPE_CHECKING:
    import moderngl
    from PySide6.QtGui import QOpenGLContext


class SurfaceHost(Protocol):
    """What :class:`GLSurface` needs of the widget it serves (:class:`app.view.viewport.Viewport`)."""

    def initializeGL(self) -> None: ...  # noqa: D102, N802
    def paintGL(self) -> None: ...  # noqa: D102, N802
    def paint_captions(self, device: GLSurface) -> None: ...  # noqa: D102
    def setFocus(self, reason: Qt.FocusReason) -> None: ...  # noqa: D102, N802
    def mousePressEvent(self, event: QMouseEvent) -> None: ...  # noqa: D102, N802
    def mouseMoveEvent(self, event: QMouseEvent) -> None: ...  # noqa: D102, N802
    def mouseReleaseEvent(self, event: QMouseEvent) -> None: ...  # noqa: D102, N802
    def wheelEvent(self, event: QWheelEvent) -> None: ...  # noqa: D102, N802
    def tabletEvent(self, event: QTabletEvent) -> None: ...  # noqa: D102, N802
    def leaveEvent(self, event: QEvent) -> None: ...  # noqa: D102, N802


class QtGLLoader:
    """Hands moderngl the GL functions of Qt's current context (``QOpenGLContext.getProcAddress``).

    Works whether Qt drives GLX or EGL. ``moderngl.create_context()`` alone would look for a GLX context
    once any headless (EGL) context exists in the process, and fail under Qt's EGL integration.
    """

    def __init__(self, context: QOpenGLContext) -> None:
        self.context = context

    def load_opengl_function(self, name: str) -> int:
        """The address of GL function ``name`` (0 if the driver has none)."""
        return int(self.context.getProcAddress(name.encode("ascii")) or 0)

    def release(self) -> None:
        """Nothing to free: the context is Qt's."""

    def __enter__(self) -> None:
        """No context switch needed (Qt made its context current)."""

    def __exit__(self, *args: object) -> None:
        """See :meth:`__enter__`."""


def attach_moderngl(moderngl: Any, context: QOpenGLContext) -> moderngl.Context:
    """A moderngl context on Qt's current GL ``context`` (EGL or GLX, whichever Qt uses)."""
    moderngl.init_context(QtGLLoader(context))
    return moderngl.get_context()


def default_surface_format() -> QSurfaceFormat:
    """OpenGL 4.1 core with a depth buffer and no vsync (frames are drawn on demand)."""
    fmt = QSurfaceFormat()
    fmt.setVersion(4, 1)
    fmt.setProfile(QSurfaceFormat.OpenGLContextProfile.CoreProfile)
    fmt.setDepthBufferSize(24)
    fmt.setSwapInterval(0)
    return fmt


class Caption:
    """A line of text drawn over the frame (the overlay, a notice): its text, colours and visibility."""

    def __init__(self, colour: str, background: QColor) -> None:
        self._text = ""
        self._visible = False
        self.colour = QColor(colour)
        self.background = background

    def text(self) -> str:
        """The caption's text."""
        return self._text

    def setText(self, text: str) -> None:  # (the QLabel API it replaces)
        """Set the text."""
        self._text = text

    def isVisible(self) -> bool:
        """Whether it is drawn over the frame."""
        return self._visible

    def setVisible(self, on: bool) -> None:
        """Show or hide it."""
        self._visible = bool(on)

    def draw(self, painter: QPainter, x: float, y: float, bottom: bool = False) -> None:
        """Draw the caption's box with its top-left (or bottom-left if ``bottom``) corner at (x, y) px."""
        lines = self._text.split("\n")
        fm = painter.fontMetrics()
        w = max(fm.horizontalAdvance(line) for line in lines) + 8
        h = fm.height() * len(lines) + 6
        top = y - h if bottom else y
        painter.fillRect(QRectF(x, top, w, h), self.background)
        painter.setPen(self.colour)
        for i, line in enumerate(lines):
            painter.drawText(QPointF(x + 4, top + 3 + fm.ascent() + i * fm.height()), line)


class GLSurface(QOpenGLWindow):
    """The viewport's GL window: paints through the :class:`Viewport` and hands it every input event."""

    def __init__(self, view: SurfaceHost) -> None:
        super().__init__(QOpenGLWindow.UpdateBehavior.NoPartialUpdate)
        self.view = view
        self.setFormat(default_surface_format())
        # keyboard focus stays with the studio's widgets (their shortcuts), the view takes it on a click
        self.setFlag(Qt.WindowType.WindowDoesNotAcceptFocus, True)

    def initializeGL(self) -> None:
        """The view's GL set-up."""
        self.view.initializeGL()

    def paintGL(self) -> None:
        """The view's frame."""
        self.view.paintGL()

    def paintOverGL(self) -> None:
        """The view's captions over the frame."""
        self.view.paint_captions(self)

    def mousePressEvent(self, event: QMouseEvent) -> None:
        """To the view (which takes the keyboard focus)."""
        self.view.setFocus(Qt.FocusReason.MouseFocusReason)
        self.view.mousePressEvent(event)

    def mouseMoveEvent(self, event: QMouseEvent) -> None:
        """To the view."""
        self.view.mouseMoveEvent(event)

    def mouseReleaseEvent(self, event: QMouseEvent) -> None:
        """To the view."""
        self.view.mouseReleaseEvent(event)

    def wheelEvent(self, event: QWheelEvent) -> None:
        """To the view."""
        self.view.wheelEvent(event)

    def tabletEvent(self, event: QTabletEvent) -> None:
        """To the view."""
        self.view.tabletEvent(event)

    def event(self, event: QEvent) -> bool:
        """The pointer leaving the window reaches the view too (it hides the brush ring)."""
        if event.type() == QEvent.Type.Leave:
            self.view.leaveEvent(event)
        return super().event(event)
