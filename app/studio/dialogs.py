"""Every message and question the studio shows, and its About and Keyboard Shortcuts dialogs.

Messages and questions are modal message boxes, each one also logged.

Tests answer these boxes as a user would: a timer finds the visible box and clicks a button
(``tests/app/studio_support.py``).
"""

from __future__ import annotations

import html
import logging
from typing import TYPE_CHECKING

from PySide6.QtCore import Qt
from PySide6.QtWidgets import (
    QApplication,
    QDialog,
    QDialogButtonBox,
    QLabel,
    QMessageBox,
    QPushButton,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)

if TYPE_CHECKING:
    from collections.abc import Callable

log = logging.getLogger("sheer.app")


def _show(parent: QWidget | None, kind: str, title: str, text: str, detail: str = "") -> None:
    (log.warning if kind == "error" else log.info)("%s: %s", title, text)
    icon = {"error": QMessageBox.Icon.Critical, "warning": QMessageBox.Icon.Warning}.get(
        kind, QMessageBox.Icon.Information)
    box = QMessageBox(icon, title, text, QMessageBox.StandardButton.Ok, parent)
    if detail:
        box.setDetailedText(detail)
    box.exec()
    box.deleteLater()


def error(parent: QWidget | None, title: str, text: str, detail: str = "") -> None:
    """Show an error (a critical message box with OK) and log it as a warning; returns once dismissed."""
    _show(parent, "error", title, text, detail)


def info(parent: QWidget | None, title: str, text: str, detail: str = "") -> None:
    """Show a piece of information (a message box with OK) and log it; returns once dismissed."""
    _show(parent, "info", title, text, detail)


def ask(parent: QWidget | None, title: str, text: str, choices: dict[str, str], default: str) -> str:
    """Ask a question with one button per choice.

    Args:
        parent: the window the box is modal to.
        title: the box's title.
        text: the question.
        choices: key → button label, in button order.
        default: the key of the default button (Enter), also the answer to Esc.

    Returns:
        The key of the button clicked.
    """
    log.info("%s: %s", title, text)
    box = QMessageBox(QMessageBox.Icon.Question, title, text, QMessageBox.StandardButton.NoButton, parent)
    buttons = {key: box.addButton(label, QMessageBox.ButtonRole.ActionRole) for key, label in choices.items()}
    box.setDefaultButton(buttons[default])
    box.setEscapeButton(buttons[default])
    box.exec()
    clicked = box.clickedButton()
    box.deleteLater()
    return next((k for k, b in buttons.items() if b is clicked), default)


def _run(box: QDialog, content: QWidget, extra: list[QPushButton] | None = None) -> None:
    """Show ``content`` above an OK button (and the ``extra`` buttons) in the modal dialog ``box``.

    Returns once it is closed.
    """
    lay = QVBoxLayout(box)
    lay.addWidget(content)
    buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok)
    for button in extra or []:
        buttons.addButton(button, QDialogButtonBox.ButtonRole.ActionRole)
    buttons.accepted.connect(box.accept)
    lay.addWidget(buttons)
    box.exec()
    box.deleteLater()


def about(parent: QWidget | None, head_credit: str, asset_credits: list[str], components: dict[str, str],
          gl: str = "", diagnostics: Callable[[], str] | None = None) -> None:
    """Help → About: what Sheer is, the head scan's credit, the sample assets' credits, the components, GL.

    Args:
        parent: the window the dialog is modal to.
        head_credit: the credit line of the head shown ("" when it has none).
        asset_credits: one credit line per sample asset.
        components: what implements each part (e.g. ``{"renderer": "render.Renderer"}``).
        gl: the studio's GL context, ``vendor / renderer / version, API`` ("" when unknown).
        diagnostics: makes the ``sheer doctor`` text that the "Copy diagnostics" button puts on the
            clipboard; it runs in a worker thread, so it must not touch Qt (None: no button).
    """
    credits = "".join(f"<li>{c}</li>" for c in asset_credits)
    used = ", ".join(f"{k}: {v}" for k, v in components.items())
    text = (f"<h3>Sheer Studio</h3><p>A physically based makeup design studio: Kubelka–Munk cosmetic "
            f"layers over subsurface-scattering skin (after Huang et al. 2013).</p>"
            f"<p><b>Head scan:</b> {head_credit or 'none'}</p>"
            f"<p><b>Sample assets</b><ul>{credits}</ul></p>"
            f"<p><small>Components in use: {used}</small></p>"
            f"<p><small><b>OpenGL:</b> {html.escape(gl or 'unknown')}</small></p>")
    box = QDialog(parent)
    box.setWindowTitle("About Sheer")
    label = QLabel(text)
    label.setWordWrap(True)
    label.setTextFormat(Qt.TextFormat.RichText)
    label.setObjectName("about_text")
    extra: list[QPushButton] = []
    if diagnostics is not None:
        copy = QPushButton("Copy diagnostics")
        copy.setObjectName("copy_diagnostics")
        copy.setToolTip("Put the `sheer doctor` report (this studio's GL context) on the clipboard")
        copy.clicked.connect(lambda: _copy_diagnostics(diagnostics, copy))
        extra.append(copy)
    _run(box, label, extra)


def _copy_diagnostics(diagnostics: Callable[[], str], button: QPushButton) -> None:
    """Make ``diagnostics()`` in a worker thread, then put it on the clipboard and say so on ``button``.

    The GUI stays responsive meanwhile (the button reads "Collecting…"); closing the dialog first still
    copies the text when it is ready.
    """
    import shiboken6

    from app.workers import run_task

    def show(label: str, tip: str) -> None:
        if shiboken6.isValid(button):
            button.setText(label)
            button.setToolTip(tip)
            button.setEnabled(True)

    def done(text: str) -> None:
        QApplication.clipboard().setText(text)
        lines = len(text.splitlines())
        log.info("About: diagnostics copied to the clipboard (%d lines)", lines)
        show("Copied", f"{lines} lines of diagnostics copied to the clipboard")

    def failed(message: str) -> None:
        log.warning("About: diagnostics failed: %s", message)
        show("Copy diagnostics", f"the diagnostics failed: {message}")

    button.setEnabled(False)
    button.setText("Collecting…")
    run_task(button.window(), "Diagnostics", lambda progress, cancelled: diagnostics(), done, failed,
             show_progress=False)


def shortcuts(parent: QWidget | None, rows: list[tuple[str, str, str]]) -> None:
    """Help → Keyboard Shortcuts: a table of (where, action, shortcut) rows."""
    box = QDialog(parent)
    box.setWindowTitle("Keyboard Shortcuts")
    table = QTableWidget(len(rows), 3)
    table.setHorizontalHeaderLabels(["Where", "Action", "Shortcut"])
    for r, row in enumerate(rows):
        for c, text in enumerate(row):
            table.setItem(r, c, QTableWidgetItem(text))
    table.resizeColumnsToContents()
    box.resize(560, 520)
    _run(box, table)
