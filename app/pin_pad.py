"""The kiosk's touch widgets: large buttons and the administrator's PIN pad (shown inside the window)."""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QGridLayout, QLabel, QPushButton, QVBoxLayout, QWidget


def big_button(text: str, height: int = 72) -> QPushButton:
    """A touch-sized push button: at least ``height`` × 120 pixels, never taking the keyboard focus."""
    b = QPushButton(text)
    b.setMinimumHeight(height)
    b.setMinimumWidth(120)
    b.setFocusPolicy(Qt.FocusPolicy.NoFocus)
    return b


class PinPad(QWidget):
    """An in-window PIN pad (no dialog): emits ``entered(pin)`` or ``cancelled``.

    Attributes:
        buttons: the keys by label ("0"–"9", "Clear", "OK").
        cancel_button: the Cancel button.
        message: the line under the prompt ("Wrong PIN" after a wrong one).
    """

    entered = Signal(str)
    cancelled = Signal()

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("pinpad")
        self.pin = ""
        self.display = QLabel("Administrator PIN")
        self.display.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.message = QLabel("")
        self.message.setAlignment(Qt.AlignmentFlag.AlignCenter)
        grid = QGridLayout()
        keys = ["1", "2", "3", "4", "5", "6", "7", "8", "9", "Clear", "0", "OK"]
        self.buttons: dict[str, QPushButton] = {}
        for i, k in enumerate(keys):
            b = big_button(k, 80)
            b.clicked.connect(lambda _c=False, key=k: self.press(key))
            grid.addWidget(b, i // 3, i % 3)
            self.buttons[k] = b
        self.cancel_button = big_button("Cancel", 64)
        self.cancel_button.clicked.connect(self._cancel)
        lay = QVBoxLayout(self)
        lay.addStretch(1)
        lay.addWidget(self.display)
        lay.addWidget(self.message)
        lay.addLayout(grid)
        lay.addWidget(self.cancel_button)
        lay.addStretch(1)

    def reset(self, message: str = "") -> None:
        """Clear the digits typed and show ``message`` under the prompt ("" for none)."""
        self.pin = ""
        self.display.setText("Administrator PIN")
        self.message.setText(message)

    def press(self, key: str) -> None:
        """A key of the pad: a digit (up to 12), "Clear", or "OK" (emits ``entered`` with the PIN typed)."""
        if key == "Clear":
            self.reset()
        elif key == "OK":
            pin, self.pin = self.pin, ""
            self.display.setText("Administrator PIN")
            self.entered.emit(pin)
        elif len(self.pin) < 12:
            self.pin += key
            self.display.setText("•" * len(self.pin))

    def _cancel(self) -> None:
        self.reset()
        self.cancelled.emit()
