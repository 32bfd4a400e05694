"""Starting the studio: the QApplication, the surface format, logging, and a readable error on failure."""

from __future__ import annotations

import logging
import sys
from pathlib import Path

log = logging.getLogger("sheer.app")


def make_application(argv: list[str] | None = None) -> object:
    from PySide6.QtGui import QSurfaceFormat
    from PySide6.QtWidgets import QApplication

    from app.qt_compat import pin_singletons
    from app.settings import APPLICATION, ORGANISATION
    from app.viewport import default_surface_format

    pin_singletons()
    import os

    os.environ.setdefault("MPLBACKEND", "Agg")  # colour-science imports pyplot; never a GUI backend

    app = QApplication.instance()
    if app is None:
        QSurfaceFormat.setDefaultFormat(default_surface_format())
        app = QApplication(argv or [sys.argv[0]])
    app.setOrganizationName(ORGANISATION)
    app.setApplicationName(APPLICATION)
    return app


def run_studio(head: str | None = None, look: str = "natural", project: str | None = None,
               resolution: int = 512) -> int:
    from km.errors import SheerError

    app = make_application()
    from app import dialogs
    from app.main_window import StudioWindow

    try:
        win = StudioWindow(head_path=Path(head) if head else None, look=look, resolution=resolution)
    except SheerError as exc:
        dialogs.error(None, "Sheer Studio", f"The studio could not start: {exc}")
        return 2
    win.show()
    if project:
        win.open_project(Path(project))
    return int(app.exec())  # type: ignore[attr-defined]
