"""Driving the studio's widgets as a designer does, for the Qt tests: typing into a field, clicking a list
row, picking a material in the library dock."""

from __future__ import annotations

from typing import Any

from PySide6.QtCore import Qt

#: The red-lip look's lipstick.
RED = "Lipstick Classic Red"


def type_into(qtbot: Any, spin: Any, value: str) -> None:
    """Select a spin box's text, type ``value`` (``.`` as the locale's decimal point) and press Enter."""
    spin.lineEdit().selectAll()
    qtbot.keyClicks(spin.lineEdit(), value.replace(".", spin.locale().decimalPoint()))
    qtbot.keyClick(spin, Qt.Key.Key_Return)


def click_row(qtbot: Any, widget: Any, row: int) -> None:
    """Click list row ``row`` of a ``QListWidget`` with the mouse."""
    item = widget.item(row)
    widget.scrollToItem(item)
    qtbot.mouseClick(widget.viewport(), Qt.MouseButton.LeftButton, pos=widget.visualItemRect(item).center())


def pick_material(qtbot: Any, dock: Any, name: str) -> None:
    """Click material ``name`` in the library dock's list."""
    rows = [dock.list.item(i).text() for i in range(dock.list.count())]
    click_row(qtbot, dock.list, rows.index(name))
    assert dock.current == name
