"""Turn and relight on the kiosk, without a capture: the drag stays within what her photograph supports
(render.mirror.TurnLimits), and the relit face is shown as the mirror view is (flipped left–right, a drag
to the right turning her as her reflection would turn). Save Photo stays as a camera sees her (not
flipped) for both views: tests/app/kiosk/test_kiosk_her_photo.py."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from app.qt_compat import pin_singletons

pin_singletons()

pytestmark = [pytest.mark.qt]


def _drag(view: Any, dx: float, dy: float = 0.0) -> None:
    """Press at the middle of ``view``, move by (dx, dy) pixels, release."""
    from PySide6.QtCore import QEvent, QPointF, Qt
    from PySide6.QtGui import QMouseEvent

    start = QPointF(200.0, 150.0)
    end = QPointF(200.0 + dx, 150.0 + dy)
    for kind, at, buttons in ((QEvent.Type.MouseButtonPress, start, Qt.MouseButton.LeftButton),
                              (QEvent.Type.MouseMove, end, Qt.MouseButton.LeftButton),
                              (QEvent.Type.MouseButtonRelease, end, Qt.MouseButton.NoButton)):
        event = QMouseEvent(kind, at, at, Qt.MouseButton.LeftButton, buttons, Qt.KeyboardModifier.NoModifier)
        {QEvent.Type.MouseButtonPress: view.mousePressEvent, QEvent.Type.MouseMove: view.mouseMoveEvent,
         QEvent.Type.MouseButtonRelease: view.mouseReleaseEvent}[kind](event)


def test_the_drag_stops_at_her_photographs_limits(qapp: object) -> None:
    from app.kiosk.shopper import TURN_DEG_PER_PX, ShopperView
    from render.mirror import TurnLimits

    view = ShopperView()
    view.turnable = True
    view.limits = TurnLimits(yaw=(-10.0, 25.0), pitch=(-20.0, 15.0))  # e.g. a face photographed turned
    turns: list[tuple[float, float]] = []
    view.turned.connect(lambda y, p: turns.append((y, p)))
    far = 100.0 / TURN_DEG_PER_PX  # 100° of drag each way
    _drag(view, far, far)
    first = (view.yaw, view.pitch)
    _drag(view, -2 * far, -2 * far)
    assert {first[0], view.yaw} == {-10.0, 25.0} and {first[1], view.pitch} == {-20.0, 15.0}, (first, view.yaw)
    assert turns[-1] == (view.yaw, view.pitch)
    view.turnable = False  # the mirror view does not turn
    _drag(view, far)
    assert turns[-1] == (view.yaw, view.pitch) and len(turns) == 2


class _FakeView:
    """Stands in for render.mirror's views: an asymmetric frame, and the relit view's turn limits."""

    def __init__(self, value: int) -> None:
        from render.mirror import TurnLimits

        self.frame = np.zeros((4, 6, 3), np.uint8)
        self.frame[:, :2] = value  # a bright left edge
        self.show_makeup = True
        self.limits = TurnLimits(yaw=(-10.0, 25.0))
        self.yaw = self.pitch = 0.0
        self.lights: list[Any] = []

    def set_layers(self, layers: Any) -> None:
        pass

    def use_capture_light(self) -> None:
        pass

    def render_image(self) -> np.ndarray:
        return self.frame.copy() if self.show_makeup else np.zeros_like(self.frame)  # "before": dark


def test_the_renderer_clamps_the_turn_to_the_relit_views_limits() -> None:
    from app.kiosk.shopper import FrameRequest, ShopperRenderer

    mirror, relight = _FakeView(200), _FakeView(100)
    ShopperRenderer._draw(mirror, relight, FrameRequest(view="relight", yaw=-40.0, pitch=3.0))
    assert (relight.yaw, relight.pitch) == (-10.0, 3.0)  # drawn at the limit, not refused


@pytest.mark.parametrize("view", ["mirror", "relight"])
def test_both_views_are_shown_flipped_as_a_mirror_shows_her(view: str) -> None:
    from app.kiosk.shopper import FrameRequest, ShopperRenderer

    mirror, relight = _FakeView(200), _FakeView(100)
    drawn = (mirror if view == "mirror" else relight).frame
    shown = ShopperRenderer._draw(mirror, relight, FrameRequest(view=view))
    assert np.array_equal(shown, drawn[:, ::-1]), "shown as a camera sees her"  # the bright edge on the right
    # before/after: the split is laid over the flipped frame, its left part "before"
    split = ShopperRenderer._draw(mirror, relight, FrameRequest(view=view, split=0.5))
    assert np.array_equal(split[:, 4:], drawn[:, ::-1][:, 4:]) and split[:, :2].max() == 0  # (2–3: the line)


def test_a_drag_to_the_right_turns_her_as_her_reflection_would_turn(qapp: object) -> None:
    """Shown flipped, her left cheek is on the screen's left: dragging right brings it forward (positive
    yaw, render.mirror.RelightView's sign), as her reflection's front follows the hand; a drag down looks
    at her from above (positive pitch)."""
    from app.kiosk.shopper import TURN_DEG_PER_PX, ShopperView

    view = ShopperView()
    view.turnable = True
    _drag(view, 10.0 / TURN_DEG_PER_PX)
    assert view.yaw == pytest.approx(10.0) and view.pitch == 0.0
    _drag(view, -20.0 / TURN_DEG_PER_PX, 5.0 / TURN_DEG_PER_PX)
    assert view.yaw == pytest.approx(-10.0) and view.pitch == pytest.approx(5.0)
