"""Every message the studio shows goes through here, so it is logged and tests can dismiss it.

Set :data:`AUTO_DISMISS_MS` (tests do) to close each message box automatically after that delay;
:data:`HISTORY` keeps (kind, title, text) of every message shown.
"""

from __future__ import annotations

import logging

from PySide6.QtCore import QTimer
from PySide6.QtWidgets import QMessageBox, QWidget

log = logging.getLogger("sheer.app")
AUTO_DISMISS_MS: int | None = None
#: In auto-dismiss mode, the answer :func:`ask` returns (else its default).
AUTO_ANSWER: str | None = None
HISTORY: list[tuple[str, str, str]] = []


def _show(parent: QWidget | None, kind: str, title: str, text: str, detail: str = "") -> None:
    HISTORY.append((kind, title, text))
    (log.warning if kind == "error" else log.info)("%s: %s", title, text)
    icon = {"error": QMessageBox.Icon.Critical, "warning": QMessageBox.Icon.Warning}.get(
        kind, QMessageBox.Icon.Information)
    box = QMessageBox(icon, title, text, QMessageBox.StandardButton.Ok, parent)
    if detail:
        box.setDetailedText(detail)
    if AUTO_DISMISS_MS is not None:
        QTimer.singleShot(AUTO_DISMISS_MS, box.accept)
    box.exec()
    box.deleteLater()


def error(parent: QWidget | None, title: str, text: str, detail: str = "") -> None:
    _show(parent, "error", title, text, detail)


def info(parent: QWidget | None, title: str, text: str, detail: str = "") -> None:
    _show(parent, "info", title, text, detail)


def ask(parent: QWidget | None, title: str, text: str, choices: dict[str, str], default: str) -> str:
    """A question with buttons ``choices`` (key -> label); returns the key chosen (``default`` on Esc)."""
    HISTORY.append(("question", title, text))
    if AUTO_DISMISS_MS is not None:
        return AUTO_ANSWER if AUTO_ANSWER in choices else default
    box = QMessageBox(QMessageBox.Icon.Question, title, text, QMessageBox.StandardButton.NoButton, parent)
    buttons = {key: box.addButton(label, QMessageBox.ButtonRole.ActionRole) for key, label in choices.items()}
    box.setDefaultButton(buttons[default])
    box.setEscapeButton(buttons[default])
    box.exec()
    clicked = box.clickedButton()
    box.deleteLater()
    return next((k for k, b in buttons.items() if b is clicked), default)
