"""The PIN pad with its lockout: after 5 wrong PINs typed on the keys it locks, shows the time left (counting
down), refuses digits; once the lock ends the right PIN is accepted."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pytest

from app.qt_compat import pin_singletons

if TYPE_CHECKING:
    from pathlib import Path

pin_singletons()

pytestmark = [pytest.mark.qt]


def test_the_pad_locks_shows_the_time_left_and_unlocks(qapp: object, tmp_path: Path) -> None:
    from app.kiosk.config import KioskConfig
    from app.kiosk.pin_lock import PinGuard
    from app.kiosk.pin_pad import PinPad
    from tests.app.kiosk.kiosk_support import pin_hash

    now = [1_700_000_000.0]
    path = tmp_path / "kiosk.json"
    KioskConfig(pin_hash=pin_hash("975318")).save(path)
    pad = PinPad(PinGuard.for_config(KioskConfig.load(path), clock=lambda: now[0]))
    accepted: list[bool] = []
    pad.accepted.connect(lambda: accepted.append(True))

    def type_pin(pin: str) -> None:
        for key in pin:
            pad.buttons[key].click()
        pad.buttons["OK"].click()

    for _ in range(4):
        type_pin("864297")
        assert pad.message.text() == "Wrong PIN" and pad.buttons["5"].isEnabled()
    type_pin("864297")
    assert pad.message.text() == "Locked after 5 wrong PINs — try again in 0:30"
    assert not pad.buttons["5"].isEnabled() and not pad.buttons["OK"].isEnabled() and pad.lock_timer.isActive()
    pad.press("9")  # a key press arriving anyway is ignored
    assert pad.pin == ""
    now[0] += 10.5
    pad.lock_timer.timeout.emit()  # the pad's one-second tick
    assert pad.message.text().endswith("try again in 0:20")
    pad.reset()  # shown again (Cancel, then an exit attempt): still locked
    assert pad.message.text().endswith("0:20")
    now[0] += 19.5
    pad.lock_timer.timeout.emit()
    assert pad.buttons["5"].isEnabled() and pad.message.text() == "" and not pad.lock_timer.isActive()
    type_pin("975318")
    assert accepted == [True] and pad.guard.failures == 0
