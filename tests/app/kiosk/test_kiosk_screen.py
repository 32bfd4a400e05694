"""The kiosk's screens on a touch screen, on the real full-screen window: every control on a 1920×1080 and a
1080×1920 (portrait) screen at a touch size, a new shopper's screen as a fresh kiosk's, shoppers' words on
the foundation finder, and the attract mode's sway about the front in a light that keeps the crown below
white. (Her own face on these screens: tests/app/kiosk/test_kiosk_tryon.py.)"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pytest
from PySide6.QtCore import QRect
from PySide6.QtGui import QImage

from app.kiosk.shades import SHOWN, THUMB_PX, match_words
from app.kiosk.window import ATTRACT_PERIOD_S, ATTRACT_SWAY_DEG, MIN_TARGET_PX
from app.qt_compat import pin_singletons
from tests.app.kiosk.screen_support import differences, fit_problems, screen_state
from tests.app.kiosk.test_kiosk_pin import open_kiosk

if TYPE_CHECKING:
    from collections.abc import Iterator

    from app.kiosk.window import KioskWindow

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]


@pytest.fixture(scope="module")
def kiosk(qapp: object, tmp_path_factory: pytest.TempPathFactory) -> Iterator[KioskWindow]:
    """A kiosk shown full screen on the test display (1920×1080), with its state as it opened."""
    with open_kiosk(qapp, tmp_path_factory.mktemp("kiosk")) as win:
        win.fresh_state = screen_state(win)  # type: ignore[attr-defined]
        win.show_full_screen()
        yield win


def find_shades(win: KioskWindow, qtbot: object) -> None:
    win.foundation_finder.find_button.click()
    qtbot.waitUntil(lambda: len(win.foundation_finder.shades) == SHOWN, timeout=60000)  # type: ignore[attr-defined]


def test_every_control_fits_both_screens_at_a_touch_size(kiosk: KioskWindow, qtbot: object) -> None:
    """Landscape 1920×1080 (the display) and portrait 1080×1920 (the window given the portrait screen's
    geometry, as on an X server without a window manager): before and after Find my foundation."""
    qtbot.waitUntil(lambda: kiosk.geometry() == QRect(0, 0, 1920, 1080), timeout=5000)  # type: ignore[attr-defined]
    kiosk.show_main()
    for width, height in ((1920, 1080), (1080, 1920)):
        kiosk.setGeometry(0, 0, width, height)
        qtbot.waitUntil(lambda w=width, h=height: kiosk.geometry() == QRect(0, 0, w, h), timeout=5000)  # type: ignore[attr-defined]
        kiosk.foundation_finder.reset()
        qtbot.wait(100)  # type: ignore[attr-defined]
        assert kiosk.foundation_finder.find_button.isVisible() and kiosk.done_button.isVisible()
        assert fit_problems(kiosk, width, height, MIN_TARGET_PX) == []
        find_shades(kiosk, qtbot)
        qtbot.wait(100)  # type: ignore[attr-defined]
        assert all(b.isVisible() for b in kiosk.foundation_finder.shade_buttons)
        assert fit_problems(kiosk, width, height, MIN_TARGET_PX) == []
    kiosk.setGeometry(0, 0, 1920, 1080)


def test_no_colour_science_on_the_kiosk_and_her_thumbnails_are_seen(kiosk: KioskWindow, qtbot: object) -> None:
    from PySide6.QtWidgets import QAbstractButton, QLabel

    kiosk.show_main()
    find_shades(kiosk, qtbot)
    texts = [w.text() for w in kiosk.findChildren(QAbstractButton) + kiosk.findChildren(QLabel)]
    assert not [t for t in texts if "Δ" in t or "ΔE" in t]
    finder = kiosk.foundation_finder
    for b, s in zip(finder.shade_buttons, finder.shades):
        name, words = b.text().split("\n")
        assert name == s.name and words in {"great match", "good match", "nearest we have"}
    # her face on a tile (a face crop is taller than wide): THUMB_PX tall, whatever the crop's size
    for i, (w, h) in enumerate(((180, 240), (40, 52), (300, 260))):
        image = QImage(w, h, QImage.Format.Format_RGB888)
        image.fill(0x806050)
        finder.set_preview(i, image)
    qtbot.wait(50)  # type: ignore[attr-defined]
    for b in finder.shade_buttons:
        assert b.icon().actualSize(b.iconSize()).height() == THUMB_PX >= 120
        assert b.height() >= THUMB_PX + 40  # the picture and her two lines of words


def test_match_words_follow_the_match_and_the_reading() -> None:
    from shade.match import ShadeMatch

    def shade(de: float) -> ShadeMatch:
        return ShadeMatch("Foundation X", 20.0, de, {"D65": de}, False, np.zeros(3), "#a08070")

    assert [match_words(shade(d)) for d in (1.0, 3.0, 8.0)] == ["great match", "good match", "nearest we have"]
    assert match_words(shade(1.0), "medium") == "good match"
    assert match_words(shade(1.0), "low") == "nearest we have"


def use_every_control(win: KioskWindow, qtbot: object) -> None:
    """A shopper on the sample face: a look, swaps, a light, before/after, Find my foundation, a shade, a
    turn, Save Photo."""
    win.show_main()
    list(win.look_buttons.values())[-1].click()
    win.swap_product("lipstick", +1)
    win.swap_product("foundation", +1)
    next(iter(win.light_buttons.values())).click()
    win.split.setValue(40)
    find_shades(win, qtbot)
    win.foundation_finder.shade_buttons[1].click()
    win.viewport.camera.orbit(25.0, 10.0)
    win.snapshot()
    assert win.toast.text() == "Photo saved"


@pytest.mark.parametrize("leave", ["done", "idle", "pin"])
def test_the_next_shopper_sees_a_fresh_screen(kiosk: KioskWindow, qtbot: object, leave: str) -> None:
    """Done, the idle timeout, or the PIN pad cancelled from the start screen: the screen is a fresh kiosk's."""
    kiosk.setGeometry(0, 0, 1920, 1080)
    use_every_control(kiosk, qtbot)
    assert differences(screen_state(kiosk), kiosk.fresh_state)  # type: ignore[attr-defined]
    if leave == "done":
        kiosk.done_button.click()
    elif leave == "idle":
        kiosk.start_attract()
    else:
        kiosk.done_button.click()
        use_every_control(kiosk, qtbot)
        kiosk.request_exit()
        kiosk.pin_pad.cancel_button.click()  # back where she was: her session goes on
        assert kiosk.screen_name == "tryon" and kiosk.toast.text() == "Photo saved"
        kiosk.start_attract()
    assert kiosk.screen_name == "start"
    assert differences(screen_state(kiosk), kiosk.fresh_state) == {}  # type: ignore[attr-defined]


def attract_frame(win: KioskWindow) -> np.ndarray:
    img = win.viewport.grabFramebuffer().convertToFormat(QImage.Format.Format_RGB888)
    h, w = img.height(), img.width()
    return np.frombuffer(img.constBits(), np.uint8).reshape(h, img.bytesPerLine())[:, : 3 * w].reshape(h, w, 3)


def test_the_attract_mode_sways_about_the_front_in_full_resolution(kiosk: KioskWindow, qtbot: object) -> None:
    kiosk.setGeometry(0, 0, 1920, 1080)
    kiosk.show_start()
    assert kiosk.attract
    yaws = [kiosk.attract_turn(t) for t in np.linspace(0.0, ATTRACT_PERIOD_S, 321)]
    assert max(abs(y) for y in yaws) <= ATTRACT_SWAY_DEG == 35.0
    assert max(yaws) > 34.9 and min(yaws) < -34.9  # the whole sway, both ways
    # the real timer: a second of the sway, the camera never past the bound, every frame a full one
    before = kiosk.viewport.settled_frames
    seen = []
    for _ in range(10):
        qtbot.wait(100)  # type: ignore[attr-defined]
        seen.append(float(kiosk.viewport.camera.yaw))
    assert all(abs(y) <= ATTRACT_SWAY_DEG for y in seen) and len(set(seen)) > 1
    assert kiosk.viewport.settled_frames > before and not kiosk.viewport.last_frame_interactive
    # the crown stays below white: the attract frames at the front and both ends of the sway
    for t in (0.0, ATTRACT_PERIOD_S / 4, 3 * ATTRACT_PERIOD_S / 4):
        kiosk.attract_turn(t)
        frame = attract_frame(kiosk)
        assert frame.shape[:2] == kiosk.viewport.pixel_size()[::-1]
        head = frame.max(axis=2) > 80
        clipped = float((frame.max(axis=2)[head] >= 255).mean())
        assert clipped < 1e-4, (t, clipped)
        assert np.percentile(frame.max(axis=2)[head], 99.9) < 245
