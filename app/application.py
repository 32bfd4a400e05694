"""The Qt application both wings start from: the environment Qt reads, the QApplication and its surface format.

The studio (:mod:`app.studio.launch`) and the kiosk (:mod:`app.kiosk.window`) each call
:func:`make_application`; neither imports the other.
"""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from PySide6.QtWidgets import QApplication

#: The variables of which one must be set for Qt to find a display (Qt's own platform choice included).
DISPLAY_VARIABLES = ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM")


def require_display(command: str) -> None:
    """Refuse, in one line, to start a window without a display; call it before anything imports Qt.

    Without ``DISPLAY``, ``WAYLAND_DISPLAY`` or ``QT_QPA_PLATFORM`` Qt's xcb plug-in aborts the process
    (status 134) with a paragraph about reinstalling the application; the line says what to do instead,
    as ``make run`` does.

    Args:
        command: the command being started (``studio``, ``kiosk``), for the line's suggestions.

    Raises:
        core.errors.SheerError: none of the variables is set.
    """
    from core.errors import SheerError

    if any(os.environ.get(name) for name in DISPLAY_VARIABLES):
        return
    raise SheerError(f"no display (DISPLAY is not set): set DISPLAY to your X server, run it under a virtual one "
                     f"with 'xvfb-run -a sheer {command}', or render without a window: 'sheer render --help'")


def configure_qt_environment() -> None:
    """Environment Qt reads when the application starts (call before the ``QApplication`` exists).

    ``QT_XCB_GL_INTEGRATION=xcb_egl`` (unless set): on X11, Qt's GL windows use EGL, as the renderer's
    headless contexts (exports, ``sheer render``) do. With Qt's default GLX integration, once a headless
    EGL context had been created in the process (even released), a Qt GL window shown afterwards could
    never make its context current (measured on Mesa 22.3 + PySide6 6.x: "Failed to make context current",
    then a crash); with EGL on both sides the order does not matter.
    """
    os.environ.setdefault("QT_XCB_GL_INTEGRATION", "xcb_egl")
    os.environ.setdefault("MPLBACKEND", "Agg")  # colour-science imports pyplot; never a GUI backend


def make_application(argv: list[str] | None = None) -> QApplication:
    """The QApplication (made once, with the viewport's OpenGL surface format as the default).

    Also pins Qt's singletons for Python (:func:`app.qt_compat.pin_singletons`), keeps matplotlib off
    GUI backends, and sets the organisation, application name and window icon.
    """
    from PySide6.QtGui import QSurfaceFormat
    from PySide6.QtWidgets import QApplication

    from app.qt_compat import pin_singletons
    from app.settings import APPLICATION, ORGANISATION
    from app.view.gl_surface import default_surface_format

    pin_singletons()
    configure_qt_environment()

    app = QApplication.instance()
    if app is None:
        QSurfaceFormat.setDefaultFormat(default_surface_format())
        app = QApplication(argv or [sys.argv[0]])
    app.setOrganizationName(ORGANISATION)
    app.setApplicationName(APPLICATION)
    from PySide6.QtGui import QIcon

    from core.assets import resource_path

    icon = resource_path("icons", "sheer.png")
    if icon.is_file():
        app.setWindowIcon(QIcon(str(icon)))
    return app
