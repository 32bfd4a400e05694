"""The brush bar's region picker: keep a stroke inside a facial region, keep it out of one, or fill one.

A :class:`RegionPicker` lists the head's regions (:attr:`painting.Document.regions`; those it lacks are
greyed out with the reason as a tooltip), a mode ("inside" or "avoid") and a **Fill** button that fills
the picked region of the selected layer to the material's default thickness with the region's soft
edge (:meth:`painting.Document.fill_region`, one undo step). The window asks :meth:`brush_options` for
the ``region``/``region_mode`` of each new :class:`painting.Brush`.

Its **Regions** menu is the Regions overlay: each region the head has can be ticked to outline it on the
face in its own colour (:class:`render.region_overlay.RegionOverlay`, drawn over every frame through the
viewport's ``after_frame`` hook once :meth:`RegionPicker.attach_overlay` has named the viewport). The
menu's button (:attr:`RegionPicker.overlay_button`) is not in the picker's row: the window places it
where a view's overlay belongs (the studio's view bar), which also keeps the brush bar narrow enough for
the studio's minimum width (:mod:`app.studio.toolbars`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from PySide6.QtCore import Signal
from PySide6.QtGui import QAction, QColor, QIcon, QPixmap
from PySide6.QtWidgets import QComboBox, QHBoxLayout, QMenu, QToolButton, QWidget

from painting.regions import REGION_NAMES

if TYPE_CHECKING:
    from app.view.viewport import Viewport
    from painting import Document
    from render.region_overlay import RegionOverlay

NO_REGION = "(any region)"


class RegionPicker(QWidget):
    """Region, mode and a Fill button for the brush bar (see the module docstring).

    Signals:
        fill_requested(str): the user asked to fill this region on the selected layer.
    """

    fill_requested = Signal(str)

    def __init__(self, doc: Document, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.doc = doc
        self.region_combo = QComboBox()
        self.region_combo.setToolTip("The facial region the brush keeps to (inside) or keeps out of (avoid)")
        self.mode_combo = QComboBox()
        self.mode_combo.addItems(["inside", "avoid"])
        self.mode_combo.setToolTip("inside: the stroke stays in the region (fading over its feather); "
                                   "avoid: the stroke never paints it")
        self.fill_button = QToolButton()  # a toolbar's button (a QPushButton is 80 px wide at least)
        self.fill_button.setText("Fill")
        self.fill_button.setToolTip("Fill the region on the selected layer (soft edge; one undo step)")
        self.overlay_button = QToolButton()  # placed by the window, not in this row (see the module doc)
        self.overlay_button.setText("Regions")
        self.overlay_button.setToolTip("Outline facial regions on the face (each in its colour)")
        self.overlay_button.setPopupMode(QToolButton.ToolButtonPopupMode.InstantPopup)
        self.overlay_menu = QMenu(self.overlay_button)
        self.overlay_button.setMenu(self.overlay_menu)
        #: region name → its overlay toggle (the regions this head has)
        self.overlay_actions: dict[str, QAction] = {}
        self._viewport: Viewport | None = None
        self._overlay: RegionOverlay | None = None
        self._overlay_for: Any = None  # the view renderer the overlay was built on
        self._overlay_stale = True  # the shown regions changed since they were uploaded
        self._watched: Any = None  # the QOpenGLContext whose destruction frees the overlay
        layout = QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        for w in (self.region_combo, self.mode_combo, self.fill_button):
            layout.addWidget(w)
        self.fill_button.clicked.connect(lambda: self.region and self.fill_requested.emit(self.region))
        self.region_combo.currentIndexChanged.connect(lambda _i: self._sync())
        self.refresh()

    def refresh(self) -> None:
        """List the document's head's regions again (e.g. after another head was opened)."""
        regions = self.doc.regions
        self.region_combo.blockSignals(True)
        self.region_combo.clear()
        self.region_combo.addItem(NO_REGION)
        model = self.region_combo.model()
        for name, what in REGION_NAMES.items():
            self.region_combo.addItem(name.replace("_", " "), name)
            i = self.region_combo.count() - 1
            if name in regions.regions:
                self.region_combo.setItemData(i, f"{what} — {regions.regions[name].source}", 3)  # ToolTipRole
            else:
                self.region_combo.setItemData(i, f"not on this head: {regions.missing.get(name, '')}", 3)
                item = model.item(i) if hasattr(model, "item") else None
                if item is not None:
                    item.setEnabled(False)
        self.region_combo.blockSignals(False)
        self._sync()
        self._refresh_overlay_menu()

    @property
    def region(self) -> str | None:
        """The picked region's name, or None."""
        data = self.region_combo.currentData()
        return str(data) if data else None

    def _sync(self) -> None:
        on = self.region is not None
        self.mode_combo.setEnabled(on)
        self.fill_button.setEnabled(on)

    def brush_options(self) -> dict[str, str | None]:
        """``region`` and ``region_mode`` for a :class:`painting.Brush`."""
        return {"region": self.region, "region_mode": self.mode_combo.currentText()}

    # ------------------------------------------------------------------ the Regions overlay
    def _refresh_overlay_menu(self) -> None:
        """One checkable entry per region of this head (ticks kept by name), then "Hide All"."""
        from render.region_overlay import region_colour

        shown = set(self.shown_regions())
        self.overlay_menu.clear()
        self.overlay_actions = {}
        for name in self.doc.regions.names():
            pm = QPixmap(12, 12)
            pm.fill(QColor(*(int(round(c * 255)) for c in region_colour(name))))
            act = self.overlay_menu.addAction(QIcon(pm), name.replace("_", " "))
            act.setCheckable(True)
            act.setChecked(name in shown)
            act.toggled.connect(lambda _on: self._overlay_changed())
            self.overlay_actions[name] = act
        self.overlay_menu.addSeparator()
        self.overlay_menu.addAction("Hide All", self.hide_overlay)
        self._overlay_changed()

    def shown_regions(self) -> list[str]:
        """The regions ticked in the overlay menu, in :data:`painting.regions.REGION_NAMES` order."""
        return [n for n, a in getattr(self, "overlay_actions", {}).items() if a.isChecked()]

    def show_regions(self, names: list[str]) -> None:
        """Tick exactly ``names`` in the overlay menu (names the head lacks are ignored)."""
        for n, a in self.overlay_actions.items():
            a.blockSignals(True)
            a.setChecked(n in names)
            a.blockSignals(False)
        self._overlay_changed()

    def hide_overlay(self) -> None:
        """Untick every region: no outlines."""
        self.show_regions([])

    def attach_overlay(self, viewport: Viewport) -> None:
        """Draw the ticked regions' outlines over ``viewport``'s frames (its ``after_frame`` hook)."""
        self._viewport = viewport
        self._overlay_changed()

    def _overlay_changed(self) -> None:
        self._overlay_stale = True
        shown = bool(self.shown_regions())
        self.overlay_button.setText(f"Regions ({len(self.shown_regions())})" if shown else "Regions")
        vp = self._viewport
        if vp is None:
            return
        vp.after_frame = self._draw_overlay if shown else None
        vp.update()

    def _draw_overlay(self, fbo: Any) -> None:
        """The viewport's after-frame hook (its GL context current, ``fbo`` its frame)."""
        vp = self._viewport
        view = None if vp is None else vp.renderer
        if vp is None or view is None or vp.ctx is None:
            return
        if self._overlay is None or self._overlay_for is not view:
            if self._overlay is not None and self._overlay.ctx is vp.ctx:
                self._overlay.release()  # another renderer on the same context (ours is current)
            self._overlay = view.region_overlay()
            self._overlay_for = view
            qctx = vp.context()
            if qctx is not None and qctx is not self._watched:  # freed with the viewport's GL
                qctx.aboutToBeDestroyed.connect(self._release_overlay)
                self._watched = qctx
            self._overlay_stale = True
        if self._overlay_stale:
            self._overlay.set_regions({n: self.doc.regions.get(n).mask for n in self.shown_regions()})
            self._overlay_stale = False
        w, h = vp.pixel_size()
        self._overlay.draw(fbo, (w, h), vp.camera.view_projection(w / max(h, 1)), vp.camera.view())

    def _release_overlay(self) -> None:
        """The viewport's GL context is going: free the overlay's GL objects (or drop them with it)."""
        overlay, self._overlay, self._overlay_for = self._overlay, None, None
        vp = self._viewport
        if overlay is None or vp is None or vp.ctx is None:
            return  # the GL context is gone: its objects went with it
        vp.makeCurrent()
        try:
            overlay.release()
        finally:
            vp.doneCurrent()
