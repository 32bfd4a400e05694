"""The customer kiosk: full screen, no menus and no file dialogs, large touch targets.

Looks, product swaps per category, light presets, drag to turn, before/after, snapshots to a configured
folder, an idle attract mode, and an administrator PIN (stored hashed) guarding every way out:
window-manager close / Alt+F4 (``closeEvent``), Esc and Ctrl+Q. Any error returns to the start screen with
a friendly message and is logged; a traceback is never shown.
"""

from __future__ import annotations

import logging
import os
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from PySide6.QtCore import QEvent, QObject, Qt, QTimer
from PySide6.QtGui import QCloseEvent, QGuiApplication, QKeyEvent, QKeySequence, QShortcut
from PySide6.QtWidgets import (
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QSlider,
    QStackedWidget,
    QVBoxLayout,
    QWidget,
)

from app.actions import KIOSK_ACTIONS
from app.kiosk_config import KioskConfig, require_pin
from app.kiosk_shades import FoundationFinder
from app.pin_lock import PinGuard
from app.pin_pad import PinPad, big_button
from app.session import Session
from app.settings import LIGHT_PRESETS
from core.cache import PrivateCache

if TYPE_CHECKING:
    from collections.abc import Callable
    from types import TracebackType

    import numpy as np
    from PySide6.QtGui import QMouseEvent

    from app.viewport import Viewport
    from capture.face import Face

log = logging.getLogger("sheer.kiosk")

#: The material categories a shopper can swap shades of (one row of ◀ ▶ buttons each).
CATEGORIES: tuple[str, ...] = ("foundation", "lipstick", "blush", "eyeshadow")
#: The built-in looks on the try-on screen (``bare`` is left out of the attract mode's cycle).
KIOSK_LOOKS: tuple[str, ...] = ("natural", "evening", "red-lip", "bare")
#: What the start screen says after an error (the error itself is only logged).
FRIENDLY = "Sorry, something went wrong. Touch the screen to start again."


class _ActivityFilter(QObject):
    """Any touch, click or key counts as activity (resets the idle timer, ends attract mode).

    ``on_activity`` returns True when the event only woke the kiosk from its attract mode: the event is
    then consumed, so the touch that shows the start screen is not also a touch on it.
    """

    def __init__(self, on_activity: Callable[[], bool]) -> None:
        super().__init__()
        self.on_activity = on_activity

    def eventFilter(self, obj: QObject, event: QEvent) -> bool:  # noqa: N802
        """Report presses and key presses as activity; consume the one that ends the attract mode."""
        if event.type() in (QEvent.Type.MouseButtonPress, QEvent.Type.TouchBegin, QEvent.Type.KeyPress,
                            QEvent.Type.TabletPress):
            return self.on_activity()
        return False


class _TouchPage(QWidget):
    """A page that reacts to a touch anywhere on it."""

    def __init__(self, on_touch: Callable[[], object]) -> None:
        super().__init__()
        self.on_touch = on_touch

    def mousePressEvent(self, event: QMouseEvent) -> None:  # noqa: N802
        self.on_touch()


class KioskWindow(QWidget):
    """Start screen → try-on screen; PIN screen on any exit attempt; attract mode when idle.

    Args:
        config: the kiosk's configuration; it must hold an administrator PIN (else ``SheerError``).
        project: a ``.sheer`` project to show instead of the built-in looks.
        session: the library and document to show; None opens the sample head's at
            ``config.resolution``.
    """

    def __init__(self, config: KioskConfig, project: str | None = None, session: Session | None = None) -> None:
        require_pin(config)
        super().__init__()
        self.config = config
        self.setWindowTitle("Sheer")
        self._allow_close = False
        self.attract = False
        self.last_error: str | None = None
        self.snapshots: list[Path] = []
        # a shopper's session (try-on screen → start screen) writes its cache entries here, removed after
        self.private_cache = PrivateCache()
        self.session = session if session is not None else Session.open(resolution=config.resolution)
        self.library = self.session.library
        self.doc = self.session.document
        self.look = "natural"
        # per look: (material, layer name, max thickness µm, map µm) of each layer, bottom first
        self._look_cache: dict[str, list[tuple[str, str, float, np.ndarray]]] = {}
        self.viewport = self._make_viewport()
        self.face: Face | None = None
        self.engine = "physical"  # the engine in use: physical | lightweight
        self._frame_samples: list[float] = []
        self._load_face()
        self.viewport.frame_drawn.connect(self._watch_frame_time)
        self.stack = QStackedWidget()
        self.start_page = self._build_start()
        self.main_page = self._build_main()
        self.pin_pad = PinPad(PinGuard.for_config(config))  # the lockout's state beside the config file
        self.pin_pad.accepted.connect(self._pin_accepted)
        self.pin_pad.cancelled.connect(self._pin_cancelled)
        for page in (self.start_page, self.main_page, self.pin_pad):
            self.stack.addWidget(page)
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addWidget(self.stack)
        self.setStyleSheet("QWidget { background: #1d1b1c; color: #f4efe9; font-size: 22px; }"
                           "QPushButton { background: #3a3536; border-radius: 14px; padding: 10px; }"
                           "QPushButton:checked { background: #b0605f; }"
                           "QSlider::groove:horizontal { height: 20px; background: #3a3536; border-radius: 10px; }"
                           "QSlider::handle:horizontal { width: 56px; margin: -18px 0; background: #e0c0b0;"
                           " border-radius: 14px; }")
        # reduced action set: only the exit (PIN) and before/after, as shortcuts
        for spec in KIOSK_ACTIONS:
            sc = QShortcut(QKeySequence(spec.shortcut), self)
            sc.activated.connect(self.request_exit if spec.id == "kiosk.exit" else self._toggle_split)
        QShortcut(QKeySequence("Esc"), self).activated.connect(self.request_exit)
        QShortcut(QKeySequence("Alt+F4"), self).activated.connect(self.request_exit)
        self.idle_timer = QTimer(self)
        self.idle_timer.setSingleShot(True)
        self.idle_timer.timeout.connect(self.guard(self.start_attract))
        self.spin_timer = QTimer(self)
        self.spin_timer.setInterval(40)
        self.spin_timer.timeout.connect(self.guard(lambda: self.viewport.orbit_by(0.6)))
        self.look_timer = QTimer(self)
        self.look_timer.timeout.connect(self.guard(self._next_attract_look))
        self._filter = _ActivityFilter(self.activity)
        from PySide6.QtWidgets import QApplication

        QApplication.instance().installEventFilter(self._filter)
        self.guard(lambda: self._load(project))()
        self.show_start()

    # ------------------------------------------------------------------ construction
    def _make_viewport(self) -> Viewport:
        from app.viewport import Viewport

        vp = Viewport(self.doc.head, self.doc.layout)
        vp.set_document(self.doc, self.library)  # its binding follows the looks and shades applied
        vp.paint_enabled = False
        vp.gl_failed.connect(lambda msg: self.fail(msg))
        return vp

    def _load_face(self) -> None:
        """The configured captured face (for the lightweight engine); a broken one is logged, not shown."""
        if not self.config.face_dir:
            if self.config.engine == "lightweight":
                log.warning("kiosk: engine 'lightweight' needs face_dir in the configuration; using physical")
            return
        from capture.face import load_face

        try:
            self.face = load_face(self.config.face_dir)
        except Exception as exc:
            log.warning("kiosk: the captured face %s could not be read (%s); using the physical renderer",
                        self.config.face_dir, exc)
            return
        if self.config.engine == "lightweight":
            self.use_engine("lightweight")

    def use_engine(self, engine: str) -> None:
        """Draw with ``"physical"`` (render.Renderer, fast mode) or ``"lightweight"`` (the captured face)."""
        if engine == "lightweight" and self.face is None:
            engine = "physical"
        self.engine = engine
        self.viewport.face = self.face if engine == "lightweight" else None
        self.viewport.mode = "lightweight" if engine == "lightweight" else "fast"
        self.viewport.update()

    def _watch_frame_time(self, _ms: float) -> None:
        """Switch to the lightweight engine when the physical renderer is too slow (``engine: auto``).

        After 5 new frames of the physical renderer whose median is over ``max_frame_ms`` (ms), when a
        captured face is configured.
        """
        vp = self.viewport
        if self.config.engine != "auto" or self.engine != "physical" or self.face is None:
            return
        if vp.renderer_frames == getattr(self, "_seen_frames", 0):
            return  # a ring-only redraw (none in the kiosk) or nothing new
        self._seen_frames = vp.renderer_frames
        if vp.renderer_frames <= 1:
            return  # the first frame also builds shadow maps and caches
        self._frame_samples.append(vp.render_ms)
        if len(self._frame_samples) >= 5:
            import statistics

            median = statistics.median(self._frame_samples[-5:])
            if median > self.config.max_frame_ms:
                log.info("kiosk: physical frames take %.0f ms (> %.0f): switching to the lightweight engine",
                         median, self.config.max_frame_ms)
                self.use_engine("lightweight")

    def _build_start(self) -> QWidget:
        page = _TouchPage(self.guard(self.show_main))
        title = QLabel("Sheer")
        title.setStyleSheet("font-size: 64px; font-weight: 300;")
        title.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.start_message = QLabel("Try on makeup — touch to start")
        self.start_message.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.start_message.setWordWrap(True)
        self.start_button = big_button("Start", 120)
        self.start_button.setMaximumWidth(640)
        self.start_button.clicked.connect(self.guard(self.show_main))
        lay = QVBoxLayout(page)
        lay.addStretch(2)
        lay.addWidget(title)
        lay.addWidget(self.start_message)
        lay.addWidget(self.start_button, 0, Qt.AlignmentFlag.AlignHCenter)
        lay.addStretch(3)
        return page

    def _build_main(self) -> QWidget:
        page = QWidget()
        self.look_buttons: dict[str, QPushButton] = {}
        looks = QHBoxLayout()
        for name in KIOSK_LOOKS:
            b = big_button(name.replace("-", " ").title())
            b.setCheckable(True)
            b.clicked.connect(self.guard(lambda _c=False, n=name: self.set_look(n)))
            looks.addWidget(b)
            self.look_buttons[name] = b
        self.product_labels: dict[str, QLabel] = {}
        products = QGridLayout()
        for row, cat in enumerate(CATEGORIES):
            prev, nxt = big_button("◀", 64), big_button("▶", 64)
            prev.setMinimumWidth(72)
            nxt.setMinimumWidth(72)
            label = QLabel(cat.title())
            label.setMinimumWidth(260)
            label.setAlignment(Qt.AlignmentFlag.AlignCenter)
            prev.clicked.connect(self.guard(lambda _c=False, c=cat: self.swap_product(c, -1)))
            nxt.clicked.connect(self.guard(lambda _c=False, c=cat: self.swap_product(c, +1)))
            products.addWidget(prev, row, 0)
            products.addWidget(label, row, 1)
            products.addWidget(nxt, row, 2)
            self.product_labels[cat] = label
        lights = QHBoxLayout()
        self.light_buttons: dict[str, QPushButton] = {}
        for name in LIGHT_PRESETS:
            b = big_button(name.title(), 64)
            b.setCheckable(True)
            b.clicked.connect(self.guard(lambda _c=False, n=name: self.set_light(n)))
            lights.addWidget(b)
            self.light_buttons[name] = b
        self.split = QSlider(Qt.Orientation.Horizontal)
        self.split.setRange(0, 100)
        self.split.setMinimumHeight(64)
        self.split.valueChanged.connect(self.guard(self._split_changed))
        self.snapshot_button = big_button("Save Photo")
        self.snapshot_button.clicked.connect(self.guard(self.snapshot))
        self.toast = QLabel("")
        side = QVBoxLayout()
        side.addLayout(products)
        side.addWidget(QLabel("Light"))
        side.addLayout(lights)
        side.addWidget(QLabel("Before  ◀▶  After"))
        side.addWidget(self.split)
        side.addWidget(self.snapshot_button)
        self.foundation_finder = FoundationFinder(self.library, self.doc, lambda: self.face, self._sync,
                                                  self.guard)
        side.addWidget(self.foundation_finder)
        side.addWidget(self.toast)
        side.addStretch(1)
        # the head scan's licence (CC BY) asks for its credit wherever it is shown
        credit = self.doc.head.credit
        if credit:
            self.credit_label = QLabel(f"Head: {credit}")
            self.credit_label.setWordWrap(True)
            self.credit_label.setStyleSheet("color: #9a9a9a; font-size: 12px;")
            side.addWidget(self.credit_label)
        body = QHBoxLayout()
        body.addWidget(self.viewport, 3)
        body.addLayout(side, 2)
        lay = QVBoxLayout(page)
        lay.addLayout(looks)
        lay.addLayout(body, 1)
        return page

    # ------------------------------------------------------------------ error handling
    def guard(self, fn: Callable[..., Any]) -> Callable[..., Any]:
        """Wrap a handler: any exception is logged and returns to the start screen with a friendly message."""

        def run(*args: Any) -> Any:
            try:
                return fn(*args)
            except Exception as exc:
                log.exception("kiosk error")
                self.fail(str(exc))
                return None

        return run

    def fail(self, detail: str) -> None:
        """Log an error and return to the start screen with the friendly message (``detail`` is kept in ``last_error``)."""
        self.last_error = detail
        log.error("kiosk: %s", detail)
        self.stop_attract()  # an error in the attract mode must not leave it turning behind the start screen
        self.start_message.setText(FRIENDLY)
        self.show_start()

    # ------------------------------------------------------------------ state
    def _load(self, project: str | None) -> None:
        if project:
            from app.project_io import load_project_into

            # no dialogs in the kiosk: a project painted at another resolution is resampled
            load_project_into(self.doc, self.library, Path(project), resample=True)
            self.look = "project"
            self._sync()
        else:
            self.set_look("natural")

    def set_look(self, name: str) -> None:
        """Apply a built-in look; painted once, then replayed from a cache (instant in attract mode)."""
        import numpy as np

        cached = self._look_cache.get(name)
        if cached is None:
            self.session.apply_look(name)
            self._look_cache[name] = [(lay.material, lay.name, float(lay.max_thickness), np.array(lay.thickness))
                                      for lay in self.doc.layers]
        else:
            for i in reversed(range(len(self.doc.layers))):
                self.doc.remove_layer(i)
            for material, lname, max_t, thick in cached:
                lay = self.doc.add_layer(material, name=lname, max_thickness=max_t)
                self.doc.set_thickness(lay, thick)
        self.doc.clear_history()
        self.look = name
        for n, b in self.look_buttons.items():
            b.setChecked(n == name)
        self._sync()

    def _layer_for(self, category: str) -> int | None:
        for i, lay in enumerate(self.doc.layers):
            if lay.material in self.library and self.library.get(lay.material).category == category:
                return i
        return None

    def swap_product(self, category: str, step: int) -> None:
        """The next (step +1) or previous (-1) shade of the library's category on that category's layer."""
        i = self._layer_for(category)
        names = [m.name for m in self.library if m.category == category]
        if i is None or not names:
            self.toast.setText(f"This look has no {category}")
            return
        cur = self.doc.layers[i].material
        k = (names.index(cur) + step) % len(names) if cur in names else 0
        self.doc.set_layer(i, material=names[k])
        self.doc.clear_history()
        self._sync()

    def set_light(self, name: str) -> None:
        """Light the face with the preset ``name`` (a key of ``app.settings.LIGHT_PRESETS``)."""
        p = LIGHT_PRESETS[name]
        lt = self.viewport.lighting
        lt.azimuth, lt.elevation = p["azimuth"], p["elevation"]
        lt.colour, lt.intensity, lt.ambient = p["colour"], p["intensity"], p["ambient"]
        for n, b in self.light_buttons.items():
            b.setChecked(n == name)
        self.viewport.update()

    def _split_changed(self, v: int) -> None:
        self.viewport.split = v / 100.0
        self.viewport.update()

    def _toggle_split(self) -> None:
        self.split.setValue(0 if self.split.value() else 50)

    def _sync(self) -> None:
        for cat, label in self.product_labels.items():
            i = self._layer_for(cat)
            label.setText(self.doc.layers[i].material if i is not None else f"{cat.title()}: —")

    def snapshot(self) -> Path:
        """Save the view as a PNG in the configured snapshot folder; returns the file.

        Raises:
            OSError: the photo could not be written.
        """
        folder = Path(self.config.snapshot_dir)
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / f"sheer-{time.strftime('%Y%m%d-%H%M%S')}-{len(self.snapshots):03d}.png"
        if not self.viewport.grabFramebuffer().save(str(path)):
            raise OSError(f"could not write the photo to {folder}")
        self.snapshots.append(path)
        self.toast.setText("Photo saved")
        return path

    # ------------------------------------------------------------------ screens
    def show_full_screen(self) -> None:
        """Show the kiosk over the whole of its screen.

        On an X server without a window manager (a kiosk started from ``xinit``) a new window opens at
        its own size in the top-left corner and ``showFullScreen`` alone does not fill the screen, so
        the window is first sized to the screen's geometry.
        """
        screen = self.screen() or QGuiApplication.primaryScreen()
        self.setGeometry(screen.geometry())
        self.showFullScreen()

    def show_start(self) -> None:
        """Show the start screen (the shopper's session ends: its private cache is removed)."""
        self.stack.setCurrentWidget(self.start_page)
        self.private_cache.close()

    def show_main(self) -> None:
        """Show the try-on screen (and count it as activity); a shopper's session uses a private cache."""
        self.private_cache.open()
        self.start_message.setText("Try on makeup — touch to start")
        self.stack.setCurrentWidget(self.main_page)
        self.viewport.update()
        self.activity()

    def activity(self) -> bool:
        """A touch, click or key: restart the idle timer; in the attract mode, back to the start screen.

        Returns:
            True when this ended the attract mode.
        """
        woke = self.attract
        if woke:
            self.stop_attract()
            self.show_start()
        self.idle_timer.start(int(self.config.idle_seconds * 1000))
        return woke

    def start_attract(self) -> None:
        """Idle: turn the head and cycle the looks on the try-on screen (not while the PIN pad is up)."""
        if self.stack.currentWidget() is self.pin_pad:
            return
        self.private_cache.close()  # idle: the shopper has gone, and so does their session's cache
        self.attract = True
        self.stack.setCurrentWidget(self.main_page)
        self.spin_timer.start()
        self.look_timer.start(int(self.config.look_seconds * 1000))

    def stop_attract(self) -> None:
        """End the attract mode (the screen stays as it is)."""
        self.attract = False
        self.spin_timer.stop()
        self.look_timer.stop()

    def _next_attract_look(self) -> None:
        looks = [n for n in KIOSK_LOOKS if n != "bare"]
        i = (looks.index(self.look) + 1) % len(looks) if self.look in looks else 0
        self.set_look(looks[i])

    # ------------------------------------------------------------------ the way out
    def request_exit(self) -> None:
        """Every way out (close, Alt+F4, Esc, Ctrl+Q) ends here: the PIN pad; the right PIN closes the kiosk."""
        self.stop_attract()
        self._before_pin = self.stack.currentWidget()
        self.pin_pad.reset()
        self.stack.setCurrentWidget(self.pin_pad)

    def _pin_accepted(self) -> None:  # (a wrong PIN is logged and shown by the pad's guard)
        log.info("kiosk: exit with the administrator PIN")
        self._allow_close = True
        self.close()

    def _pin_cancelled(self) -> None:
        before = getattr(self, "_before_pin", None)
        self.stack.setCurrentWidget(before if before is not None and before is not self.pin_pad else self.start_page)

    def closeEvent(self, event: QCloseEvent) -> None:  # noqa: N802
        """Refuse to close without the PIN (show the PIN pad); after it, stop the timers and release GL."""
        if not self._allow_close:
            event.ignore()
            self.request_exit()
            return
        self.stop_attract()
        self.idle_timer.stop()
        from PySide6.QtWidgets import QApplication

        QApplication.instance().removeEventFilter(self._filter)
        from app.workers import wait_all

        wait_all(20000)
        self.private_cache.close()
        self.viewport.shutdown()
        event.accept()

    def keyPressEvent(self, event: QKeyEvent) -> None:  # noqa: N802
        """Esc, F4 and Ctrl+Q ask for the PIN; other keys as usual."""
        if event.key() in (Qt.Key.Key_Escape, Qt.Key.Key_F4) or (
                event.key() == Qt.Key.Key_Q and event.modifiers() & Qt.KeyboardModifier.ControlModifier):
            self.request_exit()
            return
        super().keyPressEvent(event)


def run_kiosk(project: str | None = None, config_path: str | None = None, windowed: bool = False) -> int:
    """Start the kiosk; never shows a traceback (errors are logged and shown as a friendly screen)."""
    import sys

    from app.studio_app import make_application

    cfg_path = Path(config_path) if config_path else None
    config = KioskConfig.load(cfg_path)
    require_pin(config)  # before any window: a one-line message from the command line
    log_dir = Path(config.snapshot_dir).parent
    logging.basicConfig(level=logging.INFO, filename=str(Path(os.environ.get("SHEER_KIOSK_LOG", str(
        log_dir / "sheer-kiosk.log")))) if os.access(log_dir, os.W_OK) else None)
    app = make_application()

    def hook(exc_type: type[BaseException], exc: BaseException, tb: TracebackType | None) -> None:
        log.error("uncaught error in the kiosk", exc_info=(exc_type, exc, tb))
        if win is not None:
            win.fail(str(exc))

    win: KioskWindow | None = None
    sys.excepthook = hook
    win = KioskWindow(config, project=project)
    if config.fullscreen and not windowed:
        win.show_full_screen()
    else:
        win.resize(1280, 800)
        win.show()
    return int(app.exec())
