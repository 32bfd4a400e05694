"""The studio's project files: New, Open, Save, Save As, Save Self-Contained, autosave and crash recovery.

:class:`ProjectFiles` owns which project the studio window shows — its file, its name, the
``project.model.Project`` last opened or saved (the base of the next save, so the head reference and
metadata are kept) and the look it started from — and the autosaver that writes a recovery file of
unsaved work every few minutes. Reading and writing are :mod:`app.project_io` (no Qt), run in worker
threads where they may take seconds; every question (relink a head, resample maps, save changes,
recover work) is a real message box from :mod:`app.studio.dialogs`.

One Sheer at a time writes a project: the window holds the lock of the project it has open
(:class:`app.studio.project_lock.ProjectHold`); opening one another Sheer holds asks "Open a copy / Take
over / Cancel", and a project another Sheer takes over stays in this window as an untitled copy.

The window listens to two signals: :attr:`ProjectFiles.replaced` (the document's layers and the view
settings now come from a project: refresh the panels and apply the settings) and
:attr:`ProjectFiles.changed` (the file, the name or the recent files changed: update the actions).
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING

from PySide6.QtCore import QObject, QTimer, Signal
from PySide6.QtWidgets import QFileDialog, QMainWindow

from app import project_io
from app.settings import ENVIRONMENTS, LIGHT_PRESETS
from app.studio import dialogs
from app.studio.project_lock import ProjectHold
from app.workers import run_task

if TYPE_CHECKING:
    import numpy as np

    from app.session import Session
    from app.settings import StudioSettings
    from app.view.viewport import Viewport
    from painting import ChangeEvent, Document
    from project.model import Project
    from project.recovery import RecoveryInfo

log = logging.getLogger("sheer.app")

#: Seconds between checks whether an autosave is due (the autosave interval itself is a setting).
AUTOSAVE_CHECK_S = 10.0
#: How long the status bar shows that an autosave failed (ms): until about the next try.
AUTOSAVE_FAILED_MS = 12000


def autosave_failure(reason: str) -> str:
    """The status bar's line when an autosave fails (a full disk): ``reason`` names the recovery file.

    The work is still in the window and is autosaved again at the next check; the line says so.
    """
    return f"Autosave failed, will try again: {' '.join(reason.split())}"


class ProjectFiles(QObject):
    """File handling of one studio window (see the module docstring).

    Args:
        window: the studio window (title, modified flag, status bar, parent of dialogs).
        session: the library and the document the window paints on.
        viewport: the window's view (its camera and key light are saved with a project).
        settings: the window's settings (environment, light preset, autosave interval, recent files).

    Attributes:
        path: the project's file, None while untitled.
        name: the project's name (the file's stem, or "Untitled").
        project: the project last opened or saved, None for a new one.
        look_record: the look the document started from, as a project stores it (``{"name", "tags"}``).
        autosaver: the ``project.recovery.Autosaver`` of this window.
        hold: the lock of the project's file this window holds.
    """

    #: The document's layers and the view settings were replaced (a project opened or recovered).
    replaced = Signal()
    #: The project's file or name, or the recent files, changed.
    changed = Signal()

    def __init__(self, window: QMainWindow, session: Session, viewport: Viewport,
                 settings: StudioSettings) -> None:
        super().__init__(window)
        self._window = window
        self.session = session
        self.doc: Document = session.document
        self.viewport = viewport
        self.settings = settings
        self.path: Path | None = None
        self.name = "Untitled"
        self.project: Project | None = None
        self.look_record: dict[str, object] | None = {"name": session.look, "tags": []} if session.look else None
        self.autosaver = project_io.make_autosaver(self.snapshot, None, settings.autosave_minutes * 60.0)
        self.autosaver.watch(self.doc)
        self.hold = ProjectHold(window)
        self.hold.lost.connect(self._taken_over)
        self._copy = False
        self.doc.subscribe(self._on_doc_event)
        self._autosaving = False
        self.timer = QTimer(self)
        self.timer.setInterval(int(AUTOSAVE_CHECK_S * 1000))
        self.timer.timeout.connect(self._autosave_tick)
        self.timer.start()
        self._show_title()

    def _on_doc_event(self, event: ChangeEvent) -> None:
        if event.kind not in ("history", "library"):  # a library edit alone changes nothing the project saves
            self._window.setWindowModified(True)

    def _show_title(self) -> None:
        self._window.setWindowTitle(f"{self.name}[*] — Sheer Studio")

    def set_modified(self, modified: bool) -> None:
        """Mark the document modified (unsaved) or not: the window's title and :attr:`changed` follow."""
        self._window.setWindowModified(modified)
        self._show_title()
        self.changed.emit()

    def view_changed(self) -> None:
        """What the project saves of the view changed (the key light, its preset, the environment).

        The document is then modified (quitting asks) and due for an autosave.
        """
        self.autosaver.mark_dirty()
        if not self._window.isWindowModified():
            self.set_modified(True)

    # ------------------------------------------------------------------ new
    def new_project(self, look: str = "bare") -> None:
        """File → New: a built-in look on the same head, untitled and unmodified, with no undo step.

        Args:
            look: the built-in look to start from (``resources/looks/<look>.json``); File → New uses
                the bare one.
        """
        from core.errors import SheerError

        try:
            self.session.apply_look(look)
        except SheerError as exc:
            dialogs.error(self._window, "New project", str(exc))
            return
        self.autosaver.close()
        self.autosaver.project_path = None
        self.hold.release()
        self.path, self.name = None, "Untitled"
        self.project, self.look_record = None, {"name": look, "tags": []}
        self.set_modified(False)

    # ------------------------------------------------------------------ open
    def open_project(self, path: Path | None = None, background: bool = False) -> bool:
        """Open a ``.sheer`` project into the window's document.

        A missing or changed head offers to relink (:meth:`_offer_relink`); maps at another resolution
        offer to resample. Nothing in the current document changes unless the open succeeds.

        Args:
            path: the project; None asks for one (and reads it in the background).
            background: read and check the file in a worker with a progress dialog and return at once.

        Returns:
            Whether the project was opened (in the background: whether reading it started).
        """
        if path is None:
            name, _ = QFileDialog.getOpenFileName(self._window, "Open project", "", "Sheer projects (*.sheer)")
            if not name:
                return False
            path, background = Path(name), True
        claim = self.hold.claim(Path(path))
        if claim is None:
            return False
        self._copy = claim == "copy"
        return self._open_attempt(Path(path), background, None, False)

    def _open_attempt(self, path: Path, background: bool, head_path: Path | None, accept: bool) -> bool:
        from project.errors import HeadChecksumError, HeadMissingError

        def job(_progress: object = None, _cancelled: object = None) -> object:
            try:
                return project_io.read_document(path, head_path=head_path, accept_head_change=accept)
            except (HeadMissingError, HeadChecksumError) as exc:
                return exc

        def done(result: object) -> bool:
            if isinstance(result, HeadMissingError | HeadChecksumError):
                answer = self._offer_relink(path, result)
                if answer is None:
                    self.hold.drop_pending()
                    return False
                if answer == "accept":  # keep a head located before: it is the one that changed
                    return self._open_attempt(path, background, head_path, True)
                return self._open_attempt(path, background, answer, False)
            project, opened = result  # type: ignore[misc]
            if not self._opened(path, project, opened):
                self.hold.drop_pending()
                return False
            return True

        def failed(message: str) -> None:
            self.hold.drop_pending()
            dialogs.error(self._window, "Open project", f"The project could not be opened: {message}")

        if background:
            run_task(self._window, "Opening the project", job, done, failed)
            return True
        from core.errors import SheerError

        try:
            result = job()
        except (SheerError, OSError, ValueError) as exc:
            failed(str(exc))
            return False
        return done(result)

    def _offer_relink(self, path: Path, exc: Exception) -> Path | str | None:
        """Ask what to do about a missing or changed head.

        Returns:
            The head file located (retry with ``head_path=``), ``"accept"`` (retry with
            ``accept_head_change=True``) or None (Cancel).
        """
        from project.errors import HeadChecksumError

        choices = {"locate": "Locate head…"}
        if isinstance(exc, HeadChecksumError):
            what = f"The head of {path.name} changed since the project was saved ({exc.file} differs)."
            choices["accept"] = "Use it anyway"
        else:
            what = f"The head of {path.name} was not found."
        choices["cancel"] = "Cancel"
        answer = dialogs.ask(self._window, "Relink head", f"{what}\n\n{exc}", choices, "cancel")
        if answer == "accept":
            return "accept"
        if answer != "locate":
            return None
        name, _ = QFileDialog.getOpenFileName(self._window, "Locate head", str(getattr(exc, "head_path", "") or ""),
                                              "Meshes (*.glb *.gltf *.obj *.ply);;All files (*)")
        return Path(name) if name else None

    def _opened(self, path: Path, project: Project, opened: Document,
                maps: list[np.ndarray] | None = None) -> bool:
        """Install an opened project (``opened``: its document).

        Maps at another resolution than the studio's are resampled if the user agrees (in a worker;
        returns True once started), else the project is not opened.
        """
        from core.errors import SheerError

        other = project_io.other_resolution(opened, self.doc) if maps is None else None
        if other is not None:
            want = int(self.doc.resolution)
            answer = dialogs.ask(
                self._window, "Open project",
                f"The project '{project.name}' was painted at {other}×{other} texels and this studio paints at "
                f"{want}×{want}. Resample its maps to {want}×{want}? (The file is unchanged until you save; "
                f"to keep its maps as they are, start Sheer with --resolution {other}.)",
                {"resample": "Resample", "cancel": "Cancel"}, "cancel")
            if answer != "resample":
                return False
            try:
                project_io.check_compatible(project, opened, self.doc, resample=True)
            except (SheerError, OSError, ValueError) as exc:
                dialogs.error(self._window, "Open project", f"The project could not be opened: {exc}")
                return False
            run_task(self._window, "Resampling the project's maps",
                     lambda p, c: project_io.resample_layers(self.doc, opened, p),
                     lambda result: self._opened(path, project, opened, result),
                     lambda m: self._open_failed(f"The maps could not be resampled: {m}"))
            return True
        try:
            project_io.check_compatible(project, opened, self.doc, resample=maps is not None)
            project_io.install_layers(self.doc, self.session.library, project, opened, maps)
        except (SheerError, OSError, ValueError) as exc:
            dialogs.error(self._window, "Open project", f"The project could not be opened: {exc}")
            return False
        self.project, self.name, self.path = project, str(project.name), path
        self.look_record = project.look
        self._restore_view(project)
        self.autosaver.dirty = False
        if self._copy:  # another Sheer has the file: this one is an untitled copy until saved elsewhere
            self.path, self.name = None, f"{project.name} (copy)"
            self.hold.release()
        else:
            self.hold.keep()
            project_io.sweep_temporaries(path)
            self.settings.add_recent(str(path))
        self.autosaver.project_path = None if self.path is None else self.path.absolute()
        held = not self._copy
        self._copy = False
        self.replaced.emit()
        self.set_modified(False)
        if held:
            self._offer_recovery_of(path)
        return True

    def _open_failed(self, message: str) -> None:
        self.hold.drop_pending()
        dialogs.error(self._window, "Open project", message)

    def _taken_over(self, asker: object) -> None:
        """Another Sheer (``asker``) took the project over: keep the work here as an untitled copy."""
        from project.recovery_files import discard_recovery

        old = self.path
        if old is None:
            return
        discard_recovery(old)
        self.path, self.name = None, f"{self.name} (copy)"
        self.autosaver.project_path = None
        self.autosaver.mark_dirty()
        self.set_modified(True)
        self._window.statusBar().showMessage(
            f"{old.name} was taken over by another Sheer ({asker}); this window's work is an untitled copy", 15000)

    def _restore_view(self, project: Project) -> None:
        """Key light, environment and camera of a project into the settings and the viewport's camera."""
        if project.lights:
            changes: dict[str, object] = {"environment": project_io.environment_name(project.lights)}
            preset = project_io.closest_preset(project.lights, LIGHT_PRESETS)
            if preset is not None:
                changes["light_preset"] = preset
            angles = project_io.key_light_angles(project.lights)
            if angles is not None:
                changes["light_azimuth"], changes["light_elevation"] = angles
            if changes["environment"] not in ENVIRONMENTS:
                changes["environment"] = "none"
            for key, value in changes.items():
                setattr(self.settings, key, value)
        project_io.restore_camera(self.viewport.camera, project.camera)

    # ------------------------------------------------------------------ save
    def view_state(self) -> project_io.ViewState:
        """The lights, camera and look to save with the project."""
        return project_io.view_state(self.viewport.camera, self.viewport.lighting, self.settings.environment,
                                     self.look_record)

    def snapshot(self) -> Project:
        """The project as it is now (maps copied), on the project last opened or saved."""
        return project_io.snapshot(self.doc, self.name, self.project, self.view_state())

    def save_project(self, ask: bool = False, path: Path | None = None, self_contained: bool | None = None) -> bool:
        """File → Save (``ask``: Save As).

        Args:
            ask: ask for the file even when the project has one.
            path: save there without asking.
            self_contained: True embeds the head in the file; None keeps it as the project had it.

        Returns:
            Whether the project was saved (False: cancelled, or an error was shown).
        """
        from core.errors import SheerError

        target = path or (None if ask else self.path)
        if target is None:
            name, _ = QFileDialog.getSaveFileName(self._window, "Save project", f"{self.name}.sheer",
                                                  "Sheer projects (*.sheer)")
            if not name:
                return False
            target = Path(name) if name.endswith(".sheer") else Path(name + ".sheer")
        target = Path(target)
        try:
            project = project_io.snapshot(self.doc, target.stem, self.project, self.view_state())
            saved = project_io.save_project_file(project, target, self_contained)
        except (SheerError, OSError, ValueError) as exc:
            dialogs.error(self._window, "Save project", f"The project could not be saved: {exc}")
            return False
        self.project, self.path, self.name = project, saved, saved.stem
        self.hold.hold(saved)
        self.autosaver.saved(saved)
        self.settings.add_recent(str(saved))
        self.set_modified(False)
        return True

    def save_self_contained(self, path: Path | None = None) -> bool:
        """Save the project with the head embedded (asks where when ``path`` is None)."""
        return self.save_project(ask=path is None, path=path, self_contained=True)

    # ------------------------------------------------------------------ autosave and recovery
    def _autosave_tick(self) -> None:
        """Every few seconds: when unsaved changes are due, snapshot here and write in a worker."""
        a = self.autosaver
        if not a.due() or self._autosaving:
            return
        try:
            project = self.snapshot()
        except Exception as exc:  # never interrupt the user for an autosave
            log.warning("autosave snapshot failed: %s", exc)
            return
        self._autosaving = True

        def done(path: object) -> None:
            self._autosaving = False
            self._window.statusBar().showMessage(f"Autosaved to {path}", 3000)

        def failed(msg: str) -> None:
            self._autosaving = False
            log.warning("autosave failed: %s", msg)
            self._window.statusBar().showMessage(autosave_failure(msg), AUTOSAVE_FAILED_MS)

        run_task(self._window, "Autosave", lambda p, c: a.autosave_now(project), done, failed, show_progress=False)

    def offer_recovery(self) -> None:
        """After a crash: offer the newest recovery file left by a session that did not end normally.

        Recover installs it (the window shows it modified, under the original file's name), Discard
        deletes the recovery file, Later keeps it for the next start.
        """
        pending = project_io.pending_recoveries()
        if pending:
            self._offer(pending[0])

    def _offer_recovery_of(self, path: Path) -> None:
        """``path`` was just opened (File → Open, a recent file, ``sheer studio --project``): offer its autosave.

        The same question as at start-up (:meth:`offer_recovery`), for a recovery file of ``path`` (beside
        it, or in the recovery folder) left by a Sheer that did not close normally and written after the
        project was last saved; another running Sheer's live autosave, a damaged file or one older than
        the project is not offered.
        """
        from project.recovery import find_recovery

        info = find_recovery(path)
        if info is not None and not info.owner_alive and info.error is None and info.newer_than_original:
            self._offer(info)

    def _offer(self, info: RecoveryInfo) -> None:
        """Ask Recover / Discard / Later about the recovery file ``info`` and do what the user chose."""
        from core.errors import SheerError
        from project.recovery import recover

        what = info.original.name if info.original else "untitled work"
        answer = dialogs.ask(self._window, "Recover unsaved work",
                             f"Sheer did not close normally. Recover {what} autosaved at {info.saved_at}?",
                             {"recover": "Recover", "discard": "Discard", "later": "Later"}, "later")
        if answer == "discard":
            info.path.unlink(missing_ok=True)
            return
        if answer != "recover":
            return
        try:
            project = recover(info)
            self.name = project_io.load_project_into(self.doc, self.session.library, project)
        except (SheerError, OSError, ValueError) as exc:
            dialogs.error(self._window, "Recover unsaved work", f"The recovery file could not be opened: {exc}")
            return
        self.path = info.original if info.original and self.hold.hold(info.original) else None
        self.autosaver.project_path = None if self.path is None else self.path.absolute()
        self.project, self.look_record = project, project.look
        self._restore_view(project)
        self.replaced.emit()
        self.set_modified(True)
        info.path.unlink(missing_ok=True)

    # ------------------------------------------------------------------ close
    def offer_to_save(self) -> bool:
        """Offer to save unsaved changes before the document is closed or replaced.

        Asked when the window closes and before File → New, File → Open and a recent file, so no painted
        work is dropped without asking.

        Returns:
            False when the user cancelled (or chose Save and the save did not happen): leave things as
            they are.
        """
        if self._window.isWindowModified() and self.doc.layers:
            answer = dialogs.ask(self._window, "Unsaved changes", f"Save the changes to {self.name}?",
                                 {"save": "Save", "discard": "Discard", "cancel": "Cancel"}, "save")
            if answer == "cancel" or (answer == "save" and not self.save_project()):
                return False
        return True

    def close(self) -> None:
        """The window closes normally: stop autosaving, remove this session's recovery file, let go of the lock."""
        self.timer.stop()
        self.autosaver.close()
        self.hold.timer.stop()
        self.hold.release()
