"""File → Render Catalogue…: run a catalogue spec in the background, with progress and Cancel.

The dialog takes a spec (TOML, see ``docs/CATALOGUE.md``), an output folder and a number of local worker
processes, checks the spec (the expansion's count and an estimate, or the spec's one-line error), then
runs :func:`catalogue.run_catalogue` in the thread pool (:func:`app.workers.run_task`: a progress dialog
whose Cancel stops the run after the tasks under way). The outcome stays in the dialog (no modal box).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from PySide6.QtWidgets import (
    QDialog,
    QDialogButtonBox,
    QFileDialog,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
    QSpinBox,
    QVBoxLayout,
    QWidget,
)


class CatalogueDialog(QDialog):
    """Spec, output folder and workers; Check and Render (see the module docstring).

    Attributes:
        spec_edit, out_edit: the spec file and the output folder.
        workers: local worker processes (1 thread each).
        status: the last check's or run's outcome, one line or two.
        result: the last run's :class:`catalogue.driver.RunResult`, or None.
    """

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Render Catalogue")
        self.setObjectName("catalogue_dialog")
        self.result: Any = None
        self.task: Any = None
        self.spec_edit, self.out_edit = QLineEdit(), QLineEdit()
        self.workers = QSpinBox()
        self.workers.setRange(1, max(os.cpu_count() or 1, 1) * 4)
        self.workers.setValue(os.cpu_count() or 1)
        form = QFormLayout()
        form.addRow("Spec (TOML)", self._with_browse(self.spec_edit, self._browse_spec))
        form.addRow("Output folder", self._with_browse(self.out_edit, self._browse_out))
        form.addRow("Worker processes", self.workers)
        self.status = QLabel("Choose a catalogue spec (see docs/CATALOGUE.md).")
        self.status.setWordWrap(True)
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Close)
        self.check_button = buttons.addButton("Check", QDialogButtonBox.ButtonRole.ActionRole)
        self.render_button = buttons.addButton("Render", QDialogButtonBox.ButtonRole.AcceptRole)
        self.check_button.clicked.connect(self.check)
        self.render_button.clicked.connect(self.start)
        buttons.rejected.connect(self.reject)
        layout = QVBoxLayout(self)
        layout.addLayout(form)
        layout.addWidget(self.status)
        layout.addWidget(buttons)
        self.resize(560, 200)

    @classmethod
    def open_for(cls, parent: QWidget) -> CatalogueDialog:
        """Show a (non-modal) dialog over ``parent``; returns it."""
        dialog = cls(parent)
        dialog.show()
        return dialog

    def _with_browse(self, edit: QLineEdit, browse: Any) -> QWidget:
        row = QWidget()
        lay = QHBoxLayout(row)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addWidget(edit)
        button = QPushButton("Browse…")
        button.clicked.connect(browse)
        lay.addWidget(button)
        return row

    def _browse_spec(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Catalogue spec", "", "Catalogue spec (*.toml)")
        if path:
            self.spec_edit.setText(path)
            if not self.out_edit.text():
                self.out_edit.setText(str(Path(path).with_suffix("")) + "-renders")
            self.check()

    def _browse_out(self) -> None:
        path = QFileDialog.getExistingDirectory(self, "Output folder")
        if path:
            self.out_edit.setText(path)

    def _load(self) -> tuple[Any, list[Any]] | None:
        """The checked spec and its jobs, or None (the reason shown in :attr:`status`)."""
        from catalogue import expand, load_spec
        from core.errors import SheerError

        try:
            spec = load_spec(self.spec_edit.text().strip())
            return spec, expand(spec)
        except (SheerError, OSError) as exc:
            self.status.setText(f"Cannot use this spec: {exc}")
            return None

    def check(self) -> bool:
        """Check the spec and show its expansion (count, already rendered, estimate); returns whether it is usable."""
        from catalogue import estimate_seconds

        loaded = self._load()
        if loaded is None:
            return False
        spec, jobs = loaded
        out = Path(self.out_edit.text().strip()) if self.out_edit.text().strip() else None
        todo = [j for j in jobs if out is None or not (out / j.out).exists()]
        self.status.setText(f"{spec.name}: {len(jobs)} outputs ({spec.size[0]}×{spec.size[1]}, {spec.mode}), "
                            f"{len(jobs) - len(todo)} already rendered; estimate ≈ "
                            f"{estimate_seconds(todo, self.workers.value()):.0f} s")
        return True

    def start(self) -> None:
        """Render the catalogue in the background (progress dialog with Cancel); the outcome goes to :attr:`status`."""
        from app.workers import Cancelled, run_task
        from catalogue import run_catalogue

        if not self.out_edit.text().strip():
            self.status.setText("Choose an output folder.")
            return
        loaded = self._load()
        if loaded is None:
            return
        spec, jobs = loaded
        out, workers = self.out_edit.text().strip(), self.workers.value()

        def job(progress: Any, cancelled: Any) -> Any:
            def report(done: int, total: int, rendered: int, failed: int) -> None:
                progress(done / max(total, 1), f"{done} of {total} images ({rendered} rendered, {failed} failed)")

            result = run_catalogue(spec, out, jobs=jobs, workers=workers, on_progress=report, cancelled=cancelled)
            if result.cancelled:
                raise Cancelled()
            return result

        self.render_button.setEnabled(False)
        self.status.setText("Rendering…")
        self.task = run_task(self, "Rendering the catalogue", job, self._done, self._failed)

    def _done(self, result: Any) -> None:
        self.result = result
        self.render_button.setEnabled(True)
        failed = f"; {len(result.failed)} failed (see failed.json)" if result.failed else ""
        self.status.setText(f"{result.rendered} rendered, {result.skipped} already there{failed} in "
                            f"{result.seconds:.1f} s. Manifest: {result.manifest}")

    def _failed(self, message: str) -> None:
        self.render_button.setEnabled(True)
        self.status.setText("Cancelled: what was rendered stays; Render again to finish."
                            if message == "cancelled" else f"Catalogue failed: {message}")
