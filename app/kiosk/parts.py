"""Parts of the kiosk window (:class:`app.kiosk.window.KioskWindow` mixes these in).

- :class:`KioskEngines`: the captured face configured for the lightweight engine, and the fall-back to it
  when the physical renderer is too slow (``engine: auto``).
- :class:`ShopperSession`: a shopper's session: the private folder it opens and removes, and her own
  face worn on the try-on screen in place of the sample head (:mod:`app.kiosk.tryon`).
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

    from app.session import Session
    from capture.face import Face
    from painting import Document

log = logging.getLogger("sheer.kiosk")


class KioskEngines:
    """The kiosk's renderers: physical (``render.Renderer``) or lightweight (a configured captured face)."""

    config: Any
    viewport: Any

    def setup_engines(self) -> None:
        """Start on the physical engine, load the configured captured face and watch the frame times.

        The window calls it once, its viewport made.
        """
        self.face: Face | None = None  # the configured captured face (the lightweight engine's)
        self.engine = "physical"  # the engine in use: physical | lightweight
        self._frame_samples: list[float] = []
        self._load_face()
        self.viewport.frame_drawn.connect(self._watch_frame_time)

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


class ShopperSession:
    """A shopper's session on the kiosk window: her private folder, and her face worn on the try-on screen."""

    stack: Any
    main_page: Any
    invite: Any
    tryon: Any
    private_cache: Any
    stock_session: Session
    session: Session
    doc: Document
    look: str
    look_cache: dict[str, Any]
    foundation_finder: Any
    look_buttons: dict[str, Any]
    light_buttons: dict[str, Any]
    view_buttons: dict[str, Any]
    face_stack: Any
    viewport: Any
    views_bar: Any
    privacy_label: Any
    credit_label: Any
    split: Any

    stop_attract: Callable[[], None]  # (KioskWindow's methods)
    show_main: Callable[[], None]
    refresh_products: Callable[[], None]

    def set_view(self, view: str) -> None:
        """Her face in the mirror view ("mirror": her photograph, its light) or relit ("relight")."""
        if view == "mirror":
            for b in self.light_buttons.values():
                b.setChecked(False)
            self.tryon.light = None
        self.tryon.set_view(view)
        self.show_view_buttons()

    def show_view_buttons(self) -> None:
        """Check the button of the view her face is shown in (mirror or relight)."""
        for n, b in self.view_buttons.items():
            b.setChecked(n == self.tryon.view)

    @property
    def screen_name(self) -> str:
        """The screen shown: "start" (attract mode, invitation), "tryon", "camera", "busy" or "pin"."""
        page = self.stack.currentWidget()
        if page is self.main_page:
            return "tryon" if self.invite.isHidden() else "start"
        return {id(self.tryon.camera_page): "camera", id(self.tryon.busy_page): "busy"}.get(id(page), "pin")

    @property
    def stock_doc(self) -> Document:
        """The sample head's (or the project's) document, whoever is on screen."""
        return self.stock_session.document

    def begin_private_session(self) -> Path:
        """A shopper's session starts (or goes on): the attract mode stops, her private folder opens."""
        self.stop_attract()
        return self.private_cache.open()

    def end_private_session(self) -> None:
        """Her session ends: her face, her document, the shades found for her and the private folder go."""
        self.tryon.end()
        self.unwear_shopper()
        self.foundation_finder.reset()  # on the sample face too: the next shopper is not shown hers
        self.private_cache.close()

    def wear_shopper(self, session: Session) -> None:
        """Show her face on the try-on screen: the controls act on her document from now on."""
        self._stock_looks, self.look_cache = self.look_cache, {}
        self.session, self.doc = session, session.document
        self.foundation_finder.doc = self.doc
        self.foundation_finder.reset()
        self.look = session.look or self.look
        for n, b in self.look_buttons.items():
            b.setChecked(n == self.look)
        for b in self.light_buttons.values():
            b.setChecked(False)  # her photograph's own light, until she picks a preset
        self.face_stack.setCurrentWidget(self.tryon.shopper_view)
        self.views_bar.show()
        self.privacy_label.show()
        if getattr(self, "credit_label", None) is not None:
            self.credit_label.hide()  # the sample head's credit, not hers
        self.show_view_buttons()
        self.split.setValue(0)
        self.show_main()
        self.refresh_products()

    def unwear_shopper(self) -> None:
        """Back to the sample face (or the project's)."""
        if self.session is self.stock_session:
            return
        self.session, self.doc = self.stock_session, self.stock_session.document
        self.look_cache = getattr(self, "_stock_looks", {})
        self.foundation_finder.doc = self.doc
        self.foundation_finder.reset()
        self.face_stack.setCurrentWidget(self.viewport)
        self.views_bar.hide()
        self.privacy_label.hide()
        if getattr(self, "credit_label", None) is not None:
            self.credit_label.show()
        self.refresh_products()
