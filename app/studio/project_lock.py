"""The lock a studio window holds on the project it has open, so that one Sheer at a time writes it.

:class:`ProjectHold` takes the project's advisory lock (:class:`core.locks.FileLock`, purpose "open") when a
project is opened or saved under a new name, and lets go of it when the window closes, starts a new
project or opens another one. Opening a project another Sheer holds asks (a real message box)::

    <name> is open in another Sheer (<host>, pid <pid>).   [Open a copy] [Take over] [Cancel]

- Open a copy: the project opens untitled ("<name> (copy)"); saving it asks for a new file.
- Take over: the other studio is asked to let go (:func:`core.locks.take_over`); it keeps its work as an
  untitled copy and says so in its status bar, and this window holds the project.

Every second the window checks whether another Sheer asks to take its project over (:attr:`ProjectHold.lost`).
"""

from __future__ import annotations

import logging
import time
from typing import TYPE_CHECKING

from PySide6.QtCore import QCoreApplication, QObject, QTimer, Signal

from app.studio import dialogs
from core.locks import FileLock, Holder, LockedError, process_alive, take_over, takeover_request

if TYPE_CHECKING:
    from pathlib import Path

    from PySide6.QtWidgets import QWidget

log = logging.getLogger("sheer.app")

#: Milliseconds between two checks whether another Sheer asks to take the project over.
TAKEOVER_CHECK_MS = 1000


class ProjectHold(QObject):
    """The lock of the project one studio window has open (see the module docstring).

    Args:
        window: the window the questions are modal to.
    """

    #: Another Sheer took the project over (its :class:`core.locks.Holder`); the lock is let go of.
    lost = Signal(object)

    def __init__(self, window: QWidget) -> None:
        super().__init__(window)
        self._window = window
        self.lock: FileLock | None = None
        self._pending: FileLock | None = None
        self.timer = QTimer(self)
        self.timer.setInterval(TAKEOVER_CHECK_MS)
        self.timer.timeout.connect(self._check)
        self.timer.start()

    @property
    def path(self) -> Path | None:
        """The project this window holds, or None."""
        return self.lock.path if self.lock is not None else None

    def claim(self, path: Path) -> str | None:
        """Before opening ``path``: take its lock, or ask what to do when another Sheer holds it.

        Returns:
            ``"held"`` (the lock is taken: :meth:`keep` it once the project opened, or
            :meth:`drop_pending`), ``"copy"`` (open an untitled copy) or None (cancelled).
        """
        p = path.absolute()
        if self.lock is not None and self.lock.path == p:
            return "held"
        lock = FileLock(p, "open")
        holder = lock.try_acquire()
        if holder is None:
            self._pending = lock
            return "held"
        answer = dialogs.ask(self._window, "Project in use",
                             f"{path.name} is open in another Sheer ({holder.host}, pid {holder.pid}).",
                             {"copy": "Open a copy", "takeover": "Take over", "cancel": "Cancel"}, "cancel")
        if answer == "copy":
            return "copy"
        if answer != "takeover":
            return None
        try:
            self._pending = take_over(p, wait=_run_events)
        except LockedError as exc:
            dialogs.error(self._window, "Take over", f"{exc}: it did not let go of the project.")
            return None
        return "held"

    def keep(self) -> None:
        """The project claimed opened: hold its lock (letting go of the one held before)."""
        if self._pending is None:
            return
        if self.lock is not None and self.lock is not self._pending:
            self.lock.release()
        self.lock, self._pending = self._pending, None

    def drop_pending(self) -> None:
        """The project claimed did not open: let go of its lock."""
        if self._pending is not None and self._pending is not self.lock:
            self._pending.release()
        self._pending = None

    def hold(self, path: Path) -> bool:
        """Hold ``path`` (saved under a new name, or recovered) instead of the project held before.

        Returns False, holding nothing, when another Sheer holds it.
        """
        if self.claim_quietly(path):
            self.keep()
            return True
        self.release()
        return False

    def claim_quietly(self, path: Path) -> bool:
        """Take the lock of ``path`` without asking (:meth:`keep` it); False when another Sheer holds it."""
        p = path.absolute()
        if self.lock is not None and self.lock.path == p:
            return True
        lock = FileLock(p, "open")
        if lock.try_acquire() is not None:
            return False
        self._pending = lock
        return True

    def release(self) -> None:
        """Let go of the project's lock (the window closes, or shows a new project)."""
        self.drop_pending()
        if self.lock is not None:
            self.lock.release()
            self.lock = None

    def _check(self) -> None:
        """Let go of the project when another Sheer that still runs asks to take it over."""
        if self.lock is None:
            return
        asker = takeover_request(self.lock.path)
        if asker is None or not _alive(asker):
            return
        log.info("project %s: taken over by another Sheer (%s)", self.lock.path, asker)
        self.release()
        self.lost.emit(asker)


def _alive(holder: Holder) -> bool:
    """Whether the Sheer ``holder`` still runs (one on another machine is taken at its word)."""
    import socket

    return holder.host != socket.gethostname() or process_alive(holder.pid)


def _run_events() -> None:
    """Between two tries of a lock: let the window repaint (and another window of this process let go)."""
    QCoreApplication.processEvents()
    time.sleep(0.02)
