"""The studio's main window: viewport, layers panel, material library dock, brush and view controls.

Data flows one way: widgets change :class:`app.settings.StudioSettings` and call :meth:`apply`, or send
commands to the document / library; the window subscribes to the document's change events and pushes
dirty tiles to the viewport.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PySide6.QtCore import QByteArray, QEvent, QObject, QSettings, QSize, Qt, QTimer
from PySide6.QtGui import QAction, QActionGroup, QCloseEvent, QGuiApplication, QKeySequence, QResizeEvent
from PySide6.QtWidgets import (
    QApplication,
    QDockWidget,
    QFileDialog,
    QFrame,
    QLabel,
    QMainWindow,
    QMenu,
    QScrollArea,
    QWidget,
)

from app.actions import MENU_ORDER, STUDIO_ACTIONS, is_enabled, shortcut_sheet
from app.session import BACKENDS
from app.settings import (
    APPLICATION,
    LIGHT_PRESETS,
    ORGANISATION,
    StudioSettings,
    load_settings,
    save_settings,
)
from app.studio import dialogs
from app.studio.catalogue_dialog import CatalogueDialog
from app.studio.export_actions import ExportActions
from app.studio.layers_panel import LayersPanel
from app.studio.library_dock import LibraryDock
from app.studio.new_from_photo import NewFromPhoto
from app.studio.project_files import ProjectFiles
from app.studio.shade_finder import ShadeFinder
from app.studio.toolbars import WINDOW_STATE_VERSION, StudioToolbars
from app.view.viewport import Viewport
from app.workers import run_task
from painting import Brush
from render.view import RENDER_MODES, debug_views

if TYPE_CHECKING:
    from collections.abc import Callable

    from app.session import Session
    from capture.face import Face
    from painting import ChangeEvent, Stroke

log = logging.getLogger("sheer.app")


class PanelScroll(QScrollArea):
    """A dock's panel that scrolls up and down: as wide as the panel needs, as short as the screen needs.

    The panel fills the dock when there is room; when there is not, it keeps its minimum height and
    scrolls. (QScrollArea's own resizing gives a panel with a wrapped label its preferred height,
    which stretched its lists and tables far past the dock.)
    """

    def __init__(self, panel: QWidget) -> None:
        super().__init__()
        self.setFrameShape(QFrame.Shape.NoFrame)
        self.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        self.setWidget(panel)
        panel.installEventFilter(self)

    def minimumSizeHint(self) -> QSize:  # noqa: N802 (Qt's name)
        """The panel's minimum width (and the scroll bar's), and a height of a few rows."""
        panel = self.widget()
        width = panel.minimumSizeHint().width() if panel is not None else 0
        return QSize(width + self.verticalScrollBar().sizeHint().width(), 120)

    def fit_panel(self) -> None:
        """Size the panel to the dock: its width, and its height unless the panel needs more."""
        panel, view = self.widget(), self.viewport()
        if panel is None:
            return
        least = panel.minimumSizeHint()
        width = max(view.width(), least.width())
        height = max(view.height(), least.height())
        layout = panel.layout()
        if layout is not None and layout.hasHeightForWidth():
            height = max(height, layout.minimumHeightForWidth(width))
        if panel.size() != QSize(width, height):
            panel.resize(width, height)

    def resizeEvent(self, event: QResizeEvent) -> None:  # noqa: N802 (Qt's name)
        """Fit the panel to the new size."""
        super().resizeEvent(event)
        self.fit_panel()

    def eventFilter(self, watched: QObject, event: QEvent) -> bool:  # noqa: N802 (Qt's name)
        """Fit the panel again when its layout changes (a row shown or hidden, a longer text)."""
        if watched is self.widget() and event.type() == QEvent.Type.LayoutRequest:
            QTimer.singleShot(0, self.fit_panel)
        return False


class StudioWindow(StudioToolbars, QMainWindow):
    """The studio's main window on a session's document and library.

    Args:
        session: the library and the document to paint (opened by :meth:`app.session.Session.open`).
        qsettings: where the settings and the window layout persist (default: the user's).

    Attributes:
        files: New, Open, Save, autosave and crash recovery (:class:`app.studio.project_files.ProjectFiles`).
        exports: exports and layer-map transfers (:class:`app.studio.export_actions.ExportActions`).
    """

    def __init__(self, session: Session, qsettings: QSettings | None = None) -> None:
        super().__init__()
        from app.view.viewport import preload_renderer_modules

        preload_renderer_modules()  # colour-science & co. import in a worker while the document is built
        self.qsettings = qsettings or QSettings(ORGANISATION, APPLICATION)
        self.settings: StudioSettings = load_settings(self.qsettings)
        self.library = session.library
        self.doc = session.document
        self._stroke: Stroke | None = None
        self.face_path: Path | None = None  # the captured face shown by the lightweight mode
        self.selected_layer = 0
        self.doc.subscribe(self._on_doc_event)

        self.viewport = Viewport(self.doc.head, self.doc.layout)
        self.viewport.set_document(self.doc)  # its binding queues the changes; draws layers' own materials
        self.setCentralWidget(self.viewport)
        self.viewport.stroke_begin.connect(self._stroke_begin)
        self.viewport.stroke_move.connect(self._stroke_move)
        self.viewport.stroke_end.connect(self._stroke_end)
        self.viewport.light_moved.connect(self._light_moved)
        self.viewport.renderer_ready.connect(self.apply)
        self.viewport.renderer_ready.connect(self._refresh_swatches)
        self.viewport.renderer_ready.connect(self._prepare_painting)
        self.viewport.surface_picked.connect(self._skin_picked)
        self.viewport.frame_drawn.connect(self._after_first_frame)
        self.viewport.gl_failed.connect(lambda msg: QTimer.singleShot(0, lambda: dialogs.error(self, "Viewport", msg)))

        self.files = ProjectFiles(self, session, self.viewport, self.settings)
        self.files.replaced.connect(self._project_replaced)
        self.files.changed.connect(self._update_actions)
        self.exports = ExportActions(self, session, self.viewport, self.settings)
        self.exports.map_imported.connect(self.refresh_layers)

        self.layers_panel = LayersPanel()
        self.layers_panel.set_materials(self.library)
        self._wire_layers_panel()
        self.layers_panel.attach_document(self.doc)  # the selected layer's mask (issue #16)
        skin = self._skin_colour()
        self.library_dock = LibraryDock(self.doc, skin)  # its edits are the document's (undoable, saved)
        self.library_dock.material_changed.connect(self._material_changed)
        self.library_dock.in_use = lambda name: any(lay.material == name for lay in self.doc.layers)
        layers_dock = self._add_dock("Layers", self.layers_panel, Qt.DockWidgetArea.LeftDockWidgetArea)
        library_dock = self._add_dock("Material Library", self.library_dock, Qt.DockWidgetArea.RightDockWidgetArea)
        self.resizeDocks([layers_dock, library_dock], [250, 380], Qt.Orientation.Horizontal)
        self.shade_finder = ShadeFinder(session, self._skin_colour, pick_on_face=self._arm_skin_pick)
        self.tabifyDockWidget(library_dock, self._add_dock("Shade Finder", self.shade_finder,
                                                           Qt.DockWidgetArea.RightDockWidgetArea))
        library_dock.raise_()

        self.actions_by_id: dict[str, QAction] = {}
        self._build_actions()
        self.build_toolbars()
        self.env_combo.currentTextChanged.connect(lambda _t: self.files.view_changed())  # saved in projects
        self.status = QLabel()
        self.statusBar().addPermanentWidget(self.status)
        self.frame_label = QLabel()
        self.statusBar().addWidget(self.frame_label)
        # the head scan's licence (CC BY) asks for its credit wherever it is shown
        self.credit_label = QLabel()
        self.credit_label.setStyleSheet("color: gray;")
        self.statusBar().addWidget(self.credit_label)
        # the frame time is shown twice a second: relabelling on every frame would make Qt recompose the
        # window each time (costly on a software rasteriser)
        self._frame_ms = 0.0
        self.viewport.frame_drawn.connect(lambda ms: setattr(self, "_frame_ms", ms))
        self._frame_timer = QTimer(self)
        self._frame_timer.setInterval(500)
        self._frame_timer.timeout.connect(self._show_frame_time)
        self._frame_timer.start()

        geo = self.qsettings.value("window/geometry")
        if not (isinstance(geo, QByteArray) and self.restoreGeometry(geo)):
            self.resize(1600, 1000)  # (fit_to_screen makes it smaller on a smaller screen)
        self.restore_layout()
        self.fit_to_screen()
        self.refresh_layers()
        self.apply()
        self.setWindowModified(False)
        QTimer.singleShot(0, self.files.offer_recovery)

    # ------------------------------------------------------------------ construction
    def _add_dock(self, title: str, widget: QWidget, area: Qt.DockWidgetArea) -> QDockWidget:
        """A dock holding ``widget`` in a :class:`PanelScroll`.

        A panel taller than the screen scrolls, so the window's minimum height is not the tallest panel's
        (the library's made it 978 px, taller than a laptop's screen).
        """
        dock = QDockWidget(title, self)
        dock.setObjectName(title.replace(" ", "_").lower())
        scroll = PanelScroll(widget)
        scroll.setObjectName(f"{dock.objectName()}_scroll")
        dock.setWidget(scroll)
        self.addDockWidget(area, dock)
        return dock

    def fit_to_screen(self) -> None:
        """Keep the window (its frame and title bar too) within its screen's available area.

        Centred there when it is not already inside: the first window, or one restored on a smaller screen.
        """
        screen = self.screen() or QGuiApplication.primaryScreen()
        if screen is None:
            return
        area = screen.availableGeometry()
        title = 32  # a window manager's title bar and borders (not known before the window is shown)
        w = min(self.width(), area.width() - 8)
        h = min(self.height(), area.height() - title - 8)
        self.resize(max(w, self.minimumSizeHint().width()), max(h, self.minimumSizeHint().height()))
        frame = self.frameGeometry()
        frame.setHeight(self.height() + title)
        if not area.contains(frame):
            self.move(area.x() + max((area.width() - self.width()) // 2, 0),
                      area.y() + max((area.height() - self.height() - title) // 2, 0))

    def context(self) -> dict[str, bool]:
        """The predicates actions are enabled by (``ActionSpec.enabled_when``), as they are now."""
        return {"has_layers": bool(self.doc.layers), "can_undo": self.doc.can_undo, "can_redo": self.doc.can_redo,
                "has_face": self.viewport.face is not None}

    def _build_actions(self) -> None:
        menus = {name: self.menuBar().addMenu(f"&{name}") for name in MENU_ORDER}
        handlers = {
            "file.new": lambda: self.files.offer_to_save() and self.files.new_project(),
            "file.open": lambda: self.files.offer_to_save() and self.files.open_project(),
            "file.new_from_photo": lambda: NewFromPhoto.ask_for(self),
            "file.save": self.files.save_project, "file.save_as": lambda: self.files.save_project(ask=True),
            "file.export_maps": self.exports.ask_export_maps,
            "file.export_maps_exr": lambda: self.exports.ask_export_maps("exr"),
            "file.export_image": self.exports.ask_export_image, "file.export_gltf": self.exports.ask_export_gltf,
            "file.export_ora": self.exports.ask_export_ora, "looks.gallery": lambda: self.looks.show_gallery(),
            "file.quit": self.close, "file.open_face": self.ask_open_face, "file.close_face": self.close_face,
            "file.render_catalogue": lambda: CatalogueDialog.open_for(self),
            "view.mode_fast": lambda: self.set_render_mode("fast"),
            "view.mode_reference": lambda: self.set_render_mode("reference"),
            "view.mode_lightweight": lambda: self.set_render_mode("lightweight"), "edit.undo": self.undo, "edit.redo": self.redo,
            "brush.smaller": lambda: self._brush(radius=1 / 1.2), "brush.larger": lambda: self._brush(radius=1.2),
            "brush.weaker": lambda: self._brush(strength=-0.1), "brush.stronger": lambda: self._brush(strength=0.1),
            "brush.eraser": lambda: self._mode("erase"), "brush.smooth": lambda: self._mode("smooth"),
            "brush.mirror": self._toggle_mirror, "view.frame": self.viewport.frame_head,
            "view.split": self._toggle_split, "view.reference": self._toggle_reference,
            "view.overlay": self._toggle_overlay, "help.shortcuts": self.show_shortcuts,
            "view.scale_50": lambda: self.change_settings(interactive_scale_cap=0.5),
            "view.scale_75": lambda: self.change_settings(interactive_scale_cap=0.75),
            "view.scale_100": lambda: self.change_settings(interactive_scale_cap=1.0),
            "help.about": self.show_about,
        }
        for spec in STUDIO_ACTIONS:
            act = QAction(spec.title, self)
            act.setObjectName(spec.id)
            if spec.shortcut:
                act.setShortcut(QKeySequence(spec.shortcut))
                act.setShortcutContext(Qt.ShortcutContext.WindowShortcut)
            act.setCheckable(spec.checkable)
            if spec.tip:
                act.setStatusTip(spec.tip)
            handler = handlers[spec.id]
            act.triggered.connect(lambda _checked=False, h=handler: h())
            menus[spec.menu].addAction(act)
            self.actions_by_id[spec.id] = act
        act = QAction("Save Self-&Contained…", self)
        act.setObjectName("file.save_self_contained")
        act.setStatusTip("Save a copy of the project with the head embedded (opens without the head file)")
        act.triggered.connect(lambda _checked=False: self.files.save_self_contained())
        self.actions_by_id["file.save_self_contained"] = act
        file_actions = menus["File"].actions()
        after = file_actions.index(self.actions_by_id["file.save_as"]) + 1
        if after < len(file_actions):
            menus["File"].insertAction(file_actions[after], act)
        else:
            menus["File"].addAction(act)
        self.recent_menu = QMenu("Recent &Projects", self)  # above Quit, as desktop applications list them
        menus["File"].insertMenu(self.actions_by_id["file.quit"], self.recent_menu)
        menus["File"].insertSeparator(self.actions_by_id["file.quit"])
        self.developer_actions = self._build_developer_menu(menus["View"])
        from app.studio.looks_menu import LooksMenu

        self.looks = LooksMenu(self, menus["Looks"])
        self._update_actions()

    def _build_developer_menu(self, view_menu: QMenu) -> list[QAction]:
        """View → Developer: the renderer's debug views (albedo, thickness…), one checked at a time."""
        menu = view_menu.addMenu("&Developer")
        menu.setToolTipsVisible(True)
        group = QActionGroup(self)
        acts = []
        for i, name in enumerate(debug_views()):
            act = menu.addAction("Debug View: None (the image)" if i == 0 else f"Debug View: {name}")
            act.setObjectName(f"view.debug_{name}")
            act.setCheckable(True)
            act.setActionGroup(group)
            act.triggered.connect(lambda _c=False, index=i: self.change_settings(debug_view=index))
            acts.append(act)
        return acts

    def _prepare_painting(self) -> None:
        """Load the bake's texel index and the brush kernels in the background.

        The first dab is then as quick as any; a failure here only means the first dab loads them itself.
        """
        import logging

        run_task(self, "Preparing the brush", lambda _p, _c: self.doc.prepare_painting(), lambda _r: None,
                 lambda msg: logging.getLogger("sheer.app").warning("preparing the brush: %s", msg),
                 show_progress=False)

    def _update_actions(self) -> None:
        ctx = self.context()
        for spec in STUDIO_ACTIONS:
            self.actions_by_id[spec.id].setEnabled(is_enabled(spec, ctx))
        self._update_undo()
        for i, act in enumerate(getattr(self, "developer_actions", [])):
            act.setChecked(i == self.settings.debug_view)
        s = self.settings
        for aid, on in (("brush.eraser", s.brush_mode == "erase"), ("brush.smooth", s.brush_mode == "smooth"),
                        ("brush.mirror", s.brush_mirror), ("view.split", s.split > 0),
                        ("view.reference", s.render_mode == "reference"), ("view.overlay", s.overlay),
                        ("view.mode_fast", s.render_mode == "fast"),
                        ("view.mode_reference", s.render_mode == "reference"),
                        ("view.mode_lightweight", s.render_mode == "lightweight"),
                        ("view.scale_50", s.interactive_scale_cap == 0.5),
                        ("view.scale_75", s.interactive_scale_cap == 0.75),
                        ("view.scale_100", s.interactive_scale_cap == 1.0)):
            self.actions_by_id[aid].setChecked(on)
        self.recent_menu.clear()
        for p in self.settings.recent_files:
            act = self.recent_menu.addAction(p)
            act.triggered.connect(lambda _c=False, path=p: self.files.offer_to_save()
                                  and self.files.open_project(Path(path), background=True))

    def _update_undo(self) -> None:
        """Edit → Undo and Redo: enabled when there is a step, named after it ("Undo stroke on Lipstick")."""
        for aid, verb, label, can in (("edit.undo", "&Undo", self.doc.history.undo_label, self.doc.can_undo),
                                      ("edit.redo", "&Redo", self.doc.history.redo_label, self.doc.can_redo)):
            act = self.actions_by_id[aid]
            act.setEnabled(can)
            act.setText(f"{verb} {label}" if label else verb)

    def _refresh_swatches(self) -> None:
        """Once km's colour maths is loaded (with the renderer): the real swatches replace the placeholders."""
        self.layers_panel.set_materials(self.library)
        self.layers_panel.refresh(self.doc.layers, self.library, self.selected_layer)
        self.library_dock.refresh_list()
        self.library_dock.update_views()

    def _after_first_frame(self, _ms: float) -> None:
        """Deferred start-up work, once the head is on screen."""
        self.viewport.frame_drawn.disconnect(self._after_first_frame)
        QTimer.singleShot(0, self.library_dock.build_plots)

    def _show_frame_time(self) -> None:
        text = f"frame {self._frame_ms:.1f} ms"
        if self.frame_label.text() != text:
            self.frame_label.setText(text)

    # ------------------------------------------------------------------ settings → everything
    def change_settings(self, **changes: object) -> None:
        """Set fields of :attr:`settings` (``app.settings.StudioSettings``) and :meth:`apply` them."""
        for k, v in changes.items():
            setattr(self.settings, k, v)
        self.apply()

    def apply(self) -> None:
        """Push the settings object to the widgets and the viewport (the one place that does)."""
        s = self.settings
        s.clamp()
        for w, value in ((self.radius_spin, s.brush_radius_mm), (self.strength_spin, s.brush_strength),
                         (self.hardness_spin, s.brush_hardness)):
            w.blockSignals(True)
            w.setValue(value)
            w.blockSignals(False)
        for combo, text in ((self.mode_combo, s.brush_mode), (self.light_combo, s.light_preset),
                            (self.env_combo, s.environment), (self.render_combo, s.render_mode)):
            combo.blockSignals(True)
            combo.setCurrentText(text)
            combo.blockSignals(False)
        self.mirror_check.blockSignals(True)
        self.mirror_check.setChecked(s.brush_mirror)
        self.mirror_check.blockSignals(False)
        self.split_slider.blockSignals(True)
        self.split_slider.setValue(int(round(s.split * 100)))
        self.split_slider.blockSignals(False)
        vp = self.viewport
        if s.render_mode == "lightweight" and vp.face is None:
            s.render_mode = "fast"  # (e.g. remembered from a session that had a captured face open)
            self.render_combo.blockSignals(True)
            self.render_combo.setCurrentText("fast")
            self.render_combo.blockSignals(False)
        preset = LIGHT_PRESETS[s.light_preset]
        vp.lighting.azimuth, vp.lighting.elevation = s.light_azimuth, s.light_elevation
        vp.lighting.colour = preset["colour"]
        vp.lighting.intensity = preset["intensity"]
        vp.lighting.ambient = self._ambient(preset["ambient"], s.environment)
        vp.split = s.split
        vp.debug = s.debug_view
        vp.mode = s.render_mode
        vp.debug_layer_index = self.selected_layer
        vp.brush_radius_units = s.brush_radius_mm / self.doc.head.mm_per_unit
        vp.set_overlay(s.overlay)
        vp.refine.set_cap(s.interactive_scale_cap)
        vp.environment = s.environment
        self._update_actions()
        credit = self.doc.head.credit
        self.credit_label.setText(f"Head: {credit}" if credit else "")
        self.status.setText(f"brush {s.brush_radius_mm:.1f} mm · strength {s.brush_strength:.2f} · "
                            f"{s.brush_mode}{' · mirror' if s.brush_mirror else ''}")
        vp.update()

    _env_cache: dict[str, tuple[float, float, float]] = {}

    def _ambient(self, base: tuple[float, float, float], env: str) -> tuple[float, float, float]:
        if env == "none":
            return base
        if env not in self._env_cache:
            try:
                import OpenEXR

                from core.assets import find_asset

                px = OpenEXR.File(str(find_asset(f"environments/{env}.exr"))).channels()["RGB"].pixels
                mean = np.asarray(px, np.float32).reshape(-1, 3).mean(axis=0)
                mean = mean / max(float(mean.max()), 1e-6) * 0.45
                self._env_cache[env] = (float(mean[0]), float(mean[1]), float(mean[2]))
            except Exception as exc:
                dialogs.error(self, "Environment", f"The HDR environment '{env}' could not be read: {exc}")
                self.settings.environment = "none"
                return base
        return self._env_cache[env]

    def use_light_preset(self, name: str) -> None:
        """Light the head with the preset ``name`` (a key of ``app.settings.LIGHT_PRESETS``; daylight if unknown)."""
        p = LIGHT_PRESETS.get(name, LIGHT_PRESETS["daylight"])
        self.change_settings(light_preset=name, light_azimuth=p["azimuth"], light_elevation=p["elevation"])
        self.files.view_changed()  # the lights are saved with the project

    def _light_moved(self, az: float, el: float) -> None:
        self.settings.light_azimuth, self.settings.light_elevation = az, el
        self.files.view_changed()  # the key light is saved with the project

    def _brush(self, radius: float = 1.0, strength: float = 0.0) -> None:
        self.change_settings(brush_radius_mm=self.settings.brush_radius_mm * radius,
                  brush_strength=round(self.settings.brush_strength + strength, 2))

    def _mode(self, mode: str) -> None:
        self.change_settings(brush_mode="add" if self.settings.brush_mode == mode else mode)

    def _toggle_mirror(self) -> None:
        self.change_settings(brush_mirror=not self.settings.brush_mirror)

    def _toggle_split(self) -> None:
        self.change_settings(split=0.0 if self.settings.split > 0 else 0.5)

    def set_render_mode(self, mode: str) -> None:
        """Fast | reference | lightweight; the lightweight mode without a captured face asks for one."""
        if mode not in RENDER_MODES:
            return
        if mode == "lightweight" and self.viewport.face is None:
            self.apply()  # the widgets show the mode in use until a face is open
            self.ask_open_face()
            return
        self.change_settings(render_mode=mode)

    def ask_open_face(self) -> None:
        """File → Open Captured Face…: a face folder written by ``sheer capture`` (for this head)."""
        folder = QFileDialog.getExistingDirectory(self, "Open a captured face folder")
        if folder:
            self.open_face(Path(folder))

    def open_face(self, folder: Path, on_done: Callable[[Face], None] | None = None) -> None:
        """Read a captured face in a worker, then show it in the lightweight mode."""
        from capture.face import load_face

        def done(face: Face) -> None:
            self.viewport.face = face
            self.face_path = Path(folder)
            self.change_settings(render_mode="lightweight")
            self._update_actions()
            self.statusBar().showMessage(f"Captured face: {folder} (lightweight mode)", 6000)
            if on_done is not None:
                on_done(face)

        run_task(self, "Opening the captured face", lambda p, c: load_face(folder), done,
                 lambda m: dialogs.error(self, "Open captured face", f"The face could not be opened: {m}"))

    def close_face(self) -> None:
        """File → Close Captured Face: forget the face; the lightweight mode gives way to the fast one."""
        if self.viewport.face is None:
            return
        self.viewport.face = None
        self.face_path = None
        if self.settings.render_mode == "lightweight":
            self.change_settings(render_mode="fast")
        else:
            self._update_actions()
            self.viewport.update()
        self.statusBar().showMessage("Captured face closed", 4000)

    def _toggle_reference(self) -> None:
        self.change_settings(render_mode="fast" if self.settings.render_mode == "reference" else "reference")

    def _toggle_overlay(self) -> None:
        self.change_settings(overlay=not self.settings.overlay)

    # ------------------------------------------------------------------ document
    def _arm_skin_pick(self) -> None:
        """The next left click on the face picks the Shade Finder's skin (no stroke)."""
        vp = self.viewport
        vp.pick_next = True
        vp.surface.setCursor(Qt.CursorShape.CrossCursor)

    def _skin_picked(self, point: object) -> None:
        """Match the head's colour where the user clicked (the albedo's median around the point)."""
        from painting.hit import albedo_colour_at

        colour = albedo_colour_at(self.doc, self.doc.head, point)
        self.shade_finder.match_linear(colour, "the skin picked on the face")

    def _skin_colour(self) -> tuple[float, float, float]:
        r, g, b = self.doc.head.skin_rgb()
        return (float(r), float(g), float(b))

    def _on_doc_event(self, event: ChangeEvent) -> None:
        if event.kind == "history":
            if self._stroke is None:  # (a stroke's own steps: its end updates the menus)
                self._update_undo()
            return
        if event.kind == "paint":
            # every dab: the viewport's binding queues its tiles itself (menus and undo state change at
            # the stroke's end, which updates them; undo/redo update them themselves)
            if self._stroke is None:
                self._update_actions()
        else:
            self.refresh_layers()
            self._update_actions()

    def refresh_layers(self) -> None:
        """Show the document's layers in the panel (selection clamped) and have the viewport reload them."""
        n = len(self.doc.layers)
        self.selected_layer = min(max(self.selected_layer, 0), max(n - 1, 0))
        self.layers_panel.refresh(self.doc.layers, self.library, self.selected_layer)
        self.viewport.debug_layer_index = self.selected_layer
        self.viewport.reload_layers()  # e.g. a library material was edited: no document event says so

    def _wire_layers_panel(self) -> None:
        p = self.layers_panel
        p.add_requested.connect(self.add_layer)
        p.remove_requested.connect(lambda i: self.layer_command(lambda: self.doc.remove_layer(i)))
        p.move_requested.connect(self.move_layer)
        p.rename_requested.connect(lambda i, n: self.layer_command(lambda: self.doc.set_layer(i, name=n)))
        p.visibility_requested.connect(lambda i, v: self.layer_command(lambda: self.doc.set_layer(i, visible=v)))
        p.opacity_requested.connect(lambda i, v: self.layer_command(lambda: self.doc.set_layer(i, opacity=v)))
        p.max_thickness_requested.connect(
            lambda i, v: self.layer_command(lambda: self.doc.set_layer(i, max_thickness=v)))
        p.material_requested.connect(lambda i, m: self.layer_command(lambda: self.doc.set_layer(i, material=m)))
        p.selection_changed.connect(self._select_layer)
        p.import_requested.connect(self.exports.ask_import_map)
        p.export_requested.connect(self.exports.ask_export_map)

    def _select_layer(self, index: int) -> None:
        if index >= 0:
            self.selected_layer = index
            self.viewport.debug_layer_index = index  # the thickness view shows the selected layer
            self.viewport.update()

    def layer_command(self, fn: Callable[[], object]) -> None:
        """Run the document edit ``fn``; one the document refuses is shown in a dialog, not raised."""
        from core.errors import SheerError

        try:
            fn()
        except (SheerError, ValueError, IndexError) as exc:
            dialogs.error(self, "Layers", str(exc))

    def add_layer(self, material: str) -> None:
        """Add a layer of library material ``material`` on top (its maximum thickness) and select it."""
        if material not in self.library:
            dialogs.error(self, "Add layer", f"Pick a material from the library first ('{material}' is unknown).")
            return
        m = self.library.get(material)
        self.selected_layer = len(self.doc.layers)
        self.layer_command(lambda: self.doc.add_layer(material, name=material,
                                                   max_thickness=float(m.max_thickness_um)))

    def add_look(self, name: str) -> bool:
        """Looks → a built-in look: its layers on top of the document's, painted by its strokes, as one undo step.

        The top one is selected. Returns whether it was added (a look that cannot be painted is a message).
        """
        from core.errors import SheerError
        from painting.looks import apply_look

        QApplication.setOverrideCursor(Qt.CursorShape.WaitCursor)
        try:
            with self.doc.grouped(f"look {name}"):
                added = apply_look(self.doc, name, clear=False)
        except SheerError as exc:
            dialogs.error(self, "Add look", f"The look '{name}' could not be added: {exc}")
            return False
        finally:
            QApplication.restoreOverrideCursor()
        self.selected_layer = len(self.doc.layers) - 1
        self.refresh_layers()
        self._update_actions()
        self.statusBar().showMessage(f"Added the look '{name}' ({len(added)} layers); Ctrl+Z takes it off.", 6000)
        return True

    def move_layer(self, src: int, dst: int) -> None:
        """Move the layer at document index ``src`` to ``dst`` (0 = bottom) and select it."""
        self.selected_layer = dst
        self.layer_command(lambda: self.doc.move_layer(src, dst))

    def undo(self) -> None:
        """Undo the last document edit (a stroke or a layer change)."""
        self.doc.undo()
        self._update_actions()

    def redo(self) -> None:
        """Redo the last undone document edit."""
        self.doc.redo()
        self._update_actions()

    # ------------------------------------------------------------------ painting
    def _stroke_begin(self, point: np.ndarray, pressure: float) -> None:
        if not self.doc.layers:
            self.statusBar().showMessage("Add a layer to paint on (Layers panel).", 4000)
            return
        lay = self.doc.layers[self.selected_layer]
        if not lay.visible:
            self.statusBar().showMessage(f"Layer '{lay.name}' is hidden.", 4000)
            return
        s = self.settings
        brush = Brush(radius_mm=float(s.brush_radius_mm), hardness=float(s.brush_hardness),
                      strength=float(s.brush_strength), mode=s.brush_mode, mirror=bool(s.brush_mirror),
                      **self.region_picker.brush_options())
        target = self.doc.mask_stroke if self.layers_panel.paint_mask else self.doc.stroke  # (issue #16)
        self._stroke = target(lay, brush).__enter__()
        self._stroke_move(point, pressure)

    def _stroke_move(self, point: np.ndarray, pressure: float) -> None:
        if self._stroke is not None:
            self._stroke.dab(point, pressure)

    def _stroke_end(self) -> None:
        if self._stroke is not None:
            stroke, self._stroke = self._stroke, None
            stroke.__exit__(None, None, None)
            self._update_actions()

    # ------------------------------------------------------------------ materials
    def _material_changed(self, name: str | None) -> None:
        self.layers_panel.set_materials(self.library)
        self.refresh_layers()
        self.apply()

    # ------------------------------------------------------------------ projects
    def _project_replaced(self) -> None:
        """A project was opened or recovered: its layers, materials and view settings are now shown."""
        self.layers_panel.set_materials(self.library)
        self.library_dock.refresh_list()
        self.refresh_layers()
        self.apply()

    # ------------------------------------------------------------------ help
    def show_about(self) -> None:
        """Help → About: the credits, the components in use, the viewport's GL context, Copy diagnostics."""
        from app.diagnostics import live_gl_lines, studio_report
        from core.assets import ASSET_CREDITS

        live = live_gl_lines(self.viewport)  # the viewport's own context; the rest is built in a worker
        dialogs.about(self, self.doc.head.credit or "", list(ASSET_CREDITS.values()), BACKENDS,
                      gl=live[0].text, diagnostics=lambda: studio_report(live).text())

    def show_shortcuts(self) -> None:
        """Help → Keyboard Shortcuts."""
        dialogs.shortcuts(self, shortcut_sheet())

    # ------------------------------------------------------------------ close
    def closeEvent(self, event: QCloseEvent) -> None:
        """Offer to save unsaved changes (Cancel keeps the window), then save the settings and layout and release GL."""
        self._stroke_end()
        if not self.files.offer_to_save() or not self.library_dock.offer_to_save():
            event.ignore()
            return
        self.files.close()
        save_settings(self.qsettings, self.settings)
        self.qsettings.setValue("window/geometry", self.saveGeometry())
        self.qsettings.setValue("window/state", self.saveState(WINDOW_STATE_VERSION))
        self.qsettings.sync()
        from app.workers import wait_all

        wait_all(20000)
        self.viewport.shutdown()
        event.accept()
