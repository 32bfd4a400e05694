"""The kiosk's "Find my foundation" on a real kiosk window: three shades on her skin, the metamerism
warning in plain words, a tap swaps the look's foundation."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pytest

from app.kiosk.shades import SHOWN, plain_warning
from app.qt_compat import pin_singletons
from capture.face import Face
from capture.phong import PhongParams
from km.skin import fit_skin
from shade.match import ShadeBank, ShadeMatch, foundations, match_shades
from tests.app.kiosk.test_kiosk_pin import open_kiosk

if TYPE_CHECKING:
    from collections.abc import Iterator

    from app.kiosk.window import KioskWindow

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]


@pytest.fixture(scope="module")
def kiosk(qapp: object, tmp_path_factory: pytest.TempPathFactory) -> Iterator[KioskWindow]:
    with open_kiosk(qapp, tmp_path_factory.mktemp("kiosk")) as win:
        win.show_main()
        yield win


def test_find_my_foundation_shows_three_and_a_tap_wears_one(kiosk: KioskWindow, qtbot: object) -> None:
    finder = kiosk.foundation_finder
    assert finder.find_button.text() == "Find my foundation" and finder.isVisibleTo(kiosk)
    finder.find_button.click()  # read and matched in the thread pool
    assert finder.message.text() == "Reading your skin…" and not finder.find_button.isEnabled()
    qtbot.waitUntil(lambda: len(finder.shades) == SHOWN, timeout=30000)
    expected = match_shades(*(2 * [fit_skin(linear_rgb=finder.skin_rgb()).reflectance]),
                            ShadeBank.from_materials(foundations(kiosk.library)))[:SHOWN]
    assert [s.name for s in finder.shades] == [s.name for s in expected]
    assert all(b.isVisibleTo(kiosk) and s.name in b.text() for b, s in zip(finder.shade_buttons, finder.shades))
    assert finder.message.text()
    layer = next(i for i, lay in enumerate(kiosk.doc.layers)
                 if kiosk.library.get(lay.material).category == "foundation")
    finder.shade_buttons[2].click()
    assert kiosk.doc.layers[layer].material == finder.shades[2].name
    assert kiosk.product_labels["foundation"].text() == finder.shades[2].name
    assert finder.message.text() == f"You are wearing {finder.shades[2].name}."


def test_a_captured_face_is_her_skin(kiosk: KioskWindow) -> None:
    diffuse = np.array([0.25, 0.14, 0.09])
    kiosk.face = Face(params=PhongParams(diffuse=diffuse, specular=0.1, exponent=20.0, ambient_scale=0.2),
                      detail=np.ones((4, 4, 3), np.float32), data={})
    try:
        np.testing.assert_array_equal(kiosk.foundation_finder.skin_rgb(), diffuse)
    finally:
        kiosk.face = None


def test_the_warning_in_plain_words() -> None:
    def shade(by: dict[str, float], metameric: bool) -> ShadeMatch:
        return ShadeMatch("Foundation X", 20.0, by["D65"], by, metameric, np.zeros(3), "#a08070")

    assert plain_warning(shade({"D65": 1.0, "F11": 1.2, "A": 1.1}, False)) == ""
    assert plain_warning(shade({"D65": 1.0, "F11": 4.0, "A": 1.5}, True)) == (
        "Foundation X looks right here but noticeably different in the shop's light.")
