"""The studio's toolbars on a real window (xcb under Xvfb): at the screenshots' 1600×1000 every control of
every toolbar is shown — none behind QToolBar's » extension button (the Before|After slider was, once the
brush bar's Regions menu made one row 1720 px wide) —, and so they are down to the window's minimum width,
with the docks or without, every region's outline ticked or none (below 967 px the brush bar's region
picker was behind »); and a layout saved by an older version, with the View toolbar beside the brush bar,
is not restored over the two rows (app.studio.toolbars)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pytest
from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QApplication, QDockWidget, QSlider, QToolBar, QToolButton

from app.qt_compat import pin_singletons
from tests.app.studio_support import open_studio_window

if TYPE_CHECKING:
    from collections.abc import Iterator

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]


@pytest.fixture(scope="module")
def window(qapp: object, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    with open_studio_window(qapp, tmp_path_factory, wait_full_quality=False) as (win, _driver):
        yield win


def settle(win: Any, width: int, height: int) -> None:
    """Resize the window and let Qt lay its toolbars out."""
    win.resize(width, height)
    for _ in range(20):
        QApplication.processEvents()
    assert (win.width(), win.height()) == (width, height), "the window did not take the size"


def overflow(tb: QToolBar) -> list[str]:
    """What ``tb`` does not show in full: its » button if shown, and each control hidden or outside it."""
    out = []
    ext = tb.findChild(QToolButton, "qt_toolbar_ext_button")
    if ext is not None and ext.isVisible():
        out.append("the » extension button")
    for act in tb.actions():
        w = tb.widgetForAction(act)
        if w is None:
            continue
        name = act.text() or getattr(w, "text", lambda: "")() or type(w).__name__
        if not w.isVisible():
            out.append(f"{name} (hidden)")
        elif not tb.rect().contains(w.geometry()):
            out.append(f"{name} (outside {tb.rect().getRect()}: {w.geometry().getRect()})")
    return out


def bars(win: Any) -> dict[str, QToolBar]:
    return {tb.objectName(): tb for tb in win.findChildren(QToolBar)}


def test_every_toolbar_control_shows_at_1600_by_1000(window: Any) -> None:
    settle(window, 1600, 1000)
    tbs = bars(window)
    assert {"brush_toolbar", "view_toolbar"} <= set(tbs)
    for name, tb in tbs.items():
        assert tb.isVisible(), name
        assert overflow(tb) == [], f"{name} overflows at 1600 px: {overflow(tb)}"
    slider = window.split_slider
    assert isinstance(slider, QSlider) and slider.isVisible() and slider.width() >= 80, \
        "the Before|After slider must be shown and usable"
    assert window.region_picker.overlay_button.isVisible(), "the Regions menu must be shown"


def shrink(win: Any, height: int = 1000) -> int:
    """Ask for a 1 px wide window (Qt holds it at its minimum width) and return the width it took."""
    win.resize(1, height)
    for _ in range(20):
        QApplication.processEvents()
    return int(win.width())


def test_every_control_shows_down_to_the_minimum_width(window: Any) -> None:
    picker = window.region_picker
    docks = [d for d in window.findChildren(QDockWidget) if d.isVisible()]
    tbs = bars(window)
    assert docks
    widths = {}
    try:
        for case in ("the docks", "every region outlined", "no docks"):
            if case == "every region outlined":  # the Regions button's longest text, "Regions (N)"
                picker.show_regions(list(picker.overlay_actions))
            elif case == "no docks":
                for d in docks:
                    d.hide()
            widths[case] = width = shrink(window)
            for name, tb in tbs.items():
                assert overflow(tb) == [], f"{name} overflows at {width} px ({case}): {overflow(tb)}"
            for w in (picker.region_combo, picker.mode_combo, picker.fill_button, picker.overlay_button,
                      window.split_slider):
                assert w.isVisible() and w.width() > 0, f"{w} not shown at {width} px ({case})"
    finally:
        picker.hide_overlay()
        for d in docks:
            d.show()
        settle(window, 1600, 1000)
    assert widths["the docks"] < 967, widths  # the width where the region picker used to go behind »
    assert widths["no docks"] <= widths["every region outlined"], widths


def test_an_older_saved_layout_is_not_restored_over_the_two_rows(window: Any, tmp_path: Any) -> None:
    from app.studio.toolbars import WINDOW_STATE_VERSION

    settle(window, 1600, 1000)
    tbs = bars(window)
    brush, view = tbs["brush_toolbar"], tbs["view_toolbar"]
    assert view.y() > brush.y(), "the View toolbar is on its own row"
    two_rows = window.saveState(WINDOW_STATE_VERSION)
    window.removeToolBarBreak(view)  # the old one-row layout, as an older version saved it
    QApplication.processEvents()
    assert view.y() == brush.y()
    old = window.saveState(WINDOW_STATE_VERSION - 1)
    saved = window.qsettings
    try:
        window.qsettings = QSettings(str(tmp_path / "old.ini"), QSettings.Format.IniFormat)
        window.qsettings.setValue("window/state", old)
        window.restoreState(two_rows, WINDOW_STATE_VERSION)
        QApplication.processEvents()
        assert window.restore_layout() is False
        settle(window, 1600, 1000)
        assert view.y() > brush.y() and overflow(view) == [], "an old one-row layout came back"
        window.qsettings.setValue("window/state", two_rows)  # this version's own layout is restored
        assert window.restore_layout() is True
    finally:
        window.qsettings = saved
