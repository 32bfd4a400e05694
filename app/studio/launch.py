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
    from project.model import Project

log = logging.getLogger("sheer.app")


def run_studio(head: str | None = None, look: str = "natural", project: str | None = None,
               resolution: int | None = None) -> int:
    """Start the studio and run its event loop; returns the process exit status.

    The head's document is built in a worker with a progress dialog (Cancel ends with status 0); an
    unreadable library, head or look is a message box and status 2, never a traceback.

    Args:
        head: the head mesh; None for the project's (a head it references), else the sample head.
        look: the built-in look to start with ("" for none).
        project: a ``.sheer`` project to open once the window is up. It is checked first, before any
            window: a file that is not a valid project raises (the command line's one-line refusal,
            status 2); a missing or changed head is left to the window, which offers to relink it.
        resolution: texels per side of the thickness maps; None: the project's, else
            ``app.settings.DEFAULT_RESOLUTION``.

    Raises:
        core.errors.SheerError: ``project`` is not a valid project (nothing was shown).
    """
    from core.errors import SheerError

    if project:
        opened = check_project_file(Path(project))
        if opened is not None:  # the project's head and resolution, unless others were asked for
            resolution = int(opened.resolution) if resolution is None else resolution
            if head is None and opened.head.data is None and opened.head.mesh_path is not None:
                head = str(opened.head.mesh_path)
    app = make_application()
    from app.session import load_library
    from app.studio import dialogs
    from app.studio.library_dock import user_library_path
    from app.studio.main_window import StudioWindow
    from app.view.viewport import preload_renderer_modules

    preload_renderer_modules()  # in a worker, while the head and document are prepared
    try:
        library = load_library(user_library_path())  # the shipped materials, the user's saved ones over them
    except SheerError as exc:
        try:
            library = load_library()
        except SheerError as shipped:
            dialogs.error(None, "Sheer Studio", f"The material library could not be read: {shipped}")
            return 2
        dialogs.error(None, "Sheer Studio", f"Your material library could not be read: {exc}\n\nThe shipped "
                      f"library is used; Save Library replaces the file (the old one is kept as .bak).")
    outcome = open_session_with_progress(head, resolution or DEFAULT_RESOLUTION, library, look)
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
        win.files.open_project(Path(project), background=True)
    return int(app.exec())


def check_project_file(path: Path) -> Project | None:
    """``path`` opened as a project (every check of docs/FORMAT.md), or None when only its head is amiss.

    Raises:
        core.errors.SheerError: the file is not a valid project (the message names it).
    """
    from project.errors import HeadChecksumError, HeadMissingError
    from project.io import open_project

    try:
        return open_project(path)
    except (HeadMissingError, HeadChecksumError):
        return None  # the studio's window offers to relink the head


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
