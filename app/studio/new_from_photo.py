"""File → New from Photo…: capture a face from a photograph and paint the current look on it.

The photograph goes through :func:`capture.auto.capture_auto` in a worker (a progress dialog follows its
steps; Cancel stops between them), which builds the person's own head — a full head (``full_head=True``: the
sample head's skull, ears and neck warped onto her landmarks, her photograph on her face, her skin tone
elsewhere), as the kiosk captures, so the studio shows her face on a head rather than a face mask — and
writes a face folder under :func:`faces_dir`. The studio's current layers are then moved onto that head
(:func:`painting.transfer.transfer_document`, also in the worker), and a new studio window opens on the
result — the captured head as the document's head, its face open for the lightweight mode — while the
window it came from closes (offering to save its unsaved work first, as File → New does).

A photograph the quality gate refuses (no face, two faces, turned, too small, eyes closed, blurred,
washed out, too dark) is a message listing each reason in the gate's own friendly words; nothing is
written and the studio is left as it was. On success a message gives the quality report (the measured
values against their thresholds) and what the transfer did.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from PySide6.QtWidgets import QFileDialog

from app.studio import dialogs
from app.workers import Cancelled, run_task

if TYPE_CHECKING:
    from collections.abc import Callable

    from capture.face import Face
    from painting.document import Document
    from painting.transfer import TransferReport

#: Photographs the file dialog offers.
PHOTO_FILTER = "Photographs (*.jpg *.jpeg *.png *.tif *.tiff *.bmp *.webp);;All files (*)"
#: Share of the progress bar the capture takes (the transfer the rest).
_CAPTURE_SHARE = 0.8
#: Steps capture_auto reports (about; the bar advances one share per step).
_CAPTURE_STEPS = 12
#: The studio windows opened from photographs (kept alive until they close).
_OPENED: list[Any] = []


def faces_dir() -> Path:
    """Where captured faces are kept.

    ``$SHEER_FACES_DIR``, else ``$XDG_DATA_HOME/sheer/faces`` (default ``~/.local/share/sheer/faces``).
    """
    env = os.environ.get("SHEER_FACES_DIR")
    if env:
        return Path(env).expanduser()
    data = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(data) / "sheer" / "faces"


@dataclass
class Captured:
    """What the worker hands back: the face, the document on its head, the transfer's report."""

    photo: Path
    folder: Path
    face: Face
    document: Document
    report: TransferReport


def capture_and_transfer(photo: Path, folder: Path, source: Document, progress: Callable[[float, str], None],
                         cancelled: Callable[[], bool]) -> Captured | Any:
    """The worker's job: capture ``photo`` into ``folder``, then move ``source``'s layers onto the new head.

    Returns the :class:`Captured`, or the :class:`capture.quality.QualityError` when the gate refuses the
    photograph (a result, so its every reason reaches the window). Raises :class:`app.workers.Cancelled`.
    """
    from capture.auto import capture_auto
    from capture.quality import QualityError
    from painting.transfer import transfer_document

    steps = [0]

    def step(message: str) -> None:
        if cancelled():
            raise Cancelled()
        steps[0] += 1
        progress(min(steps[0] / _CAPTURE_STEPS, 1.0) * _CAPTURE_SHARE, message)

    progress(0.0, f"reading {photo.name}")
    try:
        face = capture_auto(photo, folder, progress=step, full_head=True)
    except QualityError as exc:
        return exc
    if cancelled():
        raise Cancelled()

    def transfer_progress(stage: str, fraction: float) -> None:
        if cancelled():
            raise Cancelled()
        progress(_CAPTURE_SHARE + (1.0 - _CAPTURE_SHARE) * float(fraction),
                 f"moving the layers onto the captured face ({stage})")

    try:
        document, report = transfer_document(source, face.load_head(), progress=transfer_progress)
    except BaseException:  # cancelled or failed: the new face folder is not kept either
        import shutil

        shutil.rmtree(folder, ignore_errors=True)
        raise
    return Captured(photo, folder, face, document, report)


def quality_summary(face: Face) -> str:
    """The capture's quality report in a few lines (measured value against its threshold)."""
    q = face.data.get("quality") or {}
    m, t = q.get("measured", {}), q.get("thresholds", {})
    rows = [("head turned", "yaw_deg", "max_yaw_deg", "°"), ("head tilted", "roll_deg", "max_roll_deg", "°"),
            ("face height", "face_height_ratio", "min_face_height_ratio", "×"),
            ("eyes open", "eye_openness_ratio", "min_eye_openness_ratio", "×"),
            ("sharpness", "sharpness_ratio", "min_sharpness_ratio", "×"),
            ("washed-out skin", "clipped_skin_ratio", "max_clipped_skin_ratio", "×")]
    lines = [f"{label}: {m[key]:+.2f}{unit} (limit {t[limit]:.2f})" for label, key, limit, unit in rows
             if key in m and limit in t]
    return "\n".join(lines)


class NewFromPhoto:
    """File → New from Photo… for one studio window (see the module docstring).

    ``window`` is an :class:`app.studio.main_window.StudioWindow` (not imported here: the window imports this
    module for its menu).
    """

    def __init__(self, window: Any) -> None:
        self.window = window
        #: the window opened on the captured face (a StudioWindow of the same class), once there is one
        self.opened: Any = None

    @classmethod
    def ask_for(cls, window: Any) -> NewFromPhoto | None:
        """Ask for a photograph, then :meth:`start` on it; None when the user cancels the file dialog."""
        name, _ = QFileDialog.getOpenFileName(window, "New from Photo: choose a portrait", "", PHOTO_FILTER)
        if not name:
            return None
        action = cls(window)
        action.start(Path(name))
        return action

    def start(self, photo: Path, folder: Path | None = None) -> None:
        """Capture ``photo`` (into ``folder``, default a new folder in :func:`faces_dir`) in a worker."""
        if folder is None:
            folder = faces_dir() / f"{photo.stem}-{time.strftime('%Y%m%d-%H%M%S')}"
        try:
            folder.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            dialogs.error(self.window, "New from Photo", f"{folder.parent}: cannot create the faces folder: "
                                                          f"{exc.strerror}")
            return
        source = self.window.doc
        run_task(self.window, "New from Photo",
                 lambda progress, cancelled: capture_and_transfer(photo, folder, source, progress, cancelled),
                 self._done, self._failed)

    def _failed(self, message: str) -> None:
        if message != "cancelled":
            dialogs.error(self.window, "New from Photo", f"The photograph could not be captured: {message}")

    def _done(self, result: Captured | Any) -> None:
        from capture.quality import QualityError

        if isinstance(result, QualityError):
            reasons = "\n".join(f"• {issue.message}" for issue in result.issues)
            dialogs.error(self.window, "New from Photo", f"This photograph cannot be used:\n{reasons}")
            return
        self._open(result)

    def _open(self, captured: Captured) -> None:
        """A studio window on the captured head with the transferred layers; the old window then closes."""
        from app.session import Session

        old = self.window
        win = type(old)(Session(old.library, captured.document), qsettings=old.qsettings)  # a StudioWindow
        win.viewport.face = captured.face
        win.face_path = captured.folder
        win.files.name = f"{old.files.name} on {captured.document.head.name}"
        win.files.set_modified(True)  # a new, unsaved document
        # the same window: its size, place, docks and the dock tab in front (e.g. the Shade Finder)
        from app.studio.toolbars import WINDOW_STATE_VERSION

        win.restoreGeometry(old.saveGeometry())
        win.restoreState(old.saveState(WINDOW_STATE_VERSION), WINDOW_STATE_VERSION)
        win.show()
        win.apply()
        _OPENED.append(win)
        win.destroyed.connect(lambda *_: _OPENED.remove(win) if win in _OPENED else None)
        self.opened = win
        win.statusBar().showMessage(captured.report.summary(), 15000)
        dialogs.info(win, "New from Photo",
                     f"Captured {captured.photo.name} into {captured.folder}.\n"
                     f"Quality gate passed:\n{quality_summary(captured.face)}\n\n{captured.report.summary()}")
        if old.close():  # (it may offer to save first; Cancel keeps it open)
            old.deleteLater()
