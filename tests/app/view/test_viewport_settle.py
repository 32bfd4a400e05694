"""The viewport settles when a drag's button is released, without waiting out the settle timer (issue #13).

A real studio window under Xvfb with Mesa GL; the drags are real mouse events to the viewport. What is
checked is structural (which frame follows, how many), never a time: the next frame after the release is
the full-resolution one, exactly one follows, none is drawn while the drag goes on, and inputs whose end
cannot be seen (the wheel) still wait for the timer.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pytest
from PySide6.QtCore import QPoint, QPointF, Qt

from app.qt_compat import pin_singletons
from tests.app.studio_support import open_studio_window, reset_studio

if TYPE_CHECKING:
    from collections.abc import Iterator

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]


@pytest.fixture(scope="module")
def studio(qapp: object, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    with open_studio_window(qapp, tmp_path_factory) as (win, _driver):
        yield win


@pytest.fixture
def window(studio: Any, qtbot: Any) -> Any:
    reset_studio(studio)
    qtbot.waitUntil(lambda: studio.viewport.settled, timeout=10000)
    return studio


def _drag(vp: Any, qtbot: Any, button: Qt.MouseButton, start: QPoint, steps: int,
          mods: Qt.KeyboardModifier = Qt.KeyboardModifier.NoModifier) -> QPoint:
    """Press at ``start``, then ``steps`` moves 4 px apart, each followed by the frame it asks for.

    Asserts that no full-resolution frame is drawn while the drag goes on. Returns the last position
    (the button is still held).
    """
    settled = vp.settled_frames
    qtbot.mousePress(vp, button, mods, start)
    pos = start
    for _ in range(steps):
        pos = QPoint(pos.x() + 4, pos.y())
        qtbot.mouseMove(vp, pos)
        _frame_now(vp)
        assert vp.last_frame_interactive, "a frame during the drag must be interactive"
    assert vp.settled_frames == settled, "a full frame was drawn while the drag went on"
    return pos


def _frame_now(vp: Any) -> None:
    """Draw the frame the viewport asked for now (not after the event loop's next pass)."""
    before = vp.frames
    vp.repaint()
    assert vp.frames == before + 1, "the viewport drew no frame"


def _release_settles_at_once(vp: Any, qtbot: Any, button: Qt.MouseButton, pos: QPoint,
                             mods: Qt.KeyboardModifier = Qt.KeyboardModifier.NoModifier) -> None:
    """Release: the very next frame is the full-resolution one, and exactly one follows."""
    from app.view.viewport import SETTLE_MS

    settled = vp.settled_frames
    qtbot.mouseRelease(vp, button, mods, pos)
    assert vp.stage == "settle", "releasing the button must settle the view at once"
    whole = vp.renderer.r.lighting.full_updates
    _frame_now(vp)  # drawn before the settle timer could have come due
    assert not vp.last_frame_interactive and vp.settled_frames == settled + 1
    assert vp.renderer.r.lighting.full_updates == whole, "a settle frame never rebuilds the cache whole"
    assert tuple(vp.renderer.r.last.size) == vp.pixel_size()
    assert vp.settled
    qtbot.wait(SETTLE_MS * 3)  # nothing more follows: the timer was stopped, not left to add a frame
    assert vp.settled_frames == settled + 1


def test_releasing_an_orbit_settles_at_once(window: Any, qtbot: Any) -> None:
    vp = window.viewport
    yaw = vp.camera.yaw
    pos = _drag(vp, qtbot, Qt.MouseButton.RightButton, QPoint(vp.width() // 2, vp.height() // 2), 6)
    assert vp.camera.yaw != yaw
    _release_settles_at_once(vp, qtbot, Qt.MouseButton.RightButton, pos)


def test_releasing_a_light_drag_settles_and_relights_at_full_resolution(window: Any, qtbot: Any) -> None:
    vp = window.viewport
    r = vp.renderer.r
    full = r.settings.irradiance_size
    az = vp.lighting.azimuth
    ctrl = Qt.KeyboardModifier.ControlModifier
    try:
        pos = _drag(vp, qtbot, Qt.MouseButton.LeftButton, QPoint(vp.width() // 2, vp.height() // 2), 5, ctrl)
        assert vp.lighting.azimuth != az
        assert r.irradiance.size == full // 2, "a moving light is relit at half resolution"
        whole = r.lighting.full_updates
        _release_settles_at_once(vp, qtbot, Qt.MouseButton.LeftButton, pos, ctrl)
        assert r.irradiance.size == full and r.irradiance.is_current(_irradiance_key(r))
        # the settle frame drew on the direct path; the lighting cache was rebuilt after it, without a frame
        assert r.lighting.full_updates == whole + 1 and not r.defer_cache
        drawn = vp.renderer_frames
        vp.orbit_by(0.5)  # the next frames fetch the rebuilt cache
        _frame_now(vp)
        assert vp.renderer_frames == drawn + 1 and r.lighting.full_updates == whole + 1
    finally:
        vp.lighting.azimuth = az
        vp.refresh()
        qtbot.waitUntil(lambda: vp.frames > 0 and vp.settled, timeout=10000)


def _irradiance_key(r: Any) -> Any:
    """The renderer's irradiance key for its current lights (as ``Renderer.render`` makes it)."""
    s, env = r.settings, r.environment
    return (tuple((lt.kind, tuple(lt.vector), tuple(lt.colour), lt.intensity, lt.shadows, lt.reference_distance)
                  for lt in r.lights),
            None if env is None else env.coefficients.tobytes(), s.normal_strength, s.pcf_radius, s.shadow_size)


def test_releasing_a_stroke_settles_at_once_with_the_stroke_in_the_frame(window: Any, qtbot: Any) -> None:
    vp = window.viewport
    start = QPoint(vp.width() // 2, int(vp.height() * 0.45))
    assert vp.pick(QPointF(start)) is not None, "the stroke must start on the face"
    steps = len(window.doc.history)
    pos = _drag(vp, qtbot, Qt.MouseButton.LeftButton, start, 5)
    _release_settles_at_once(vp, qtbot, Qt.MouseButton.LeftButton, pos)
    assert len(window.doc.history) == steps + 1, "the drag was not one stroke"
    assert not vp.pending_changes, "the settled frame must hold the whole stroke"


def test_reference_mode_release_draws_the_fast_then_the_reference_frame(window: Any, qtbot: Any) -> None:
    from app.view.viewport import SETTLE_MS

    vp = window.viewport
    window.change_settings(render_mode="reference")
    try:
        qtbot.waitUntil(lambda: vp.settled, timeout=10000)
        pos = _drag(vp, qtbot, Qt.MouseButton.RightButton, QPoint(vp.width() // 2, vp.height() // 2), 4)
        settled = vp.settled_frames
        qtbot.mouseRelease(vp, Qt.MouseButton.RightButton, Qt.KeyboardModifier.NoModifier, pos)
        _frame_now(vp)
        assert vp.renderer.drawn_by == "fast" and vp.settled_frames == settled + 1
        qtbot.waitUntil(lambda: vp.settled_frames == settled + 2, timeout=10000)
        assert vp.renderer.drawn_by == "reference" and vp.settled
        qtbot.wait(SETTLE_MS * 3)
        assert vp.settled_frames == settled + 2
    finally:
        window.change_settings(render_mode="fast")
        qtbot.waitUntil(lambda: vp.settled, timeout=10000)


def test_a_click_that_moved_nothing_draws_no_frame(window: Any, qtbot: Any) -> None:
    from app.view.viewport import SETTLE_MS

    vp = window.viewport
    drawn, settled = vp.renderer_frames, vp.settled_frames
    centre = QPoint(vp.width() // 2, vp.height() // 2)
    qtbot.mousePress(vp, Qt.MouseButton.RightButton, Qt.KeyboardModifier.NoModifier, centre)
    qtbot.mouseRelease(vp, Qt.MouseButton.RightButton, Qt.KeyboardModifier.NoModifier, centre)
    qtbot.wait(SETTLE_MS * 2)
    assert vp.settled and vp.stage == "final"
    assert (vp.renderer_frames, vp.settled_frames) == (drawn, settled)


def test_the_wheel_still_waits_for_the_settle_timer(window: Any, qtbot: Any) -> None:
    """The wheel has no release: its frames stay interactive until input has been quiet for SETTLE_MS."""
    from PySide6.QtCore import QPoint as P
    from PySide6.QtGui import QWheelEvent
    from PySide6.QtWidgets import QApplication

    vp = window.viewport
    settled = vp.settled_frames
    centre = QPointF(vp.width() / 2, vp.height() / 2)
    event = QWheelEvent(centre, QPointF(vp.mapToGlobal(centre.toPoint())), P(0, 0), P(0, 120),
                        Qt.MouseButton.NoButton, Qt.KeyboardModifier.NoModifier, Qt.ScrollPhase.NoScrollPhase,
                        False)
    QApplication.sendEvent(vp, event)
    assert vp.stage == "interactive"
    _frame_now(vp)
    assert vp.last_frame_interactive and vp.settled_frames == settled
    qtbot.waitUntil(lambda: vp.settled, timeout=10000)
    assert vp.settled_frames == settled + 1
