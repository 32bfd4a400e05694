"""What a kiosk window shows, for the kiosk's screen tests: its controls' rectangles and its widgets' state.

- :func:`fit_problems`: every visible control inside the screen, unclipped, touch-sized; no scroll bar.
- :func:`screen_state`: every widget's text, checked state, visibility and value, and the face's view,
  light, turn and split: what a shopper sees (one window's states compare equal when it shows the same;
  widgets are named by their identity, so the states of one window only).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from app.kiosk.window import KioskWindow


def controls(win: KioskWindow) -> list[Any]:
    """The visible buttons and sliders of the window's current screen."""
    from PySide6.QtWidgets import QAbstractButton, QSlider

    return [w for w in win.findChildren(QAbstractButton) + win.findChildren(QSlider) if w.isVisible()]


def fit_problems(win: KioskWindow, width: int, height: int, min_px: int) -> list[str]:
    """What breaks "every control on a ``width``×``height`` screen, ≥ ``min_px`` pixels, no scroll bar"."""
    from PySide6.QtCore import QPoint, QRect

    screen = QRect(0, 0, width, height)
    problems = []
    if win.geometry() != screen:
        problems.append(f"window {win.geometry()} is not the screen {screen}")
    for bar in (win.side_panel.verticalScrollBar(), win.side_panel.horizontalScrollBar()):
        if bar.isVisible():
            problems.append("a scroll bar is shown")
    for w in controls(win):
        name = getattr(w, "text", lambda: "")() or type(w).__name__
        rect = QRect(w.mapTo(win, QPoint(0, 0)), w.size())
        if not screen.contains(rect):
            problems.append(f"{name!r} at {rect} leaves the screen")
        if w.visibleRegion().boundingRect() != w.rect():
            problems.append(f"{name!r} is cut: only {w.visibleRegion().boundingRect()} of {w.rect()} shows")
        if min(rect.width(), rect.height()) < min_px:
            problems.append(f"{name!r} is {rect.width()}×{rect.height()} px, under {min_px}")
    return problems


def screen_state(win: KioskWindow) -> dict[str, Any]:
    """Everything a shopper can see of the window's widgets and of the face shown (see the module docstring)."""
    from PySide6.QtWidgets import QAbstractButton, QLabel, QSlider, QStackedWidget

    state: dict[str, Any] = {}
    for w in win.findChildren(QAbstractButton):
        state[f"button {id(w):x}"] = (w.text(), w.isChecked(), w.isVisibleTo(win), w.isEnabled(), w.icon().isNull())
    for w in win.findChildren(QLabel):
        state[f"label {id(w):x}"] = (w.text(), w.isVisibleTo(win))
    for w in win.findChildren(QSlider):
        state[f"slider {id(w):x}"] = w.value()
    for w in win.findChildren(QStackedWidget):
        state[f"stack {id(w):x}"] = w.currentIndex()
    lt, cam = win.viewport.lighting, win.viewport.camera
    state["light"] = (lt.azimuth, lt.elevation, tuple(lt.colour), lt.intensity, tuple(lt.ambient), lt.exposure)
    state["camera"] = (round(float(cam.yaw), 6), round(float(cam.pitch), 6), round(float(cam.distance), 6))
    state["split"] = win.viewport.split
    state["look"] = (win.look, [(lay.material, lay.name) for lay in win.doc.layers])
    state["her view"] = (win.tryon.view, win.tryon.light, win.tryon.shopper_view.yaw, win.tryon.shopper_view.pitch)
    state["shades"] = [s.name for s in win.foundation_finder.shades]
    state["toast"] = win.toast.text()
    return state


def differences(a: dict[str, Any], b: dict[str, Any]) -> dict[str, tuple[Any, Any]]:
    """The entries of two :func:`screen_state` that differ: name → (a's, b's)."""
    return {k: (a.get(k), b.get(k)) for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)}
