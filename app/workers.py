"""Long work off the GUI thread, with a progress dialog and Cancel.

A job runs as a QRunnable on the global QThreadPool; its progress goes to a QProgressDialog whose Cancel
asks it to stop; its result or error comes back on the GUI thread through signals.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

from PySide6.QtCore import QObject, QRunnable, Qt, QThreadPool, Signal
from PySide6.QtWidgets import QProgressDialog, QWidget

log = logging.getLogger("sheer.app")

#: fn(progress(fraction 0..1, message), cancelled() -> bool) -> result
Job = Callable[[Callable[[float, str], None], Callable[[], bool]], Any]


class Cancelled(Exception):
    """Raised by a job that saw ``cancelled()`` become true."""


class _Signals(QObject):
    progress = Signal(float, str)
    done = Signal(object)
    failed = Signal(str)
    cancelled = Signal()


class Task(QRunnable):
    """A job in the thread pool; ``signals`` carries its progress, result, error or cancellation."""

    def __init__(self, job: Job) -> None:
        super().__init__()
        self.job: Job | None = job
        self.signals = _Signals()
        self._cancel = threading.Event()
        self.setAutoDelete(False)

    def cancel(self) -> None:
        """Ask the job to stop (it sees ``cancelled()`` become true and raises :class:`Cancelled`)."""
        self._cancel.set()

    def run(self) -> None:
        """Run the job (in a pool thread) and emit its outcome; an internal error is logged, then reported."""
        from core.errors import SheerError

        # the task lets go of its job as it starts: what the job holds (a shopper's photograph, a window) is
        # freed when the job ends, whoever still holds the task
        job, self.job = self.job, None
        if job is None:
            return
        try:
            result = job(lambda f, m="": self.signals.progress.emit(float(f), str(m)), self._cancel.is_set)
        except Cancelled:
            self.signals.cancelled.emit()
        except (SheerError, OSError, ValueError) as exc:
            self.signals.failed.emit(str(exc))
        except Exception as exc:  # an internal error: logged with its traceback, shown as one line
            log.exception("background task failed")
            self.signals.failed.emit(f"internal error: {type(exc).__name__}: {exc}")
        else:
            self.signals.done.emit(result)


_RUNNING: set[Task] = set()


def run_task(parent: QWidget | None, title: str, job: Job, on_done: Callable[[Any], None],
             on_error: Callable[[str], None], show_progress: bool = True) -> Task:
    """Start ``job`` in the thread pool with a progress dialog (Cancel asks the job to stop)."""
    task = Task(job)
    dialog: QProgressDialog | None = None
    if show_progress:
        dialog = QProgressDialog(title, "Cancel", 0, 1000, parent)
        dialog.setWindowTitle(title)
        dialog.setWindowModality(Qt.WindowModality.WindowModal)
        dialog.setMinimumDuration(300)
        dialog.setAutoClose(False)
        dialog.setAutoReset(False)
        dialog.canceled.connect(task.cancel)

        def progress(f: float, msg: str) -> None:
            dialog.setValue(int(f * 1000))
            if msg:
                dialog.setLabelText(f"{title}\n{msg}")

        task.signals.progress.connect(progress)

    def finish() -> None:
        _RUNNING.discard(task)
        # the connections are held by Qt, out of Python's garbage collector's sight; they hold these
        # closures, which hold the task: the signals' object goes (after this emission), and its connections
        # with it; without this, every finished task (and its result) stayed alive
        task.signals.deleteLater()
        if dialog is not None:
            dialog.canceled.disconnect(task.cancel)  # closing the dialog emits canceled
            dialog.close()
            dialog.deleteLater()

    task.signals.done.connect(lambda r: (finish(), on_done(r)))
    task.signals.failed.connect(lambda m: (finish(), on_error(m)))
    task.signals.cancelled.connect(lambda: (finish(), on_error("cancelled")))
    _RUNNING.add(task)
    QThreadPool.globalInstance().start(task)
    return task


def wait_all(timeout_ms: int = 30000) -> bool:
    """Wait up to ``timeout_ms`` ms for every job in the pool; returns whether they all finished."""
    return QThreadPool.globalInstance().waitForDone(timeout_ms)
