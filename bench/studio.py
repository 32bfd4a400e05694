"""``sheer bench studio --json``: the studio's start-up, orbit frame rate and dab-to-frame latency.

Start-up to first frame, orbit frame rate at 1280×720 (fast mode) and dab-to-frame latency, measured on
the real studio window (xcb; re-runs itself under ``xvfb-run`` when there is no display).

Every timed series reports its median under the key's plain name and, beside it, its 90th percentile
(``…_p90``) and its slowest sample (``…_max``): a median alone hides hitches.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import shutil
import subprocess
import sys
import time
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable

    from PySide6.QtCore import QEvent, Qt

    from app.view.viewport import Viewport


def _process_age_s() -> float:
    """Seconds since this process started (Linux /proc), or 0 when unknown."""
    try:
        with open("/proc/self/stat", encoding="ascii") as f:
            start_ticks = int(f.read().rsplit(")", 1)[1].split()[19])
        with open("/proc/uptime", encoding="ascii") as f:
            uptime = float(f.read().split()[0])
        return max(uptime - start_ticks / os.sysconf("SC_CLK_TCK"), 0.0)
    except (OSError, ValueError, IndexError):
        return 0.0


def main(argv: list[str]) -> int:
    """Run the benchmark (``argv``: its options, see ``--help``), print one JSON object; returns 0.

    Raises:
        core.errors.SheerError: no display and no ``xvfb-run``, or the viewport drew no frame in time.
    """
    # start-up is timed from the process's own start (interpreter and imports included)
    t_start = time.perf_counter() - _process_age_s()
    args = _options(argv)
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        return _under_xvfb(argv)
    from PySide6.QtWidgets import QApplication

    win, startup = _open_studio(args.resolution, t_start)
    vp = win.viewport
    # orbit at 1280×720 in fast mode, driven by real input events (a right-button drag)
    win.settings.render_mode = "fast"
    win.apply()
    vp.setFixedSize(1280, 720)
    win.resize(1280 + 700, 720 + 200)
    for _ in range(20):
        QApplication.processEvents()
    size = vp.pixel_size()
    probe = _PresentProbe(vp)
    orbit, settles, settle_frames = _settled_drags(vp, probe, "orbit", args.orbit_seconds, 5, args.settles)
    # a key-light drag (Ctrl + left drag): the settled frame relights (shadows, irradiance, lighting cache)
    light, light_settles, light_frames = _settled_drags(vp, probe, "light", 1.0, 3, args.settles)
    # the same pose, interactive and settled: how far the interactive frame is from the full one
    compared = _interactive_vs_settled(vp)
    paint, layer_res = _paint_drag(win, probe, args.dab_seconds)
    result = _figures(vp, startup, size, orbit, settles, settle_frames, light, light_settles, light_frames,
                      compared, paint, layer_res)
    win.setWindowModified(False)  # the bench's strokes are not kept: close without the save question
    win.close()
    print(json.dumps(result))
    return 0


def _options(argv: list[str]) -> argparse.Namespace:
    """The benchmark's options (:class:`core.errors.SheerError` for a ``--settles`` below 1)."""
    p = argparse.ArgumentParser(prog="sheer bench studio", description=__doc__)
    p.add_argument("--json", action="store_true", help="print one JSON object (the only format)")
    p.add_argument("--orbit-seconds", type=float, default=3.0, help="length of the orbit drag (s)")
    p.add_argument("--dab-seconds", type=float, default=1.5, help="length of the painting drag (s)")
    p.add_argument("--settles", type=int, default=6,
                   help="drags whose settle is timed, of each kind (orbit, key light; ≥ 1): the first after the "
                        "long drag, the others after 0.5 s drags")
    p.add_argument("--resolution", type=int, default=None,
                   help="paint resolution (texels; default: the studio's, app.settings.DEFAULT_RESOLUTION)")
    args = p.parse_args(argv)
    if args.settles < 1:
        from core.errors import SheerError

        raise SheerError(f"--settles must be at least 1, got {args.settles}")
    return args


def _under_xvfb(argv: list[str]) -> int:
    """Run the benchmark again under ``xvfb-run`` (no display here); its exit status."""
    xvfb = shutil.which("xvfb-run")
    if xvfb is None:
        from core.errors import SheerError

        raise SheerError("the studio benchmark needs a display (or xvfb-run)")
    cmd = [xvfb, "-a", "-s", "-screen 0 1920x1080x24", sys.executable, "-m", "app", "bench", "studio", *argv]
    return subprocess.call(cmd)


def _open_studio(resolution: int | None, t_start: float) -> tuple[Any, float]:
    """The studio window on the sample head's natural look, shown, and its start-up to first frame (s).

    It keeps its settings and recovery files in a scratch folder (no recovery offer from the user's sessions).
    """
    import tempfile

    from PySide6.QtCore import QSettings

    from app.application import make_application

    make_application()
    from app.session import Session
    from app.settings import DEFAULT_RESOLUTION
    from app.studio.main_window import StudioWindow
    from core.errors import SheerError

    scratch = tempfile.mkdtemp(prefix="sheer-bench-")
    # the bench's own recovery folder: no recovery offer from the user's sessions, none left behind
    os.environ["SHEER_RECOVERY_DIR"] = os.path.join(scratch, "recovery")
    ini = os.path.join(scratch, "bench.ini")
    session = Session.open(resolution=resolution or DEFAULT_RESOLUTION, look="natural")
    win = StudioWindow(session, qsettings=QSettings(ini, QSettings.Format.IniFormat))
    win.resize(1500, 900)
    win.show()
    vp = win.viewport
    _wait_until(lambda: vp.first_frame_time is not None, 120.0)
    if vp.first_frame_time is None:
        raise SheerError("bench studio: the viewport drew no frame within 120 s")
    return win, vp.first_frame_time - t_start


def _settled_drags(vp: Viewport, probe: _PresentProbe, kind: str, seconds: float, step_px: int,
                   count: int) -> tuple[dict[str, Any], list[float], list[float]]:
    """A ``kind`` drag of ``seconds``, then ``count`` − 1 of 0.5 s (each the other way), each from a settled view.

    Returns the first drag's figures (:func:`_drag`), the settle time after each (ms) and the settled
    frames' paintGL (ms).
    """
    _wait_until(lambda: vp.settled, 10.0)
    first = _drag(vp, probe, kind, seconds, step_px=step_px)
    frames: list[float] = []
    settles = [_settle_time(vp, probe, first["last_event"], frames)]
    for k in range(1, count):  # more drags, each released: settle times to spread (p90, max)
        _wait_until(lambda: vp.settled, 10.0)
        drag = _drag(vp, probe, kind, 0.5, step_px=step_px * (-1) ** k)
        settles.append(_settle_time(vp, probe, drag["last_event"], frames))
    return first, settles, frames


def _paint_drag(win: Any, probe: _PresentProbe, seconds: float) -> tuple[dict[str, Any], int | None]:
    """Dab → frame on screen: a real left-button drag on the face, each move a dab, on a new layer.

    Returns the drag's figures (:func:`_drag`) and the layer's resolution.
    """
    from PySide6.QtCore import QPointF

    from core.errors import SheerError

    vp = win.viewport
    vp.orbit_by(-vp.camera.yaw)
    _wait_until(lambda: vp.settled, 10.0)
    win.add_layer(next(iter(win.library)).name)
    _draw_frame(vp)  # the new layer's full evaluation is not a dab
    _wait_until(lambda: vp.settled, 10.0)
    cx, cy = vp.width() / 2, vp.height() / 2
    if vp.pick(QPointF(cx - 60, cy)) is None:
        raise SheerError("bench studio: the stroke's start is not on the face")
    paint = _drag(vp, probe, "paint", seconds, step_px=2, start=(cx - 60, cy))
    _wait_until(lambda: vp.settled, 10.0)
    return paint, int(win.doc.layers[-1].thickness.shape[0]) if win.doc.layers else None


def _figures(vp: Viewport, startup: float, size: tuple[int, int], orbit: dict[str, Any], settles: list[float],
             settle_frames: list[float], light: dict[str, Any], light_settles: list[float],
             light_frames: list[float], compared: tuple[float, float, float], paint: dict[str, Any],
             layer_res: int | None) -> dict[str, Any]:
    """The benchmark's JSON object from its measurements (the keys are explained in its ``note``)."""
    from app.session import BACKENDS
    from bench.stats import spread

    de_mean, de_p95, inter_scale = compared
    dabs: dict[str, float | None] = {}
    for key, series in (("dab_to_frame_ms", paint["latencies_ms"]), ("dab_update_ms", paint["update_ms"])):
        dabs.update(spread(key, series, 1) if series else dict.fromkeys((key, f"{key}_p90", f"{key}_max")))
    return {
        "startup_to_first_frame_s": round(startup, 3),
        "orbit_fps": round(orbit["fps"], 1),
        **spread("orbit_frame_ms", orbit["intervals_ms"], 2),
        **spread("orbit_paintgl_ms", orbit["paint_ms"], 1),
        "orbit_frames_presented": orbit["presented"],
        "orbit_input_events": orbit["events"],
        "orbit_event_deliveries": orbit["deliveries"],
        "orbit_interactive_scale": float(np.median(orbit["scales"])) if orbit["scales"] else None,
        **spread("settle_ms", settles, 1),
        "light_drag_fps": round(light["fps"], 1),
        **spread("light_settle_ms", light_settles, 1),
        "settles_timed": len(settles),
        "settle_frame_ms": round(float(np.median(settle_frames)), 1),
        "light_settle_frame_ms": round(float(np.median(light_frames)), 1),
        "light_drag_paintgl_ms": round(float(np.median(light["paint_ms"])), 1),
        "interactive_vs_settled_de2000": round(de_mean, 3),
        "interactive_vs_settled_de2000_p95": round(de_p95, 3),
        "interactive_scale_compared": inter_scale,
        "viewport_px": list(size),
        **dabs,
        **spread("dab_frame_paintgl_ms", paint["paint_ms"], 1),
        **spread("dab_frame_flush_ms", paint["flush_ms"], 1),
        "first_dab_ms": None if paint["first_ms"] is None else round(paint["first_ms"], 1),
        "dabs_presented": len(paint["latencies_ms"]),
        "paint_resolution": layer_res,
        "render_mode": "fast",
        "interactive_budget_ms": vp.refine.budget_ms,
        "interactive_scale_cap": vp.refine.max_scale,
        "load_average_1min": round(os.getloadavg()[0], 2),
        "cpus": os.cpu_count(),
        "renderer_frames": vp.renderer_frames,
        "note": "input is real Qt mouse events sent to the window's QWindow (Qt dispatches them) on a fixed "
                "100 Hz schedule (moves overdue behind a frame coalesced into one, as X11 compresses motion); a "
                "frame counts when it is presented (the viewport's frameSwapped, after its GL window's swap). "
                "orbit_fps = frames presented / orbit time; orbit_frame_ms = "
                "intervals between presented frames; orbit_paintgl_ms = the viewport's paintGL per orbit "
                "frame (the rest: Qt's event handling and the swap); dab_to_frame_ms = from a dab's scheduled event time to "
                "the presentation of the first frame containing it; first_dab_ms = the session's first dab "
                "(the stroke's press) to its frame; settle_ms = from the last input event to the "
                "full-resolution frame presented (the button is released once the last move's frame is on "
                "screen; a release settles the view at once), over settles_timed drags: a 3 s orbit, then 0.5 s "
                "ones; settle_frame_ms = the settled frame's paintGL (median); light_settle_ms = the same after "
                "key-light drags (Ctrl + left drag: the settled frame relights; 1 s, then 0.5 s ones), "
                "light_settle_frame_ms its settled frame's paintGL, light_drag_fps and light_drag_paintgl_ms "
                "the 1 s drag's frames; interactive_vs_settled_de2000 = mean ΔE2000 over skin "
                "pixels of one pose drawn interactive (scale: interactive_scale_compared) and settled; "
                "dab_update_ms = the handling of one (coalesced) move event: pick + painting the dabs; "
                "dab_frame_paintgl_ms = paintGL of a frame while painting, dab_frame_flush_ms its share pushing "
                "the dirty tiles to the GPU (texture-space KM)",
        "backends": dict(BACKENDS),
        "targets": {"startup_to_first_frame_s": 3.0, "orbit_fps": 24.0, "dab_to_frame_ms": 60.0,
                    "dab_to_frame_ms_max": 120.0, "settle_ms": 300.0, "light_settle_ms": 300.0, "interactive_vs_settled_de2000": 2.0,
                    "first_dab_ms": "≤ 2 × dab_to_frame_ms"},
    }


class _PresentProbe:
    """Every new frame the viewport presents.

    Each is (time, frame number, interactive, scale, paintGL ms, flush ms, settled): ``interactive`` when
    the renderer drew an interactive frame for it, ``settled`` when it is a new full-resolution frame drawn
    after input stopped (the viewport's ``settled_frames`` advanced). A frame is presented when the
    viewport's ``frameSwapped`` fires (after its GL window's swap) and its paintGL ran since the last one.
    """

    def __init__(self, vp: Viewport) -> None:
        self.vp = vp
        self.presents: list[tuple[float, int, bool, float, float, float, bool]] = []
        self._last_frame = vp.frames
        self._last_settled = vp.settled_frames
        vp.frameSwapped.connect(self._swapped)

    def _swapped(self) -> None:
        vp = self.vp
        if vp.frames == self._last_frame:
            return  # a composition without a new frame of ours
        self._last_frame = vp.frames
        settled = vp.settled_frames > self._last_settled
        self._last_settled = vp.settled_frames
        scale = vp.renderer.scale if vp.renderer is not None else 1.0
        self.presents.append((time.perf_counter(), vp.frames, vp.last_frame_interactive, scale, vp.frame_ms,
                              vp.flush_ms, settled))


def _send_mouse(vp: Viewport, kind: QEvent.Type, x: float, y: float, button: Qt.MouseButton,
                held: Qt.MouseButton, mods: Qt.KeyboardModifier | None = None) -> None:
    """Deliver one mouse event at viewport position (``x``, ``y``) to the viewport's top-level window.

    Sent to the ``QWindow`` (not the widget): Qt's own dispatch finds the widget under the pointer, or the
    one holding the mouse grab during a drag, exactly as for an event from the window system.
    """
    from PySide6.QtCore import QPoint, QPointF, Qt
    from PySide6.QtGui import QMouseEvent
    from PySide6.QtWidgets import QApplication

    window = vp.window().windowHandle()
    local = QPointF(vp.mapTo(vp.window(), QPoint(int(round(x)), int(round(y)))))
    event = QMouseEvent(kind, local, QPointF(window.mapToGlobal(local.toPoint())), button, held,
                        Qt.KeyboardModifier.NoModifier if mods is None else mods)
    QApplication.sendEvent(window, event)


def _drag(vp: Viewport, probe: _PresentProbe, kind: str, seconds: float, step_px: int,
          start: tuple[float, float] | None = None, rate_hz: float = 100.0) -> dict[str, Any]:
    """A drag of real mouse events delivered to the window on a fixed schedule; what reached the screen.

    ``kind`` is ``"orbit"`` (right button), ``"paint"`` (left button on the face: each move a dab) or
    ``"light"`` (Ctrl + left button: the key light follows).
    Moves are due every 1/``rate_hz`` s. When a frame delays the loop, the overdue moves are coalesced into
    one event at the newest position, as X11 (and Qt's xcb plugin) compresses queued pointer motion; each
    keeps its scheduled time, so a latency includes the wait behind the frame in progress, as a hand feels it.
    """
    from PySide6.QtCore import QEvent, Qt

    button = Qt.MouseButton.RightButton if kind == "orbit" else Qt.MouseButton.LeftButton
    mods = Qt.KeyboardModifier.ControlModifier if kind == "light" else None
    none = Qt.MouseButton.NoButton
    x, y = start if start is not None else (vp.width() / 2, vp.height() / 2)
    n_events = int(seconds * rate_hz)
    period = 1.0 / rate_hz
    first_present = len(probe.presents)
    events: list[tuple[float, int]] = []  # (scheduled time, the viewport's frame counter when delivered)
    update_ms: list[float] = []
    frames_at_press = vp.frames
    t_press = time.perf_counter()
    _send_mouse(vp, QEvent.Type.MouseButtonPress, x, y, button, button, mods)
    t0 = time.perf_counter()
    k = 0
    while k < n_events:
        now = time.perf_counter()
        k_due = min(int((now - t0) / period) + 1, n_events)  # events scheduled up to now
        if k_due > k:
            x += step_px * (k_due - k)
            t_in = time.perf_counter()
            _send_mouse(vp, QEvent.Type.MouseMove, x, y, none, button, mods)
            update_ms.append((time.perf_counter() - t_in) * 1000.0)
            events += [(t0 + i * period, vp.frames) for i in range(k, k_due)]
            k = k_due
        # wait in Qt's event loop (frames are drawn and presented there) until the next event is due: a
        # busy loop here would take a core from the renderer on a 2-core machine
        _run_event_loop(max(t0 + k * period - time.perf_counter(), 0.0))
    t_end = t0 + (n_events - 1) * period
    last_frames = events[-1][1] if events else vp.frames
    _wait_until(lambda: len(probe.presents) > first_present and probe.presents[-1][1] > last_frames, 5.0)
    presents = probe.presents[first_present:]
    _send_mouse(vp, QEvent.Type.MouseButtonRelease, x, y, button, none, mods)
    during = [p for p in presents if p[0] <= t_end + 0.001]
    times = [p[0] for p in during]
    intervals = [(b - a) * 1000.0 for a, b in itertools.pairwise(times)]
    lat = []
    for t_sched, frames_before in events:
        shown = next((p for p in presents if p[1] > frames_before), None)
        if shown is not None:
            lat.append((shown[0] - t_sched) * 1000.0)
    first_ms = None
    if kind == "paint":
        shown = next((p for p in presents if p[1] > frames_at_press), None)
        first_ms = None if shown is None else (shown[0] - t_press) * 1000.0
    fps = (len(times) - 1) / (times[-1] - times[0]) if len(times) > 2 else 0.0
    return {"fps": fps, "intervals_ms": intervals or [0.0], "presented": len(during), "events": n_events,
            "deliveries": len(update_ms), "paint_ms": [p[4] for p in during] or [0.0],
            "flush_ms": [p[5] for p in during] or [0.0],
            "scales": [p[3] for p in during if p[2]], "latencies_ms": lat,
            "update_ms": update_ms if kind == "paint" else [], "first_ms": first_ms, "last_event": t_end}


def _settle_time(vp: Viewport, probe: _PresentProbe, t_last: float, frames_ms: list[float] | None = None) -> float:
    """Milliseconds from the last input event (``t_last``, perf_counter) to the full frame presented.

    The full frame's paintGL (ms) is appended to ``frames_ms`` when given.
    """
    from core.errors import SheerError

    n = len([p for p in probe.presents if p[0] <= t_last])
    _wait_until(lambda: vp.settled and any(p[6] for p in probe.presents[n:]), 5.0)
    settled = next((p for p in probe.presents[n:] if p[6]), None)
    if settled is None:
        raise SheerError("bench studio: the view did not settle within 5 s of the last input")
    if frames_ms is not None:
        frames_ms.append(settled[4])
    return (settled[0] - t_last) * 1000.0


def _interactive_vs_settled(vp: Viewport) -> tuple[float, float, float]:
    """Mean and 95th percentile ΔE2000 over skin pixels of one pose, settled vs interactive; the scale."""
    from app.qt_compat import qimage_to_rgb
    from bench.stats import de2000_srgb8

    settled = qimage_to_rgb(vp.grabFramebuffer())
    vp.makeCurrent()
    skin = vp.renderer.skin_pixel_mask()
    vp.doneCurrent()
    vp.note_input()  # the same pose, drawn as an interactive frame
    interactive = qimage_to_rgb(vp.grabFramebuffer())
    scale = float(vp.renderer.scale)
    _wait_until(lambda: vp.settled, 5.0)
    if skin.shape != settled.shape[:2] or not skin.any():
        return float("nan"), float("nan"), scale
    de = de2000_srgb8(settled, interactive, skin)
    return float(np.mean(de)), float(np.percentile(de, 95)), scale


def _run_event_loop(seconds: float) -> None:
    """Run Qt's event loop for ``seconds`` (sleeping while there is nothing to do), then return."""
    from PySide6.QtCore import QEventLoop, QTimer
    from PySide6.QtWidgets import QApplication

    if seconds <= 0.0:
        QApplication.processEvents()
        return
    loop = QEventLoop()
    QTimer.singleShot(max(int(seconds * 1000.0), 1), loop.quit)
    loop.exec()


def _wait_until(cond: Callable[[], bool], timeout: float) -> None:
    """Run the event loop until ``cond()`` is true or ``timeout`` seconds have passed.

    In 20 ms slices spent inside Qt's event loop (not a Python busy loop, which would hold the GIL the
    studio's import worker needs).
    """
    deadline = time.perf_counter() + timeout
    while not cond() and time.perf_counter() < deadline:
        _run_event_loop(0.02)


def _draw_frame(vp: Viewport) -> None:
    """Repaint the viewport and wait until the frame is drawn and finished on the GPU.

    A ``repaint()`` of a window that is not exposed (e.g. just after a resize under a window manager)
    returns without painting; timing that would report absurd frame rates, so the frame counter must
    advance, or the benchmark fails with a clear message.
    """
    from PySide6.QtWidgets import QApplication

    from core.errors import SheerError

    before = vp.frames
    vp.repaint()
    deadline = time.perf_counter() + 10.0
    while vp.frames == before and time.perf_counter() < deadline:
        QApplication.processEvents()
        vp.repaint()
    if vp.frames == before:
        raise SheerError("bench studio: the viewport drew no frame within 10 s (is the window exposed?)")
    vp.makeCurrent()
    vp.ctx.finish()
    vp.doneCurrent()
