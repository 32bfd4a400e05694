"""Starting the studio: the QApplication, the surface format, logging, and a readable error on failure."""

from __future__ import annotations

import logging
import sys
from pathlib import Path

log = logging.getLogger("sheer.app")

#: The thickness maps' resolution (texels per side) for a new document in the studio and the kiosk.
#:
#: 2048², the issue's own example. What the resolution costs a dab is its share of dab-to-frame: the
#: painting and the texture-space KM of the tiles it touches (``sheer bench studio`` reports it as
#: ``dab_update_ms``). Measured on the shared 2-core machine under load (load average 4–5, renderer at
#: 2d088a1, 8 mm brush): 10 ms at 1024², 20–50 ms at 2048² (27 ms median over runs), against a frame of
#: the renderer of 200–400 ms on that machine then. The frame, not the resolution, is what keeps
#: dab-to-frame above 100 ms today; with the renderer's target frame (≤ ~40 ms) 2048² leaves
#: dab-to-frame within 100 ms, so no smaller default is needed. Re-measure with
#: ``sheer bench studio --json --resolution N`` (``--resolution`` on ``sheer studio`` overrides this).
DEFAULT_RESOLUTION = 2048


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
    from PySide6.QtGui import QIcon

    from core.assets import resource_path

    icon = resource_path("icons", "sheer.png")
    if icon.is_file():
        app.setWindowIcon(QIcon(str(icon)))
    return app


def run_studio(head: str | None = None, look: str = "natural", project: str | None = None,
               resolution: int = DEFAULT_RESOLUTION) -> int:
    from core.errors import SheerError

    app = make_application()
    from app import dialogs, seams
    from app.main_window import StudioWindow
    from app.viewport import preload_renderer_modules

    preload_renderer_modules()  # in a worker, while the head and document are prepared
    try:
        library = seams.load_library()
    except SheerError as exc:
        dialogs.error(None, "Sheer Studio", f"The material library could not be read: {exc}")
        return 2
    outcome = open_document_with_progress(head, resolution, library, look)
    if isinstance(outcome, str):
        if outcome != "cancelled":
            dialogs.error(None, "Sheer Studio", f"The studio could not start: {outcome}")
        return 2 if outcome != "cancelled" else 0
    try:
        win = StudioWindow(look="", resolution=resolution, document=outcome, library=library)
    except SheerError as exc:
        dialogs.error(None, "Sheer Studio", f"The studio could not start: {exc}")
        return 2
    win.show()
    if project:
        win.open_project(Path(project))
    return int(app.exec())  # type: ignore[attr-defined]


def open_document_with_progress(head: str | None, resolution: int, library: object, look: str = "") -> object:
    """Build the painting document in a worker thread (mesh cleaning, UV check or unwrap, bake, then the
    look's strokes) with a progress dialog and Cancel; returns the document, or an error message
    (``"cancelled"``).
    """
    from PySide6.QtCore import QEventLoop

    from app import seams
    from app.workers import Cancelled, run_task

    outcome: dict[str, object] = {}
    loop = QEventLoop()

    active = [True]

    def job(progress: object, cancelled: object) -> object:
        def report(stage: str, fraction: float) -> None:
            # the document keeps this callback for later (lazy) bakes: only report while opening
            if not active[0]:
                return
            if cancelled():  # type: ignore[operator]
                raise Cancelled()
            progress(float(fraction), str(stage))  # type: ignore[operator]

        try:
            doc = seams.open_document(Path(head) if head else None, resolution, library, progress=report)
        finally:
            active[0] = False
        if look:
            progress(1.0, f"painting the look '{look}'")  # type: ignore[operator]
            seams.apply_look(doc, library, look)
            doc.clear_history()
        return doc

    def finish(key: str, value: object) -> None:
        outcome[key] = value
        loop.quit()

    run_task(None, "Opening the head", job, lambda d: finish("doc", d), lambda m: finish("error", m))
    loop.exec()
    return outcome.get("doc", outcome.get("error", "cancelled"))
