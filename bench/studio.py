"""``sheer bench studio --json``: the studio's start-up, orbit frame rate and dab-to-frame latency.

Start-up to first frame, orbit frame rate at 1280×720 (fast mode) and dab-to-frame latency, measured on
the real studio window (xcb; re-runs itself under ``xvfb-run`` when there is no display).

Every timed series reports its median under the key's plain name and, beside it, its 90th percentile
(``…_p90``) and its slowest sample (``…_max``): a median alone hides hitches.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable

    from app.viewport import Viewport


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
    p = argparse.ArgumentParser(prog="sheer bench studio", description=__doc__)
    p.add_argument("--json", action="store_true", help="print one JSON object (the only format)")
    p.add_argument("--frames", type=int, default=40, help="orbit frames to time")
    p.add_argument("--dabs", type=int, default=20, help="dabs to time")
    p.add_argument("--resolution", type=int, default=None,
                   help="paint resolution (texels; default: the studio's, app.settings.DEFAULT_RESOLUTION)")
    args = p.parse_args(argv)
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        xvfb = shutil.which("xvfb-run")
        if xvfb is None:
            from core.errors import SheerError

            raise SheerError("the studio benchmark needs a display (or xvfb-run)")
        cmd = [xvfb, "-a", "-s", "-screen 0 1920x1080x24", sys.executable, "-m", "app", "bench", "studio", *argv]
        return subprocess.call(cmd)

    import tempfile

    import numpy as np
    from PySide6.QtCore import QPointF, QSettings
    from PySide6.QtWidgets import QApplication

    from app.studio_app import make_application

    make_application()
    from app.main_window import StudioWindow
    from app.session import BACKENDS, Session
    from app.settings import DEFAULT_RESOLUTION
    from bench.stats import spread
    from core.errors import SheerError

    scratch = tempfile.mkdtemp(prefix="sheer-bench-")
    # the bench's own recovery folder: no recovery offer from the user's sessions, none left behind
    os.environ["SHEER_RECOVERY_DIR"] = os.path.join(scratch, "recovery")
    ini = os.path.join(scratch, "bench.ini")
    session = Session.open(resolution=args.resolution or DEFAULT_RESOLUTION, look="natural")
    win = StudioWindow(session, qsettings=QSettings(ini, QSettings.Format.IniFormat))
    win.resize(1500, 900)
    win.show()
    vp = win.viewport
    _wait_until(lambda: vp.first_frame_time is not None, 120.0)
    if vp.first_frame_time is None:
        raise SheerError("bench studio: the viewport drew no frame within 120 s")
    startup = vp.first_frame_time - t_start

    # orbit at 1280×720 in fast mode: each timed frame is a new view drawn by render.Renderer, finished
    win.settings.render_mode = "fast"
    win.apply()
    vp.setFixedSize(1280, 720)
    win.resize(1280 + 700, 720 + 200)
    for _ in range(20):
        QApplication.processEvents()
    size = vp.pixel_size()
    times, paint_ms = _timed_orbit(vp, args.frames)
    orbit_fps = 1.0 / statistics.median(times)

    # dab → frame on screen: the dab (painting), its tiles' KM update and the new frame, finished
    vp.orbit_by(-vp.camera.yaw)
    _draw_frame(vp)
    cx, cy = size[0] // 2, size[1] // 2
    dpr = vp.devicePixelRatioF()
    hit = vp.pick(QPointF(cx / dpr, cy / dpr))
    win.add_layer(next(iter(win.library)).name)
    _draw_frame(vp)  # the new layer's full evaluation is not a dab
    lat, upd = [], []
    if hit is not None:
        win._stroke_begin(hit, 1.0)
        _draw_frame(vp)
        for i in range(args.dabs):
            t0 = time.perf_counter()
            p = vp.pick(QPointF((cx + 2 * i) / dpr, cy / dpr))
            win._stroke_move(p if p is not None else np.asarray(hit), 1.0)
            # the dab's share: painting + the texture-space KM of its tiles (what the resolution changes)
            vp.makeCurrent()
            vp.apply_layer_changes()
            vp.ctx.finish()
            vp.doneCurrent()
            upd.append(time.perf_counter() - t0)
            _draw_frame(vp)
            lat.append(time.perf_counter() - t0)
        win._stroke_end()
    layer_res = int(win.doc.layers[-1].thickness.shape[0]) if win.doc.layers else None
    dabs: dict[str, float | None] = {}
    for key, series in (("dab_to_frame_ms", lat), ("dab_update_ms", upd)):
        dabs.update(spread(key, [s * 1000.0 for s in series], 1) if series
                    else dict.fromkeys((key, f"{key}_p90", f"{key}_max")))
    result = {
        "startup_to_first_frame_s": round(startup, 3),
        "orbit_fps": round(orbit_fps, 1),
        **spread("orbit_frame_ms", [t * 1000.0 for t in times], 2),
        **spread("orbit_paintgl_ms", paint_ms, 1),
        "viewport_px": list(size),
        **dabs,
        "paint_resolution": layer_res,
        "render_mode": "fast",
        "load_average_1min": round(os.getloadavg()[0], 2),
        "cpus": os.cpu_count(),
        "renderer_frames": vp.renderer_frames,
        "note": "every timed frame is drawn by render.Renderer at the viewport's full size (no preview, no "
                "reduced resolution) and finished on the GPU (ctx.finish) before the clock stops; "
                "orbit_paintgl_ms is the viewport's share of an orbit step (the rest: Qt, window composition); "
                "dab_update_ms is a dab's share of dab_to_frame_ms (painting + texture-space KM of its tiles)",
        "backends": dict(BACKENDS),
        "targets": {"startup_to_first_frame_s": 3.0, "orbit_fps": 15.0, "dab_to_frame_ms": 100.0},
    }
    win.setWindowModified(False)  # the bench's strokes are not kept: close without the save question
    win.close()
    print(json.dumps(result))
    return 0


def _timed_orbit(vp: Viewport, frames: int) -> tuple[list[float], list[float]]:
    """Time ``frames`` orbit steps of 2° each, each a new frame drawn by the renderer.

    Returns:
        The seconds of each step, and the milliseconds of each step spent in the viewport's paintGL
        (the renderer, finished; the rest is Qt composing the window). The first 3 steps are untimed.
    """
    from core.errors import SheerError

    times, paint = [], []
    for i in range(frames + 3):
        t0 = time.perf_counter()
        before = vp.renderer_frames
        vp.orbit_by(2.0)
        _draw_frame(vp)
        if vp.renderer_frames != before + 1:
            raise SheerError("bench studio: an orbit step did not draw a new frame")
        if i >= 3:
            times.append(time.perf_counter() - t0)
            paint.append(vp.render_ms)
    return times, paint


def _wait_until(cond: Callable[[], bool], timeout: float) -> None:
    """Run the event loop until ``cond()`` is true or ``timeout`` seconds have passed.

    In 20 ms slices spent inside Qt's event loop (not a Python busy loop, which would hold the GIL the
    studio's import worker needs).
    """
    from PySide6.QtCore import QEventLoop, QTimer

    deadline = time.perf_counter() + timeout
    while not cond() and time.perf_counter() < deadline:
        loop = QEventLoop()
        QTimer.singleShot(20, loop.quit)
        loop.exec()


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
