"""The kiosk's touch widgets: large buttons and the administrator's PIN pad (shown inside the window).

The pad checks PINs through :class:`app.kiosk.pin_lock.PinGuard` (the lockout after wrong PINs) and shows the
time left of a lock.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtWidgets import QGridLayout, QLabel, QPushButton, QVBoxLayout, QWidget

if TYPE_CHECKING:
    from app.kiosk.pin_lock import PinGuard


def big_button(text: str, height: int = 72) -> QPushButton:
    """A touch-sized push button: at least ``height`` × 120 pixels, never taking the keyboard focus."""
    b = QPushButton(text)
    b.setMinimumHeight(height)
    b.setMinimumWidth(120)
    b.setFocusPolicy(Qt.FocusPolicy.NoFocus)
    return b


class PinPad(QWidget):
    """An in-window PIN pad (no dialog) that checks the PIN through a :class:`app.kiosk.pin_lock.PinGuard`.

    Emits ``accepted`` for the right PIN and ``cancelled`` for Cancel. A wrong PIN shows "Wrong PIN";
    once the guard locks, the digits and OK are disabled and the message counts the lock down each
    second ("Locked after N wrong PINs — try again in m:ss").

    Attributes:
        guard: the PIN check with its lockout.
        buttons: the keys by label ("0"–"9", "Clear", "OK").
        cancel_button: the Cancel button.
        message: the line under the prompt.
    """

    accepted = Signal()
    cancelled = Signal()

    def __init__(self, guard: PinGuard, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("pinpad")
        self.guard = guard
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
        self.lock_timer = QTimer(self)
        self.lock_timer.setInterval(1000)
        self.lock_timer.timeout.connect(self.show_lock)
        lay = QVBoxLayout(self)
        lay.addStretch(1)
        lay.addWidget(self.display)
        lay.addWidget(self.message)
        lay.addLayout(grid)
        lay.addWidget(self.cancel_button)
        lay.addStretch(1)

    def reset(self, message: str = "") -> None:
        """Clear the digits typed and show ``message`` under the prompt ("" for none), or the lock."""
        self.pin = ""
        self.display.setText("Administrator PIN")
        self.message.setText(message)
        self.show_lock()

    def show_lock(self) -> float:
        """Show the time left of the guard's lock (keys disabled) or, once over, enable the keys; returns it (s)."""
        left = self.guard.remaining()
        locked = left > 0
        for key, b in self.buttons.items():
            b.setEnabled(not locked or key == "Clear")
        if locked:
            secs = math.ceil(left)
            self.message.setText(f"Locked after {self.guard.failures} wrong PINs — try again in "
                                 f"{secs // 60}:{secs % 60:02d}")
            if not self.lock_timer.isActive():
                self.lock_timer.start()
        elif self.lock_timer.isActive():
            self.lock_timer.stop()
            self.message.setText("")
        return left

    def press(self, key: str) -> None:
        """A key of the pad: a digit (up to 12), "Clear", or "OK" (checks the PIN typed)."""
        if key == "Clear":
            self.reset()
        elif key == "OK":
            pin, self.pin = self.pin, ""
            self.display.setText("Administrator PIN")
            verdict = self.guard.attempt(pin)
            if verdict.accepted:
                self.message.setText("")
                self.accepted.emit()
            elif not verdict.locked_s:
                self.message.setText("Wrong PIN")
            self.show_lock()
        elif len(self.pin) < 12 and self.guard.remaining() <= 0:
            self.pin += key
            self.display.setText("•" * len(self.pin))

    def _cancel(self) -> None:
        self.reset()
        self.cancelled.emit()
