"""``sheer bench soak --json``: the studio and the kiosk run long, and what they hold must stay flat.

Two soaks, each sampled as it goes (after ``gc.collect()``):

- **studio**: a real studio window (xcb; re-runs itself under ``xvfb-run`` without a display) takes
  ``--studio-strokes`` strokes (real left-button drags on the face), with undo/redo cycles, layer adds and
  removes (a stroke on each added layer) and orbit frames spread evenly among them;
- **kiosk**: a real kiosk window takes ``--kiosk-shoppers`` shoppers in a row through its watched-folder
  camera: good photos (saved with Save Photo and Done, or left for the idle timeout), refused ones (a blank
  wall), one who walks away on the camera screen, an unreadable photo (an error), and once a kiosk process
  killed with SIGKILL in the middle of a session (a child process with its private folder open) and the
  kiosk restarted (a new window, which sweeps the dead process's folder).

What is sampled: the resident set (``/proc/self/statm``), the Python heap (``tracemalloc``'s traced
bytes), the GL objects alive (:class:`GLLedger`: every texture, buffer, framebuffer, renderbuffer, program,
vertex array, sampler and query made through a ``moderngl.Context`` and not released, plus the standalone
contexts made by ``moderngl.create_context``), the Python threads (``threading.active_count()``), the
process's tasks (``/proc/self/task``: native threads too) and its open files (``/proc/self/fd``).

Each series is summarised by :func:`trend`: a least-squares line over the last 80 % of the samples (the
first 20 % are the warm-up: caches, pools and shader programs filling), its slope per 100 operations with
a 95 % interval, and the warm-up's growth beside it. :func:`leaks` names the series whose slope is over a
bound (:data:`STUDIO_BOUNDS`, :data:`KIOSK_BOUNDS`). An operation is one stroke, one undo or redo, one layer
added or removed, one orbit frame; in the kiosk, one shopper.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import inspect
import itertools
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import tracemalloc
import weakref
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator

#: moderngl.Context methods that make a GL object, and the kind it is counted as
GL_MAKERS: dict[str, str] = {
    "texture": "textures", "texture3d": "textures", "texture_array": "textures", "texture_cube": "textures",
    "depth_texture": "textures", "depth_texture_cube": "textures", "buffer": "buffers",
    "framebuffer": "framebuffers", "empty_framebuffer": "framebuffers", "renderbuffer": "renderbuffers",
    "depth_renderbuffer": "renderbuffers", "program": "programs", "compute_shader": "programs",
    "vertex_array": "vertex_arrays", "sampler": "samplers", "query": "queries",
}
#: the moderngl classes whose ``release`` frees a GL object
GL_CLASSES = ("Buffer", "Texture", "Texture3D", "TextureArray", "TextureCube", "Framebuffer", "Renderbuffer",
              "Program", "ComputeShader", "VertexArray", "Sampler", "Query")

#: the series sampled, and their units
SERIES = {"rss_mb": "MB", "py_mb": "MB", "gl_objects": "objects", "threads": "threads", "tasks": "tasks",
          "fds": "files"}

#: Studio bounds on the slope per 100 operations over the last 80 %, about five times what 2,000 strokes
#: measured (docs/BENCHMARKS.md "soak": resident +0.9 MB, Python heap +0.6 MB, GL objects, threads and
#: files 0): one GL object, thread or file kept per layer add/remove, or 5 MB per 100 strokes, is over them.
STUDIO_BOUNDS = {"rss_mb": 5.0, "py_mb": 1.0, "gl_objects": 0.5, "threads": 0.5, "tasks": 0.5, "fds": 0.5}
#: Kiosk bounds on the slope per 100 shoppers: 3 MB resident or 0.2 MB of Python heap per shopper, or one GL
#: object, thread or file kept per ten shoppers, is over them.
KIOSK_BOUNDS = {"rss_mb": 300.0, "py_mb": 20.0, "gl_objects": 10.0, "threads": 10.0, "tasks": 10.0,
                "fds": 10.0}


# ---------------------------------------------------------------------------------------------- GL objects


@dataclass
class _Made:
    kind: str
    ctx: int  # the ledger's key of the object's context (0: unknown)
    site: str = ""  # where it was made (the first caller outside this module)
    freed: bool = False


@dataclass
class GLLedger:
    """Counts the GL objects alive: each made through a ``moderngl.Context`` method and not released.

    While active (``with GLLedger() as ledger:``) the object-making methods of ``moderngl.Context``
    (:data:`GL_MAKERS`) and ``moderngl.create_context`` are wrapped; an object counts as freed when its
    ``release()`` runs, when its context is released, or when Python collects it in a context whose
    ``gc_mode`` is ``"auto"``. An object dropped without ``release()`` under the default ``gc_mode``
    (``None``) keeps its GL name: it stays counted, as the leak it is.
    """

    made: dict[int, _Made] = field(default_factory=dict)
    _keys: itertools.count[int] = field(default_factory=lambda: itertools.count(1))
    _undo: list[tuple[Any, str, Any]] = field(default_factory=list)

    def __enter__(self) -> GLLedger:
        import moderngl

        for name, kind in GL_MAKERS.items():
            if hasattr(moderngl.Context, name):
                self._patch(moderngl.Context, name, self._maker(getattr(moderngl.Context, name), kind))
        for name in GL_CLASSES:
            cls = getattr(moderngl, name, None)
            if cls is not None and "release" in vars(cls):
                self._patch(cls, "release", self._releaser(cls.release))
        self._patch(moderngl.Context, "release", self._context_releaser(moderngl.Context.release))
        self._patch(moderngl, "create_context", self._context_maker(moderngl.create_context))
        return self

    def __exit__(self, *exc: object) -> None:
        for owner, name, old in reversed(self._undo):
            setattr(owner, name, old)
        self._undo.clear()

    def _patch(self, owner: Any, name: str, new: Any) -> None:
        self._undo.append((owner, name, vars(owner).get(name, getattr(owner, name))))
        setattr(owner, name, new)

    def _record(self, obj: Any, kind: str, ctx: Any) -> None:
        if getattr(obj, "sheer_soak_key", None) is not None:  # (simple_framebuffer and the like call a maker)
            return
        key = next(self._keys)
        ctx_key = getattr(ctx, "sheer_soak_key", 0) if ctx is not None else 0
        self.made[key] = _Made(kind, ctx_key, _caller())
        with contextlib.suppress(AttributeError, TypeError):
            obj.sheer_soak_key = key
            weakref.finalize(obj, self._collected, key, weakref.ref(ctx) if ctx is not None else None)

    def _maker(self, fn: Callable[..., Any], kind: str) -> Callable[..., Any]:
        def make(ctx: Any, *args: Any, **kwargs: Any) -> Any:
            obj = fn(ctx, *args, **kwargs)
            self._record(obj, kind, ctx)
            return obj
        return make

    def _context_maker(self, fn: Callable[..., Any]) -> Callable[..., Any]:
        def make(*args: Any, **kwargs: Any) -> Any:
            ctx = fn(*args, **kwargs)
            if kwargs.get("standalone"):  # (a context wrapping Qt's own is not made here)
                self._record(ctx, "contexts", None)
            return ctx
        return make

    def _releaser(self, fn: Callable[..., Any]) -> Callable[..., Any]:
        def release(obj: Any) -> Any:
            self._free(getattr(obj, "sheer_soak_key", None))
            return fn(obj)
        return release

    def _context_releaser(self, fn: Callable[..., Any]) -> Callable[..., Any]:
        def release(ctx: Any) -> Any:
            key = getattr(ctx, "sheer_soak_key", None)
            self._free(key)
            if key is not None:
                for made in self.made.values():
                    if made.ctx == key:
                        made.freed = True
            return fn(ctx)
        return release

    def _free(self, key: int | None) -> None:
        if key is not None and key in self.made:
            self.made[key].freed = True

    def _collected(self, key: int, ctx_ref: weakref.ref[Any] | None) -> None:
        ctx = ctx_ref() if ctx_ref is not None else None
        if ctx is not None and getattr(ctx, "gc_mode", None) in ("auto", "context_gc"):
            self._free(key)

    def sites(self) -> dict[str, int]:
        """GL objects alive, per kind and the place that made them (``kind file:line``)."""
        out: dict[str, int] = {}
        for made in self.made.values():
            if not made.freed:
                out[f"{made.kind} {made.site}"] = out.get(f"{made.kind} {made.site}", 0) + 1
        return out

    def alive(self) -> dict[str, int]:
        """GL objects alive, per kind (``"total"``: all of them but the contexts)."""
        out: dict[str, int] = {}
        for made in self.made.values():
            if not made.freed:
                out[made.kind] = out.get(made.kind, 0) + 1
        out["total"] = sum(n for k, n in out.items() if k != "contexts")
        return out


def _caller() -> str:
    """``file:line`` of the innermost caller outside this module and moderngl."""
    here = inspect.currentframe()
    frame = here.f_back.f_back if here is not None and here.f_back is not None else None
    while frame is not None and (frame.f_code.co_filename == __file__ or "moderngl" in frame.f_code.co_filename):
        frame = frame.f_back
    if frame is None:
        return "?"
    return f"{os.path.relpath(frame.f_code.co_filename)}:{frame.f_lineno}"


# ---------------------------------------------------------------------------------------------- sampling


def rss_mb() -> float:
    """This process's resident set (MB)."""
    with open("/proc/self/statm", encoding="ascii") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def count_entries(folder: str) -> int:
    """How many entries ``folder`` has (``/proc/self/task``, ``/proc/self/fd``); -1 when unreadable."""
    try:
        return len(os.listdir(folder))
    except OSError:
        return -1


@dataclass
class Sampler:
    """The samples of one soak: after each batch of operations, every series of :data:`SERIES`."""

    ledger: GLLedger
    ops: list[int] = field(default_factory=list)
    values: dict[str, list[float]] = field(default_factory=lambda: {k: [] for k in SERIES})
    gl_kinds: list[dict[str, int]] = field(default_factory=list)
    #: other figures noted beside the samples (not bounded): e.g. the undo history's bytes
    notes: dict[str, list[float]] = field(default_factory=dict)
    note: Callable[[], dict[str, float]] | None = None

    def sample(self, ops: int) -> None:
        """Record every series after ``ops`` operations (garbage collected first)."""
        gc.collect()
        gl = self.ledger.alive()
        now = {"rss_mb": rss_mb(), "py_mb": tracemalloc.get_traced_memory()[0] / 1e6 if tracemalloc.is_tracing()
               else 0.0, "gl_objects": gl["total"], "threads": threading.active_count(),
               "tasks": count_entries("/proc/self/task"), "fds": count_entries("/proc/self/fd")}
        self.ops.append(ops)
        for k, v in now.items():
            self.values[k].append(float(v))
        self.gl_kinds.append(gl)
        for k, v in (self.note() if self.note is not None else {}).items():
            self.notes.setdefault(k, []).append(float(v))

    def trends(self) -> dict[str, dict[str, float]]:
        """Each series' :func:`trend`."""
        return {k: trend(self.ops, v) for k, v in self.values.items()}


@contextlib.contextmanager
def sampling() -> Iterator[Sampler]:
    """A :class:`Sampler` with its GL ledger active and ``tracemalloc`` tracing (stopped after)."""
    started = not tracemalloc.is_tracing()
    if started:
        tracemalloc.start(1)
    try:
        with GLLedger() as ledger:
            yield Sampler(ledger)
    finally:
        if started:
            tracemalloc.stop()


def trend(ops: list[int], values: list[float], tail: float = 0.8) -> dict[str, float]:
    """The line fitted over the last ``tail`` of the samples, and the warm-up before it.

    Returns its slope per 100 operations and a 95 % half-interval (``±``), the warm-up's growth (first
    sample to the tail's first), the tail's span of values and of operations, the first and last values.
    """
    n = len(ops)
    start = min(int(round(n * (1.0 - tail))), max(n - 2, 0))
    x, y = np.asarray(ops[start:], float), np.asarray(values[start:], float)
    if len(x) < 2 or np.ptp(x) == 0:
        return {"slope_per_100": 0.0, "ci95_per_100": float("inf"), "warmup": 0.0, "tail_span": 0.0,
                "tail_ops": 0.0, "first": float(values[0]) if values else 0.0,
                "last": float(values[-1]) if values else 0.0}
    slope, intercept = np.polyfit(x, y, 1)
    resid = y - (slope * x + intercept)
    sxx = float(((x - x.mean()) ** 2).sum())
    se = float(np.sqrt((resid ** 2).sum() / max(len(x) - 2, 1) / sxx)) if len(x) > 2 else float("inf")
    return {"slope_per_100": float(slope * 100), "ci95_per_100": 1.96 * se * 100,
            "warmup": float(values[start] - values[0]), "tail_span": float(np.ptp(y)), "tail_ops": float(np.ptp(x)),
            "first": float(values[0]), "last": float(values[-1])}


def leaks(trends: dict[str, dict[str, float]], bounds: dict[str, float], relative: float = 0.5) -> list[str]:
    """The series that grow after the warm-up, each as one line.

    A series grows when its slope per 100 operations is over its absolute bound, or when its growth over
    the tail (the fitted line's rise) is over ``relative`` × the warm-up's growth and over one unit (an
    object, a thread, a file, a MB).
    """
    out = []
    for k, t in trends.items():
        if k not in bounds:
            continue
        rise = t["slope_per_100"] * t["tail_ops"] / 100
        if t["slope_per_100"] > bounds[k]:
            out.append(f"{k}: {t['slope_per_100']:+.3g} per 100 operations (bound {bounds[k]:g})")
        elif rise > max(relative * t["warmup"], 1.0):
            out.append(f"{k}: {rise:+.3g} over the last {t['tail_ops']:g} operations, more than "
                       f"{relative:g} × the warm-up's {t['warmup']:+.3g}")
    return out


# ---------------------------------------------------------------------------------------------- the studio


def run_event_loop(seconds: float) -> None:
    """Run Qt's event loop for ``seconds``."""
    from PySide6.QtCore import QEventLoop, QTimer

    loop = QEventLoop()
    QTimer.singleShot(max(int(seconds * 1000), 0), loop.quit)
    loop.exec()


def wait_until(cond: Callable[[], bool], timeout: float, what: str) -> None:
    """Run the event loop until ``cond()`` holds.

    Raises:
        core.errors.SheerError: ``timeout`` seconds passed first (``what`` did not happen).
    """
    from core.errors import SheerError

    deadline = time.perf_counter() + timeout
    while not cond():
        if time.perf_counter() > deadline:
            raise SheerError(f"bench soak: {what} did not happen within {timeout:g} s")
        run_event_loop(0.02)


def stroke(win: Any, n: int) -> None:
    """One stroke: a left-button drag of ten moves over the face, then the frame it asks for.

    Its row and side vary with ``n``.
    """
    from PySide6.QtCore import QPoint, Qt
    from PySide6.QtTest import QTest

    vp = win.viewport
    y = int(vp.height() * (0.45 + 0.03 * (n % 5)))
    x = vp.width() // 2 + (-50 if n % 2 else 10)
    QTest.mousePress(vp, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, QPoint(x, y))
    for dx in range(4, 44, 4):
        QTest.mouseMove(vp, QPoint(x + dx, y))
    QTest.mouseRelease(vp, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, QPoint(x + 40, y))
    vp.repaint()


@dataclass(frozen=True)
class StudioPlan:
    """A studio soak's size and how many samples are taken.

    Strokes, with undo/redo cycles, layer add/removes and orbit frames spread evenly among them.
    """

    strokes: int = 2000
    undo_cycles: int = 200
    layer_cycles: int = 50
    orbit_frames: int = 400
    samples: int = 40
    #: the undo history's budget (MB): the history is bounded by design (painting.history); a small one
    #: fills during the warm-up, so that what it holds is not mistaken for a leak
    history_mb: float = 16.0

    def every(self, count: int) -> int:
        """After how many strokes one of ``count`` interleaved operations comes (0: never)."""
        return max(self.strokes // count, 1) if count > 0 else 0


def _prepare_studio(win: Any, plan: StudioPlan, sampler: Sampler) -> str:
    """Set the window up for a soak; returns the material its layers are made of.

    The interactive scale is pinned (render.progressive adapts it to the frame times, and each new scale
    makes frame targets, kept for the last three sizes, so that they are made in the warm-up), the undo
    history's budget set to ``plan.history_mb``, a layer added to paint on.
    """
    vp = win.viewport
    vp.refine.min_scale = vp.refine.max_scale = vp.refine.scale
    win.doc.history.budget_bytes = int(plan.history_mb * 1e6)
    sampler.note = lambda: {"history_mb": win.doc.history.nbytes / 1e6, "layers": len(win.doc.layers)}
    material: str = next(iter(win.library)).name
    win.add_layer(material)
    return material


def studio_soak(win: Any, plan: StudioPlan, sampler: Sampler) -> int:
    """Run ``plan`` on the studio window ``win``, sampling into ``sampler``; returns the operations done.

    Strokes go on the selected layer; an undo cycle is an undo and a redo; a layer cycle adds a layer,
    strokes it and removes it through the layers panel; an orbit frame turns the view 3° and draws.
    """
    vp = win.viewport
    material = _prepare_studio(win, plan, sampler)
    undo_every, layer_every = plan.every(plan.undo_cycles), plan.every(plan.layer_cycles)
    orbit_every, sample_every = plan.every(plan.orbit_frames), plan.every(plan.samples)
    orbits_per = max(plan.orbit_frames // plan.strokes, 1) if plan.orbit_frames else 0
    ops, sign = 0, 1.0
    sampler.sample(ops)
    for n in range(1, plan.strokes + 1):
        stroke(win, n)
        ops += 1
        if undo_every and n % undo_every == 0:
            win.undo()
            vp.repaint()
            win.redo()
            vp.repaint()
            ops += 2
        if layer_every and n % layer_every == 0:
            win.add_layer(material)
            stroke(win, n + 1)
            win.layers_panel.remove_requested.emit(len(win.doc.layers) - 1)
            win.selected_layer = len(win.doc.layers) - 1
            vp.repaint()
            ops += 3
        if orbit_every and n % orbit_every == 0:
            for _ in range(orbits_per):
                sign = -sign
                vp.orbit_by(3.0 * sign)
                vp.repaint()
                ops += 1
        if n % sample_every == 0:
            run_event_loop(0.0)
            sampler.sample(ops)
    return ops


# ---------------------------------------------------------------------------------------------- the kiosk

#: the kinds of shopper, in the order they come (one killed kiosk comes in the middle of the row)
SHOPPERS = ("saves", "refused", "walks away", "error", "idle after")
#: the child process a SIGKILL ends in the middle of a session: its private folder open, her photo in it
_KILLED_KIOSK = """
import sys, time
from core.cache import PrivateCache
root = PrivateCache().open()
(root / "face").mkdir()
(root / "face" / "photo.png").write_bytes(b"her photo")
print(root, flush=True)
time.sleep(120)
"""


def open_kiosk(folder: Path) -> Any:
    """A 1280×800 kiosk window (PIN 2468, 512² maps), shown.

    Its camera is the watched folder ``folder``/drop and its snapshots go to ``folder``/photos.
    """
    from app.kiosk.config import KioskConfig, hash_pin
    from app.kiosk.window import KioskWindow

    if not hasattr(open_kiosk, "pin"):
        open_kiosk.pin = hash_pin("2468")  # type: ignore[attr-defined]
    cfg = KioskConfig(pin_hash=open_kiosk.pin, snapshot_dir=str(folder / "photos"),  # type: ignore[attr-defined]
                      idle_seconds=600, fullscreen=False, resolution=512, camera="off",
                      watch_dir=str(folder / "drop"))
    win = KioskWindow(cfg)
    win.resize(1280, 800)
    win.show()
    wait_until(lambda: win.viewport.frames > 0, 120.0, "the kiosk's first frame")
    return win


def close_kiosk(win: Any) -> None:
    """Close the kiosk window (the administrator's PIN taken as given) and let Qt delete it."""
    win.close_without_pin()
    win.deleteLater()
    run_event_loop(0.05)


def _shopper(win: Any, kind: str, drop: Path, photo: bytes) -> None:
    """One shopper of ``kind`` (:data:`SHOPPERS`) at the kiosk ``win``: "Try it on me" to the start screen."""
    from PIL import Image

    win.tryon_button.click()
    if kind == "walks away":  # the idle timeout on the camera screen
        win.start_attract()
    elif kind == "refused":  # a blank wall: the quality gate's message, then she leaves
        Image.new("RGB", (640, 480), (120, 110, 100)).save(drop / "wall.jpg")
        wait_until(lambda: win.tryon.last_refusal != "", 60.0, "the refusal")
        win.start_attract()
    elif kind == "error":  # a photo cut short: the start screen with a message
        (drop / "cut.jpg").write_bytes(photo[: len(photo) // 3])
        wait_until(lambda: win.screen_name == "start", 30.0, "the unreadable photo's message")
    else:  # her photo: her face made up, then Save Photo and Done, or the idle timeout
        (drop / "shopper.jpg").write_bytes(photo)
        wait_until(lambda: win.tryon.shopper_view.image is not None, 180.0, "her made-up face")
        if kind == "saves":
            win.snapshot()
            win.done_button.click()
        else:
            win.start_attract()
    wait_until(lambda: win.screen_name == "start" and not win.private_cache.is_open, 30.0, "the start screen")


def kill_a_kiosk() -> Path:
    """A kiosk process killed (SIGKILL) while a shopper's private folder is open; returns that folder."""
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    child = subprocess.Popen([sys.executable, "-c", _KILLED_KIOSK], stdout=subprocess.PIPE, text=True, env=env)
    try:
        assert child.stdout is not None
        root = Path(child.stdout.readline().strip())
    finally:
        child.send_signal(signal.SIGKILL)
        child.wait(30)
    return root


@dataclass
class KioskTally:
    """What a kiosk soak left.

    The shoppers of each kind, the photos saved, the killed kiosk's folder and whether the restart removed it.
    """

    kinds: dict[str, int] = field(default_factory=dict)
    saved: list[str] = field(default_factory=list)
    killed_folder: str = ""
    swept_at_restart: bool = False


def kiosk_soak(folder: Path, shoppers: int, sampler: Sampler, photo: Path) -> KioskTally:
    """``shoppers`` shoppers in a row at a kiosk (:func:`open_kiosk` in ``folder``); returns the tally.

    Sampled after each into ``sampler``; the kinds of :data:`SHOPPERS` in turn, and in the middle of the
    row a kiosk killed and the kiosk restarted (a new window).
    """
    tally = KioskTally()
    data = photo.read_bytes()
    (folder / "drop").mkdir(parents=True, exist_ok=True)
    win = open_kiosk(folder)
    try:
        sampler.sample(0)
        kinds = itertools.cycle(SHOPPERS)
        for n in range(1, shoppers + 1):
            if n == max(shoppers // 2, 1) + 1:
                killed = kill_a_kiosk()
                tally.saved += [p.name for p in win.snapshots]
                close_kiosk(win)
                win = open_kiosk(folder)  # the restart: its private cache sweeps the dead process's folder
                tally.killed_folder, tally.swept_at_restart = str(killed), not killed.exists()
                tally.kinds["killed and restarted"] = 1
            else:
                kind = next(kinds)
                _shopper(win, kind, folder / "drop", data)
                tally.kinds[kind] = tally.kinds.get(kind, 0) + 1
            sampler.sample(n)
    finally:
        tally.saved += [p.name for p in win.snapshots]
        close_kiosk(win)
    return tally


# ---------------------------------------------------------------------------------------------- the bench


def _options(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="sheer bench soak", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--studio-strokes", type=int, default=2000, help="strokes in the studio (0: no studio soak)")
    p.add_argument("--kiosk-shoppers", type=int, default=50, help="shoppers at the kiosk (0: no kiosk soak)")
    p.add_argument("--resolution", type=int, default=512, help="the studio's and kiosk's map resolution")
    p.add_argument("--json", action="store_true", help="print JSON (the only format)")
    return p.parse_args(argv)


def _under_xvfb(argv: list[str]) -> int:
    """Run the benchmark again under ``xvfb-run`` (no display here); its exit status.

    Raises:
        core.errors.SheerError: there is no ``xvfb-run``.
    """
    from core.errors import SheerError

    xvfb = shutil.which("xvfb-run")
    if xvfb is None:
        raise SheerError("the soak benchmark needs a display (or xvfb-run)")
    cmd = [xvfb, "-a", "-s", "-screen 0 1920x1080x24", sys.executable, "-m", "app", "bench", "soak", *argv]
    return subprocess.call(cmd)


def _report(sampler: Sampler, bounds: dict[str, float], seconds: float) -> dict[str, Any]:
    """One soak's JSON section: the trends, the bounds and what is over them, the samples, the seconds."""
    trends = sampler.trends()
    return {"trends": trends, "bounds": bounds, "leaks": leaks(trends, bounds), "ops": sampler.ops,
            "values": sampler.values, "notes": sampler.notes, "gl_kinds_last": sampler.gl_kinds[-1],
            "seconds": round(seconds, 1)}


def _studio(strokes: int, resolution: int) -> dict[str, Any]:
    """The studio soak of ``strokes`` strokes on a 1280×720 viewport.

    A tenth as many undo cycles, a fortieth as many layer cycles, a fifth as many orbit frames.
    """
    from PySide6.QtCore import QSettings

    from app.session import Session
    from app.studio.main_window import StudioWindow

    scratch = Path(tempfile.mkdtemp(prefix="sheer-bench-soak-"))
    os.environ["SHEER_RECOVERY_DIR"] = str(scratch / "recovery")
    plan = StudioPlan(strokes=strokes, undo_cycles=strokes // 10, layer_cycles=max(strokes // 40, 1),
                      orbit_frames=strokes // 5, samples=40)
    t0 = time.perf_counter()
    with sampling() as sampler:
        win = StudioWindow(Session.open(resolution=resolution, look="natural"),
                           qsettings=QSettings(str(scratch / "bench.ini"), QSettings.Format.IniFormat))
        win.viewport.setFixedSize(1280, 720)
        win.show()
        wait_until(lambda: win.viewport.frames > 0 and win.viewport.full_quality_ready, 120.0, "the first frame")
        studio_soak(win, plan, sampler)
        win.setWindowModified(False)
        win.close()
    shutil.rmtree(scratch, ignore_errors=True)
    out = _report(sampler, STUDIO_BOUNDS, time.perf_counter() - t0)
    out["plan"] = plan.__dict__
    return out


def _kiosk(shoppers: int) -> dict[str, Any]:
    """The kiosk soak of ``shoppers`` shoppers, and what it left: private folders, the snapshot folder."""
    from core.assets import find_asset

    folder = Path(tempfile.mkdtemp(prefix="sheer-bench-soak-kiosk-"))
    t0 = time.perf_counter()
    with sampling() as sampler:
        tally = kiosk_soak(folder, shoppers, sampler, find_asset("photos/grace_hopper.jpg"))
    out = _report(sampler, KIOSK_BOUNDS, time.perf_counter() - t0)
    mine = list(Path(tempfile.gettempdir()).glob(f"sheer-private-cache-{os.getpid()}-*"))
    photos = sorted(p.name for p in (folder / "photos").glob("*")) if (folder / "photos").exists() else []
    out.update({"tally": tally.__dict__, "private_folders_left": len(mine),
                "snapshot_folder_only_saved": photos == sorted(tally.saved)})
    shutil.rmtree(folder, ignore_errors=True)
    return out


def main(argv: list[str]) -> int:
    """Run the soaks (``argv``: see ``--help``), print one JSON object; returns 0, or 1 when one leaks."""
    args = _options(argv)
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        return _under_xvfb(argv)
    from app.application import make_application

    make_application()
    result: dict[str, Any] = {"note": "slopes per 100 operations over the last 80 % of the samples (bench/soak.py)"}
    if args.studio_strokes > 0:
        result["studio"] = _studio(args.studio_strokes, args.resolution)
    if args.kiosk_shoppers > 0:
        result["kiosk"] = _kiosk(args.kiosk_shoppers)
    result["loadavg"] = list(os.getloadavg())
    print(json.dumps(result))
    return 1 if any(result[k]["leaks"] for k in ("studio", "kiosk") if k in result) else 0
