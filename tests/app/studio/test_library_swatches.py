"""What you pick is what you see, in the studio (a real window under Xvfb, Mesa GL): the Material Library
shows each material in the pan (R∞), as applied on the reference skin or lip at its default thickness, and on
this head; it states the coverage; the layer list shows each layer's material as applied."""

from __future__ import annotations

import re

import numpy as np
import pytest

from app.qt_compat import pin_singletons
from tests.app.studio_support import studio_fixture, window_fixture

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]

studio = studio_fixture()
window = window_fixture()


def swatch(label: object) -> tuple[int, int, int]:
    """The colour a swatch label is painted with (its style sheet's background)."""
    found = re.search(r"background: rgb\((\d+), (\d+), (\d+)\)", label.styleSheet())  # type: ignore[attr-defined]
    assert found, label.styleSheet()  # type: ignore[attr-defined]
    return tuple(int(x) for x in found.groups())  # type: ignore[return-value]


def test_the_library_shows_the_pan_the_applied_and_this_heads_swatch(window: object) -> None:
    from app.studio.layers_panel import applied_rgb, material_rgb

    dock = window.library_dock
    dock.select("Lipstick Classic Red")
    m = window.library.get("Lipstick Classic Red")
    s = {k: swatch(v) for k, v in dock.swatches.items()}
    assert s["in the pan"] == material_rgb(m)
    assert s["as applied"] == applied_rgb(m)
    # the sample head's own lips are the reference lip: on this head it is as applied, within a code or two
    assert np.abs(np.subtract(s["on this head"], s["as applied"])).max() <= 3
    # a full-coverage lipstick as applied is its bullet (within a few codes), not the orange-red of before
    assert np.abs(np.subtract(s["as applied"], s["in the pan"])).max() <= 8
    assert "full coverage" in dock.coverage_label.text() and "0.95" in dock.coverage_label.text()
    assert "on this head" in dock.swatches["on this head"].toolTip()

    dock.select("Blush Peach")
    blush = window.library.get("Blush Peach")
    s = {k: swatch(v) for k, v in dock.swatches.items()}
    assert s["as applied"] == applied_rgb(blush)
    assert s["on this head"] == applied_rgb(blush, dock.skin)  # the head's skin
    assert s["as applied"] != s["in the pan"] and "sheer coverage" in dock.coverage_label.text()


def test_the_layer_list_shows_each_layer_as_applied(window: object) -> None:
    from app.studio.layers_panel import applied_rgb

    panel = window.layers_panel
    layers = window.doc.layers
    assert len(layers) >= 2
    for row in range(panel.list.count()):
        lay = layers[len(layers) - 1 - row]  # top layer first
        colour = panel.list.item(row).icon().pixmap(8, 8).toImage().pixelColor(4, 4)
        assert (colour.red(), colour.green(), colour.blue()) == applied_rgb(window.library.get(lay.material)), lay.name
