"""Starting the studio: the QApplication, the surface format, logging, and a readable error on failure."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING

from app.application import make_application
from app.settings import DEFAULT_RESOLUTION

if TYPE_CHECKING:
    from collections.abc import Callable

    from app.session import Session
    from km.library import Library

log = logging.getLogger("sheer.app")


def run_studio(head: str | None = None, look: str = "natural", project: str | None = None,
               resolution: int = DEFAULT_RESOLUTION) -> int:
    """Start the studio and run its event loop; returns the process exit status.

    The head's document is built in a worker with a progress dialog (Cancel ends with status 0); an
    unreadable library, head or look is a message box and status 2, never a traceback.

    Args:
        head: the head mesh; None for the sample head.
        look: the built-in look to start with ("" for none).
        project: a ``.sheer`` project to open once the window is up.
        resolution: texels per side of the thickness maps.
    """
    from core.errors import SheerError

    app = make_application()
    from app.session import load_library
    from app.studio import dialogs
    from app.studio.main_window import StudioWindow
    from app.view.viewport import preload_renderer_modules

    preload_renderer_modules()  # in a worker, while the head and document are prepared
    try:
        library = load_library()
    except SheerError as exc:
        dialogs.error(None, "Sheer Studio", f"The material library could not be read: {exc}")
        return 2
    outcome = open_session_with_progress(head, resolution, library, look)
    if isinstance(outcome, str):
        if outcome != "cancelled":
            dialogs.error(None, "Sheer Studio", f"The studio could not start: {outcome}")
        return 2 if outcome != "cancelled" else 0
    try:
        win = StudioWindow(outcome)
    except SheerError as exc:
        dialogs.error(None, "Sheer Studio", f"The studio could not start: {exc}")
        return 2
    win.show()
    if project:
        win.open_project(Path(project))
    return int(app.exec())


def open_session_with_progress(head: str | None, resolution: int, library: Library, look: str = "") -> Session | str:
    """Open a :class:`app.session.Session` in a worker thread with a progress dialog and Cancel.

    The dialog follows the stages of :meth:`app.session.Session.open` (mesh cleaning, UV check or unwrap,
    bake, then the look's strokes) while the event loop keeps running.

    Returns:
        The session, or a one-line error message (``"cancelled"`` when the user cancelled).
    """
    from PySide6.QtCore import QEventLoop

    from app.session import Session
    from app.workers import Cancelled, run_task

    outcome: dict[str, Session | str] = {}
    loop = QEventLoop()

    def job(progress: Callable[[float, str], None], cancelled: Callable[[], bool]) -> Session:
        def report(stage: str, fraction: float) -> None:
            if cancelled():
                raise Cancelled()
            progress(float(fraction), str(stage))

        return Session.open(Path(head) if head else None, resolution, look, library=library, progress=report)

    def finish(key: str, value: Session | str) -> None:
        outcome[key] = value
        loop.quit()

    run_task(None, "Opening the head", job, lambda s: finish("session", s), lambda m: finish("error", m))
    loop.exec()
    return outcome.get("session", outcome.get("error", "cancelled"))
