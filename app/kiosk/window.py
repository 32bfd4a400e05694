"""The customer kiosk: full screen, no menus and no file dialogs, large touch targets.

The start screen is the attract mode: the sample face turning and the looks cycling, with the invitation
on top (Start, and "Try it on me" when a camera or a watched folder is configured). The try-on screen has
looks, product swaps per category, light presets, drag to turn, before/after, snapshots to a configured
folder; "Try it on me" (:mod:`app.kiosk.tryon`) puts the shopper's own face there. An administrator PIN
(stored hashed) guards every way out: window-manager close / Alt+F4 (``closeEvent``), Esc and Ctrl+Q.
Any error returns to the start screen with a friendly message and is logged; a traceback is never shown.
A shopper's session (from leaving the start screen until Done or the idle timeout) keeps everything
derived from her in memory or a private temporary folder, removed when it ends.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from PySide6.QtCore import QBuffer, QByteArray, QEvent, QIODevice, QObject, QPoint, QSize, Qt, QTimer
from PySide6.QtGui import QCloseEvent, QGuiApplication, QKeyEvent, QKeySequence, QResizeEvent, QShortcut
from PySide6.QtWidgets import (
    QBoxLayout,
    QFrame,
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QScrollArea,
    QSlider,
    QStackedWidget,
    QVBoxLayout,
    QWidget,
)

from app.actions import KIOSK_ACTIONS
from app.kiosk.camera_page import PRIVACY_LINE
from app.kiosk.config import (
    DEFAULT_LOOKS,
    KioskConfig,
    KioskLook,
    builtin_look,
    install_look_projects,
    kiosk_looks,
    open_look_projects,
    replay_layers,
    require_pin,
    snapshot_layers,
)
from app.kiosk.parts import KioskEngines, ShopperSession
from app.kiosk.pin_lock import PinGuard
from app.kiosk.pin_pad import PinPad, big_button
from app.kiosk.shades import FoundationFinder
from app.kiosk.tryon import TryOn
from app.session import Session
from app.settings import LIGHT_PRESETS
from core.atomicio import atomic_write_bytes
from core.cache import PrivateCache
from core.errors import SheerError

if TYPE_CHECKING:
    from collections.abc import Callable
    from types import TracebackType

    from app.kiosk.config import LookLayer
    from app.view.viewport import Viewport

log = logging.getLogger("sheer.kiosk")

#: The material categories a shopper can swap shades of (one row of ◀ ▶ buttons each).
CATEGORIES: tuple[str, ...] = ("foundation", "lipstick", "blush", "eyeshadow")
#: The built-in looks on the try-on screen when the configuration lists no ``looks`` (``bare`` is left out
#: of the attract mode's cycle).
KIOSK_LOOKS: tuple[str, ...] = DEFAULT_LOOKS
#: What the start screen says when the configured camera gives no pictures and no watched folder is set.
CAMERA_DOWN = "“Try it on me” is not available right now: the camera is not working."
#: What the start screen says after an error (the error itself is only logged).
FRIENDLY = "Sorry, something went wrong. Touch the screen to start again."
#: The invitation on the start screen.
INVITATION = "Try on makeup — touch to start"
#: What the try-on screen says when Save Photo could not write the photo (a full disk, a folder it cannot
#: write in); she stays on her screen and may try again.
PHOTO_NOT_SAVED = "Your photo could not be saved — please ask a member of staff"
#: The smallest touch target, pixels: 9 mm at 135 DPI (a 16-inch 1920×1080 panel, the densest kiosk
#: screen supported; on the usual 21–32-inch panels, 69–105 DPI, 48 px is 11.6–17.7 mm).
MIN_TARGET_PX = 48
#: The height of the kiosk's touch buttons, pixels (above :data:`MIN_TARGET_PX`).
BUTTON_PX = 60
#: The attract mode's sway: the face turns ±this many degrees about the front (never its back).
ATTRACT_SWAY_DEG = 35.0
#: Seconds of one whole sway (front → right → front → left → front).
ATTRACT_PERIOD_S = 16.0
#: Milliseconds between two steps of the sway (a new camera yaw and a full-resolution frame).
ATTRACT_STEP_MS = 50
#: The attract mode's light: the default key light dimmed by this factor, so that the bald crown stays
#: below white (the brightest head pixel of the attract frames stays well under 255).
ATTRACT_KEY_SCALE = 0.8


def attract_yaw(t_s: float) -> float:
    """The attract camera's yaw, degrees, ``t_s`` seconds into the sway: ±:data:`ATTRACT_SWAY_DEG` about 0."""
    return ATTRACT_SWAY_DEG * math.sin(2.0 * math.pi * t_s / ATTRACT_PERIOD_S)


class _SidePanel(QScrollArea):
    """The try-on controls; they scroll only in a window smaller than the kiosk's screens.

    Its size hint is its content's whole size (a scroll area's own hint is capped), so a portrait
    screen gives the controls their full height under the face.
    """

    def sizeHint(self) -> QSize:  # noqa: N802
        """The content's size hint, pixels."""
        inner = self.widget()
        return inner.sizeHint() if inner is not None else super().sizeHint()

    def eventFilter(self, obj: QObject, event: QEvent) -> bool:  # noqa: N802
        """The content grew or shrank (the finder's shades, her views): ask the window's layout again."""
        if obj is self.widget() and event.type() == QEvent.Type.LayoutRequest:
            self.updateGeometry()
        return super().eventFilter(obj, event)


class _ActivityFilter(QObject):
    """Any touch, click or key counts as activity (resets the idle timer, ends attract mode).

    ``on_activity`` gets the press's global position (None for a key) and returns True when the event
    only woke the kiosk from its attract mode: the event is then consumed, so the touch that starts the
    try-on is not also a touch on what lies under it.
    """

    def __init__(self, on_activity: Callable[[QPoint | None], bool]) -> None:
        super().__init__()
        self.on_activity = on_activity

    def eventFilter(self, obj: QObject, event: QEvent) -> bool:  # noqa: N802
        """Report presses and key presses as activity; consume the one that ends the attract mode."""
        t = event.type()
        if t in (QEvent.Type.MouseButtonPress, QEvent.Type.TabletPress):
            return self.on_activity(event.globalPosition().toPoint())  # type: ignore[attr-defined]
        if t == QEvent.Type.TouchBegin:
            points = event.points()  # type: ignore[attr-defined]
            return self.on_activity(points[0].globalPosition().toPoint() if points else None)
        if t == QEvent.Type.KeyPress:
            return self.on_activity(None)
        return False


class KioskWindow(KioskEngines, ShopperSession, QWidget):
    """Start screen (attract mode) → try-on screen (the sample face or hers); PIN screen on any exit attempt.

    Args:
        config: the kiosk's configuration; it must hold an administrator PIN (else ``SheerError``).
        project: a ``.sheer`` project: the first look (its button first, selected), then the configured ones.
        session: the library and document to show; None opens the sample head's at
            ``config.resolution``.
        looks: the looks, their projects already on ``session``'s head (``sheer kiosk`` checks them before
            any window opens); None reads them from ``config`` and ``project`` (one that cannot be used
            is logged and left out).
    """

    def __init__(self, config: KioskConfig, project: str | None = None, session: Session | None = None,
                 looks: list[KioskLook] | None = None) -> None:
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
        self.stock_session = self.session  # the sample head's (or the project's); hers replaces it a while
        self.library = self.session.library
        self.doc = self.session.document
        self.look = "natural"
        # per look: its layers on the document shown, bottom first (replayed instantly in the attract mode)
        self.look_cache: dict[str, list[LookLayer]] = {}
        self.looks = self._prepare_looks(looks, project)
        self.viewport = self._make_viewport()
        self._fresh_lighting = dataclasses.replace(self.viewport.lighting)  # what each new shopper starts with
        self._attract_t0 = time.monotonic()
        self.setup_engines()
        self.stack = QStackedWidget()
        self.tryon = TryOn(self)
        self.main_page = self._build_main()
        self.pin_pad = PinPad(PinGuard.for_config(config))  # the lockout's state beside the config file
        self.pin_pad.accepted.connect(self._pin_accepted)
        self.pin_pad.cancelled.connect(self._pin_cancelled)
        for page in (self.main_page, self.tryon.camera_page, self.tryon.busy_page, self.pin_pad):
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
        self.spin_timer.setInterval(ATTRACT_STEP_MS)
        self.spin_timer.timeout.connect(self.guard(lambda: self.attract_turn()))
        self.look_timer = QTimer(self)
        self.look_timer.timeout.connect(self.guard(self._next_attract_look))
        self._filter = _ActivityFilter(self.activity)
        from PySide6.QtWidgets import QApplication

        QApplication.instance().installEventFilter(self._filter)
        self._camera_at_start()
        self.guard(self._load)()
        self.show_start()  # the attract mode from the start: the face turning under the invitation

    # ------------------------------------------------------------------ construction
    def _make_viewport(self) -> Viewport:
        from app.view.viewport import Viewport

        vp = Viewport(self.doc.head, self.doc.layout)
        vp.set_document(self.doc, self.library)  # its binding follows the looks and shades applied
        vp.paint_enabled = False
        vp.gl_failed.connect(lambda msg: self.fail(msg))
        return vp

    def _build_invite(self) -> QWidget:
        """The invitation over the turning face: the title, a line, Start and "Try it on me"."""
        box = QWidget()
        title = QLabel("Sheer")
        title.setStyleSheet("font-size: 64px; font-weight: 300;")
        title.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.start_message = QLabel(INVITATION)
        self.start_message.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.start_message.setWordWrap(True)
        self.start_button = big_button("Start", 110)
        self.start_button.setMaximumWidth(520)
        self.start_button.clicked.connect(self.guard(self.show_main))
        self.tryon_button = big_button("Try it on me", 110)
        self.tryon_button.setMaximumWidth(520)
        self.tryon_button.clicked.connect(self.guard(self.tryon.start))
        from app.camera_source import camera_present

        # a camera that is there, or a watched folder (a kiosk with neither offers no "Try it on me")
        self.tryon_button.setVisible(bool(self.config.watch_dir) or camera_present(self.config.camera))
        buttons = QHBoxLayout()
        buttons.addStretch(1)
        buttons.addWidget(self.start_button, 2)
        buttons.addWidget(self.tryon_button, 2)
        buttons.addStretch(1)
        lay = QVBoxLayout(box)
        lay.addWidget(title)
        lay.addWidget(self.start_message)
        lay.addLayout(buttons)
        return box

    def _build_main(self) -> QWidget:
        """The try-on page: the invitation, the looks' bar, the face (hers or the sample's) and the side panel."""
        page = QWidget()
        self.invite = self._build_invite()
        self.look_buttons: dict[str, QPushButton] = {}
        self.looks_bar = QWidget()
        QHBoxLayout(self.looks_bar)
        for look in self.looks:
            self._add_look_button(look)
        side_box = self._build_side()
        self.face_stack = QStackedWidget()
        self.face_stack.addWidget(self.viewport)
        self.face_stack.addWidget(self.tryon.shopper_view)
        # landscape: the face left, the controls right; portrait: the controls under the face (_fit_screen)
        self.body = QBoxLayout(QBoxLayout.Direction.LeftToRight)
        left = QVBoxLayout()
        left.addWidget(self.face_stack, 1)
        left.addWidget(self.privacy_label)  # under her face, while it is shown
        self.body.addLayout(left, 3)
        # the controls fit the kiosk's screens (1920×1080, 1080×1920) whole; only a smaller window scrolls
        self.side_panel = _SidePanel()
        self.side_panel.setWidget(side_box)
        self.side_panel.setWidgetResizable(True)
        self.side_panel.setFrameShape(QFrame.Shape.NoFrame)
        self.side_panel.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        self.body.addWidget(self.side_panel, 2)
        lay = QVBoxLayout(page)
        lay.addWidget(self.invite)
        lay.addWidget(self.looks_bar)
        lay.addLayout(self.body, 1)
        return page

    def _fit_screen(self) -> None:
        """Lay the try-on screen out for the window's shape: side by side when wide, stacked when tall."""
        portrait = self.height() > self.width()
        self.body.setDirection(QBoxLayout.Direction.TopToBottom if portrait else QBoxLayout.Direction.LeftToRight)
        self.body.setStretch(0, 1 if portrait else 3)
        self.body.setStretch(1, 0 if portrait else 2)

    def resizeEvent(self, event: QResizeEvent) -> None:  # noqa: N802
        """Follow the screen's orientation (a portrait kiosk stacks the controls under the face)."""
        super().resizeEvent(event)
        self._fit_screen()

    def _build_side(self) -> QWidget:
        """The side panel: the views, the products, the light, Before|After, Save Photo, the foundation finder."""
        products = self._build_products()
        lights = self._build_lights()
        self.split = QSlider(Qt.Orientation.Horizontal)
        self.split.setRange(0, 100)
        self.split.setMinimumHeight(BUTTON_PX)
        self.split.valueChanged.connect(self.guard(self._split_changed))
        self.snapshot_button = big_button("Save Photo", BUTTON_PX)
        self.snapshot_button.clicked.connect(self.guard(self.save_photo))
        self.done_button = big_button("Done", BUTTON_PX)
        self.done_button.clicked.connect(self.guard(self.show_start))
        self.toast = QLabel("")
        self._build_views_bar()
        self.privacy_label = QLabel(PRIVACY_LINE)
        self.privacy_label.setWordWrap(True)
        self.privacy_label.setStyleSheet("color: #b8b0a8; font-size: 14px;")
        self.privacy_label.hide()
        side_box = QWidget()
        side = QVBoxLayout(side_box)
        side.setContentsMargins(0, 0, 0, 0)
        side.addWidget(self.views_bar)
        side.addLayout(products)
        lights.insertWidget(0, QLabel("Light"))
        side.addLayout(lights)
        before_after = QHBoxLayout()
        before_after.addWidget(QLabel("Before"))
        before_after.addWidget(self.split, 1)
        before_after.addWidget(QLabel("After"))
        side.addLayout(before_after)
        self.foundation_finder = FoundationFinder(
            self.library, self.doc, lambda: self.tryon.shopper.face if self.tryon.shopper else self.face,
            self.refresh_products, self.guard, skin_source=self.tryon.her_skin)
        self.foundation_finder.found.connect(self.guard(self.tryon.preview_shades))
        side.addWidget(self.foundation_finder)
        side.addWidget(self.toast)
        last_row = QHBoxLayout()  # Save Photo and Done side by side: the finder's shades above stay on screen
        last_row.addWidget(self.snapshot_button)
        last_row.addWidget(self.done_button)
        side.addLayout(last_row)
        side.addStretch(1)
        # the head scan's licence (CC BY) asks for its credit wherever it is shown
        credit = self.doc.head.credit
        if credit:
            self.credit_label = QLabel(f"Head: {credit}")
            self.credit_label.setWordWrap(True)
            self.credit_label.setStyleSheet("color: #9a9a9a; font-size: 12px;")
            side.addWidget(self.credit_label)
        return side_box

    def _build_products(self) -> QGridLayout:
        """A row per category: ◀ the product on its layer ▶."""
        self.product_labels: dict[str, QLabel] = {}
        products = QGridLayout()
        for row, cat in enumerate(CATEGORIES):
            prev, nxt = big_button("◀", BUTTON_PX), big_button("▶", BUTTON_PX)
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
        return products

    def _build_lights(self) -> QHBoxLayout:
        """A button per light preset."""
        lights = QHBoxLayout()
        self.light_buttons: dict[str, QPushButton] = {}
        for name in LIGHT_PRESETS:
            b = big_button(name.title(), BUTTON_PX)
            b.setCheckable(True)
            b.clicked.connect(self.guard(lambda _c=False, n=name: self.set_light(n)))
            lights.addWidget(b)
            self.light_buttons[name] = b
        return lights

    def _build_views_bar(self) -> None:
        """Her face's views (mirror, turn and relight), hidden until she wears her face."""
        self.view_buttons: dict[str, QPushButton] = {}
        views = QHBoxLayout()
        for name, text in (("mirror", "Mirror"), ("relight", "Turn and relight")):
            b = big_button(text, BUTTON_PX)
            b.setCheckable(True)
            b.clicked.connect(self.guard(lambda _c=False, n=name: self.set_view(n)))
            views.addWidget(b)
            self.view_buttons[name] = b
        self.views_bar = QWidget()
        self.views_bar.setLayout(views)
        self.views_bar.hide()

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

    def fail(self, detail: str, message: str = FRIENDLY) -> None:
        """Log an error and return to the start screen with a friendly ``message``.

        ``detail`` is kept in ``last_error``; the shopper's session ends. An error in the attract mode
        itself stops it (no face turning on after a failure).
        """
        self.last_error = detail
        log.error("kiosk: %s", detail)
        broke_attract = self.attract
        self.show_start(attract=not broke_attract)
        self.start_message.setText(message)

    # ------------------------------------------------------------------ state
    def _camera_at_start(self) -> None:
        """Check the configured camera once, as the kiosk opens; say what is wrong, never fail.

        A camera that gives no pictures (unplugged since it was configured) is logged with its reason;
        with a watched folder "Try it on me" takes the photo from it (the camera is tried again at each
        try-on), without one the start screen says the camera is not working and offers no try-on.
        """
        from app.camera_source import camera_at_start

        works, why = camera_at_start(self.config.camera)
        watched = bool(self.config.watch_dir)
        self.tryon_button.setVisible(works or watched)
        self.camera_notice = QLabel(CAMERA_DOWN if why and not watched else "")
        self.camera_notice.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.camera_notice.setWordWrap(True)
        self.camera_notice.setStyleSheet("color: #e0b0a0; font-size: 18px;")
        self.camera_notice.setVisible(bool(self.camera_notice.text()))
        self.invite.layout().addWidget(self.camera_notice)
        if why and watched:
            log.warning("kiosk: %s; 'Try it on me' takes the photo from the watched folder %s",
                        why, self.config.watch_dir)
        elif why:
            log.error("kiosk: %s; 'Try it on me' is not offered", why)
        elif not works and not watched and self.config.camera_enabled:
            log.info("kiosk: no camera found (camera %r) and no watched folder: 'Try it on me' is not offered",
                     self.config.camera)

    def _prepare_looks(self, looks: list[KioskLook] | None, project: str | None) -> list[KioskLook]:
        """The kiosk's looks, each project's layers on the kiosk's head.

        ``looks`` as ``sheer kiosk`` checked them, or read from the configuration and ``project``; here a
        look that cannot be used is logged and left out (the built-in looks when none is left).
        """

        def refused(_look: KioskLook, message: str) -> None:
            log.error("kiosk: %s; the look is left out", message)
            self.last_error = message

        if looks is None:
            try:
                looks = kiosk_looks(self.config, project)
            except SheerError as exc:
                refused(builtin_look(""), str(exc))
                looks = [builtin_look(name) for name in DEFAULT_LOOKS]
        open_look_projects(looks, on_error=refused)
        install_look_projects(looks, self.stock_session, on_error=refused)
        return looks or [builtin_look(name) for name in DEFAULT_LOOKS]

    def _add_look_button(self, look: KioskLook, index: int = -1) -> None:
        """The look's button on the looks' bar (at ``index``; -1: last)."""
        b = big_button(look.label, BUTTON_PX)
        b.setCheckable(True)
        b.clicked.connect(self.guard(lambda _c=False, n=look.key: self.set_look(n)))
        self.looks_bar.layout().insertWidget(index, b)
        self.look_buttons[look.key] = b

    def _load(self, project: str | None = None) -> None:
        """Show the first look; with ``project``, that project becomes the first look (its button first).

        Raises:
            SheerError: the project cannot be used (the looks are unchanged then).
        """
        if project:
            look = KioskLook("", "", "--project", path=Path(project).absolute())
            open_look_projects([look])
            install_look_projects([look], self.stock_session)  # resampled: no dialogs in the kiosk
            old = next((i for i, k in enumerate(self.looks) if k.key == look.key), None)
            if old is None:
                self.looks.insert(0, look)
                self._add_look_button(look, 0)
            else:
                self.looks[old] = look
                self.look_buttons[look.key].setText(look.label)
            self.look_cache.pop(look.key, None)
            if self.session is not self.stock_session:
                getattr(self, "_stock_looks", {}).pop(look.key, None)
        self.set_look(self.looks[0].key)

    def _look_named(self, name: str) -> KioskLook:
        """The kiosk's look ``name`` (its key); a built-in look the kiosk does not list is taken too."""
        return next((k for k in self.looks if k.key == name), None) or builtin_look(name)

    def set_look(self, name: str) -> None:
        """Show the look ``name`` (a key of :attr:`looks`, or any built-in look) on the face shown.

        Painted (or carried onto her face) once, then replayed from a cache (instant in the attract mode).

        Raises:
            SheerError: an unknown look (the face is unchanged then).
        """
        cached = self.look_cache.get(name)
        if cached is None:
            self._paint_look(self._look_named(name))
            self.look_cache[name] = snapshot_layers(self.doc)
        else:
            replay_layers(self.doc, cached)
        self.doc.clear_history()
        self.look = name
        for n, b in self.look_buttons.items():
            b.setChecked(n == name)
        self.refresh_products()

    def _paint_look(self, look: KioskLook) -> None:
        """Put ``look`` on the document shown: a built-in look painted, a project's layers replayed.

        On her face a project's layers, painted on the kiosk's head, are carried onto her head
        (``painting.transfer``) from the kiosk's document, which is given them for the while.
        """
        if look.layers is None:
            self.session.apply_look(look.builtin)
            return
        if self.session is self.stock_session:
            replay_layers(self.doc, look.layers)
            return
        from painting.transfer import transfer_layers

        stock = self.stock_doc
        kept = snapshot_layers(stock)
        replay_layers(stock, look.layers)
        try:
            replay_layers(self.doc, [])
            transfer_layers(stock, self.doc)
        finally:
            replay_layers(stock, kept)

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
        self.refresh_products()

    def set_light(self, name: str) -> None:
        """Light the face with the preset ``name`` (a key of ``app.settings.LIGHT_PRESETS``).

        Her face turns to the relit view.
        """
        p = LIGHT_PRESETS[name]
        for n, b in self.light_buttons.items():
            b.setChecked(n == name)
        if self.tryon.active:
            self.tryon.set_light(p)
            self.show_view_buttons()
            return
        lt = self.viewport.lighting
        lt.azimuth, lt.elevation = p["azimuth"], p["elevation"]
        lt.colour, lt.intensity, lt.ambient = p["colour"], p["intensity"], p["ambient"]
        self.viewport.update()

    def _split_changed(self, v: int) -> None:
        if self.tryon.active:
            self.tryon.refresh(layers=False)
            return
        self.viewport.split = v / 100.0
        self.viewport.update()

    def _toggle_split(self) -> None:
        self.split.setValue(0 if self.split.value() else 50)

    def refresh_products(self) -> None:
        """Show each category's product on its label (the layers' materials), and on her face in the try-on."""
        for cat, label in self.product_labels.items():
            i = self._layer_for(cat)
            label.setText(self.doc.layers[i].material if i is not None else f"{cat.title()}: —")
        if self.tryon.active:
            self.tryon.refresh()

    #: What Save Photo says with her face on screen: the screen is a mirror, the photo is not.
    SAVED_AS_CAMERA = "Photo saved — as a camera sees you (the screen shows you as a mirror does)"

    def snapshot(self) -> Path:
        """Save Photo: a PNG in the configured snapshot folder; returns the file.

        With her face on screen, her made-up photograph at its own resolution as a camera shows her (not
        the mirrored screen, no before/after line; with the before/after slider on, the pair side by side
        too: :meth:`app.kiosk.tryon.TryOn.save_image`); else the sample head's view.

        Raises:
            OSError: the photo could not be written.
        """
        folder = Path(self.config.snapshot_dir)
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / f"sheer-{time.strftime('%Y%m%d-%H%M%S')}-{len(self.snapshots):03d}.png"
        if self.tryon.active:
            written = self.tryon.save_image(path)  # her photo, drawn anew: the one thing of hers that is written
        else:
            # encoded in memory, then written atomically: QImage.save to the file itself says it saved
            # a photo that a full disk cut short
            png = QByteArray()
            buffer = QBuffer(png)
            buffer.open(QIODevice.OpenModeFlag.WriteOnly)
            if not self.viewport.grabFramebuffer().save(buffer, "PNG"):
                raise OSError(f"{path}: the view could not be encoded as a PNG")
            atomic_write_bytes(path, png.data())
            written = [path]
        self.snapshots.extend(written)
        self.toast.setText(self.SAVED_AS_CAMERA if self.tryon.active else "Photo saved")
        return path

    def save_photo(self) -> Path | None:
        """The Save Photo button: :meth:`snapshot`; the file written, or None when it could not be written.

        A photo that cannot be written (``OSError``: a full disk, a folder the kiosk cannot write in)
        leaves her on her try-on screen with :data:`PHOTO_NOT_SAVED`, to try again or press Done; the
        reason goes to the log as one line and into ``last_error``. Any other error is the guard's.
        """
        try:
            return self.snapshot()
        except OSError as exc:
            reason = " ".join(str(exc).split())
            self.last_error = reason
            log.error("kiosk: Save Photo failed: %s", reason)
            self.toast.setText(PHOTO_NOT_SAVED)
            return None

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

    def show_start(self, attract: bool = True) -> None:
        """The start screen: the shopper's session ends (nothing of hers is kept).

        The face turns and the looks cycle under the invitation (``attract``).
        """
        self.end_private_session()
        self.stop_attract()
        try:
            self.reset_screen()
        except Exception:  # (an error that brought the start screen may break this too: log it, go on)
            log.exception("kiosk: the screen could not be reset for the next shopper")
        self.start_message.setText(INVITATION)
        self.invite.show()
        self.looks_bar.hide()
        self.side_panel.hide()
        self.stack.setCurrentWidget(self.main_page)
        if attract:
            self.attract = True
            self._attract_t0 = time.monotonic()
            self.viewport.lighting.intensity = self._fresh_lighting.intensity * ATTRACT_KEY_SCALE
            self.spin_timer.start()
            self.look_timer.start(int(self.config.look_seconds * 1000))
        self.viewport.update()

    def reset_screen(self) -> None:
        """Put every control back as a fresh kiosk shows it: nothing of one shopper reaches the next.

        The status line, the finder's shades, the light (none checked, the default key light), the
        before/after split, her views' buttons, the sample face's look (its swaps undone) and its view.
        """
        self.toast.setText("")
        self.foundation_finder.reset()
        for b in (*self.light_buttons.values(), *self.view_buttons.values()):
            b.setChecked(False)
        self.split.setValue(0)
        self.viewport.split = 0.0
        self.viewport.lighting = dataclasses.replace(self._fresh_lighting)
        self.viewport.frame_head()
        if not hasattr(self, "_opening_look"):  # (the first start screen: the look the kiosk opened with)
            self._opening_look = self.look
        self.set_look(self._opening_look)  # as a fresh kiosk opens: her look and product swaps undone

    def show_main(self) -> None:
        """Show the try-on screen (and count it as activity); a shopper's session uses a private cache."""
        if self.attract:  # the sample face comes to rest facing her, in the shop's default light
            self.viewport.frame_head()
            self.viewport.lighting.intensity = self._fresh_lighting.intensity
        self.begin_private_session()
        self.invite.hide()
        self.looks_bar.show()
        self.side_panel.show()
        self.stack.setCurrentWidget(self.main_page)
        self.viewport.update()
        self.activity()

    def activity(self, pos: QPoint | None = None) -> bool:
        """A touch, click or key: restart the idle timer; in the attract mode a touch starts the try-on screen.

        A press on "Try it on me" (``pos``, global pixels) is left to the button.

        Returns:
            True when this ended the attract mode (the event is then consumed).
        """
        woke = self.attract and pos is not None  # a key (an administrator's) does not start a try-on
        if woke:
            from PySide6.QtWidgets import QApplication

            under = QApplication.widgetAt(pos) if pos is not None else None
            if under is not None and (under is self.tryon_button or self.tryon_button.isAncestorOf(under)):
                woke = False
            else:
                self.show_main()
        self.idle_timer.start(int(self.config.idle_seconds * 1000))
        return woke

    def start_attract(self) -> None:
        """Idle: the shopper has gone; her session ends, the start screen turns the face.

        Not while the PIN pad is up.
        """
        if self.stack.currentWidget() is self.pin_pad:
            return
        self.show_start()

    def stop_attract(self) -> None:
        """End the attract mode (the screen stays as it is)."""
        self.attract = False
        self.spin_timer.stop()
        self.look_timer.stop()

    def attract_turn(self, t_s: float | None = None) -> float:
        """One step of the attract mode's sway: the camera at :func:`attract_yaw` of ``t_s``; returns the yaw.

        ``t_s``: seconds into the sway (None: since the attract mode started). The frame is a full-resolution
        one (a camera move, not an input: no low-resolution interactive frames in the attract mode).
        """
        t = time.monotonic() - self._attract_t0 if t_s is None else t_s
        cam = self.viewport.camera
        cam.yaw, cam.pitch = attract_yaw(t), 5.0
        self.viewport.update()
        return float(cam.yaw)

    def _next_attract_look(self) -> None:
        looks = [k.key for k in self.looks if k.in_attract] or [self.looks[0].key]
        i = (looks.index(self.look) + 1) % len(looks) if self.look in looks else 0
        self.set_look(looks[i])

    # ------------------------------------------------------------------ the way out
    def request_exit(self) -> None:
        """Every way out (close, Alt+F4, Esc, Ctrl+Q) ends here: the PIN pad; the right PIN closes the kiosk."""
        self.stop_attract()
        self._before_pin = self.stack.currentWidget()
        self.tryon.camera_page.stop()
        self.pin_pad.reset()
        self.stack.setCurrentWidget(self.pin_pad)

    def _pin_accepted(self) -> None:  # (a wrong PIN is logged and shown by the pad's guard)
        log.info("kiosk: exit with the administrator PIN")
        self.close_without_pin()

    def close_without_pin(self) -> None:
        """Close the kiosk now, as the administrator PIN does (the screenshots script)."""
        self._allow_close = True
        self.close()

    def _pin_cancelled(self) -> None:
        before = getattr(self, "_before_pin", None)
        if before is None or before is self.pin_pad or (before is self.main_page and not self.invite.isHidden()):
            self.show_start()
        elif before is self.tryon.camera_page:
            self.tryon.start()  # the preview was stopped for the PIN pad
        else:
            self.stack.setCurrentWidget(before)

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
        self.end_private_session()
        self.viewport.shutdown()
        event.accept()

    def keyPressEvent(self, event: QKeyEvent) -> None:  # noqa: N802
        """Esc, F4 and Ctrl+Q ask for the PIN; other keys as usual."""
        if event.key() in (Qt.Key.Key_Escape, Qt.Key.Key_F4) or (
                event.key() == Qt.Key.Key_Q and event.modifiers() & Qt.KeyboardModifier.ControlModifier):
            self.request_exit()
            return
        super().keyPressEvent(event)


def run_kiosk(config: KioskConfig, looks: list[KioskLook] | None = None, session: Session | None = None,
              windowed: bool = False) -> int:
    """Start the kiosk; never shows a traceback (errors are logged and shown as a friendly screen).

    ``sheer kiosk`` has checked the configuration, opened ``looks``' projects on ``session``'s head and
    opened the log (``app.commands.kiosk``); a look left None is read from ``config`` here.
    """
    import sys

    from app.application import make_application

    require_pin(config)  # before any window: a one-line message from the command line
    app = make_application()

    def hook(exc_type: type[BaseException], exc: BaseException, tb: TracebackType | None) -> None:
        log.error("uncaught error in the kiosk", exc_info=(exc_type, exc, tb))
        if win is not None:
            win.fail(str(exc))

    win: KioskWindow | None = None
    sys.excepthook = hook
    win = KioskWindow(config, session=session, looks=looks)
    if config.fullscreen and not windowed:
        win.show_full_screen()
    else:
        win.resize(1280, 800)
        win.show()
    return int(app.exec())
