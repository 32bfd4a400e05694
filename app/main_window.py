"""The studio's main window: viewport, layers panel, material library dock, brush and view controls.

Data flows one way: widgets change :class:`app.settings.StudioSettings` and call :meth:`apply`, or send
commands to the document / library; the window subscribes to the document's change events and pushes
dirty tiles to the viewport.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np
from PySide6.QtCore import QByteArray, QSettings, Qt, QTimer
from PySide6.QtGui import QAction, QCloseEvent, QKeySequence
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDialog,
    QDialogButtonBox,
    QDockWidget,
    QDoubleSpinBox,
    QFileDialog,
    QInputDialog,
    QLabel,
    QMainWindow,
    QSlider,
    QTableWidget,
    QTableWidgetItem,
    QToolBar,
    QVBoxLayout,
    QWidget,
)

from app import dialogs, seams
from app.actions import MENU_ORDER, STUDIO_ACTIONS, is_enabled, shortcut_sheet
from app.export import export_gltf, export_maps, render_image
from app.layers_panel import LayersPanel
from app.library_dock import LibraryDock
from app.render_adapter import RENDER_MODES, debug_views, layer_inputs
from app.settings import (
    APPLICATION,
    ENVIRONMENTS,
    LIGHT_PRESETS,
    ORGANISATION,
    StudioSettings,
    load_settings,
    save_settings,
)
from app.viewport import Viewport
from app.workers import run_task

log = logging.getLogger("sheer.app")


class StudioWindow(QMainWindow):
    def __init__(self, head_path: str | Path | None = None, look: str = "natural", resolution: int | None = None,
                 qsettings: QSettings | None = None, document: Any = None, library: Any = None) -> None:
        super().__init__()
        from app.viewport import preload_renderer_modules

        preload_renderer_modules()  # colour-science & co. import in a worker while the document is built
        self.qsettings = qsettings or QSettings(ORGANISATION, APPLICATION)
        self.settings: StudioSettings = load_settings(self.qsettings)
        self.library = library if library is not None else seams.load_library()
        if document is None:
            from app.studio_app import DEFAULT_RESOLUTION

            document = seams.open_document(head_path, resolution or DEFAULT_RESOLUTION, self.library)
        self.doc = document
        self.project_path: Path | None = None
        self.project_name = "Untitled"
        self.project: Any = None  # the project.io.Project last opened or saved (the base of the next save)
        self.look_record: dict[str, Any] | None = {"name": look, "tags": []} if look else None
        self._stroke: Any = None
        self.face_path: Path | None = None  # the captured face shown by the lightweight mode
        self._stroke_cm: Any = None
        self.selected_layer = 0
        if look:
            seams.apply_look(self.doc, self.library, look)
            self.doc.clear_history()
        self.doc.subscribe(self._on_doc_event)

        self.viewport = Viewport(self.doc.head, getattr(self.doc, "layout", None))
        self.viewport.layers_source = lambda: layer_inputs(self.doc, self.library)
        self.setCentralWidget(self.viewport)
        self.viewport.stroke_begin.connect(self._stroke_begin)
        self.viewport.stroke_move.connect(self._stroke_move)
        self.viewport.stroke_end.connect(self._stroke_end)
        self.viewport.light_moved.connect(self._light_moved)
        self.viewport.renderer_ready.connect(self.apply)
        self.viewport.renderer_ready.connect(self._refresh_swatches)
        self.viewport.frame_drawn.connect(self._after_first_frame)
        self.viewport.gl_failed.connect(lambda msg: QTimer.singleShot(0, lambda: dialogs.error(self, "Viewport", msg)))

        self.layers_panel = LayersPanel()
        self.layers_panel.set_materials(self.library)
        self._wire_layers_panel()
        skin = self._skin_colour()
        self.library_dock = LibraryDock(self.library, skin)
        self.library_dock.material_changed.connect(self._material_changed)
        self.library_dock.in_use = lambda name: any(lay.material == name for lay in self.doc.layers)
        layers_dock = self._add_dock("Layers", self.layers_panel, Qt.DockWidgetArea.LeftDockWidgetArea)
        library_dock = self._add_dock("Material Library", self.library_dock, Qt.DockWidgetArea.RightDockWidgetArea)
        self.resizeDocks([layers_dock, library_dock], [250, 380], Qt.Orientation.Horizontal)

        self.actions_by_id: dict[str, QAction] = {}
        self._build_actions()
        self._build_toolbars()
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
        if isinstance(geo, QByteArray):
            self.restoreGeometry(geo)
        else:
            self.resize(1280, 800)
        state = self.qsettings.value("window/state")
        if isinstance(state, QByteArray):
            self.restoreState(state)
        self.refresh_layers()
        self.apply()
        self.setWindowModified(False)
        self._update_title()
        from app import project_io

        self.autosaver = project_io.make_autosaver(self._snapshot, None, self.settings.autosave_minutes * 60.0)
        self.autosave_timer = QTimer(self)
        self.autosave_timer.setInterval(10_000)
        self.autosave_timer.timeout.connect(self._autosave_tick)
        if self.autosaver is not None:
            self.autosave_timer.start()
        QTimer.singleShot(0, self.offer_recovery)

    # ------------------------------------------------------------------ construction
    def _add_dock(self, title: str, widget: QWidget, area: Qt.DockWidgetArea) -> QDockWidget:
        dock = QDockWidget(title, self)
        dock.setObjectName(title.replace(" ", "_").lower())
        dock.setWidget(widget)
        self.addDockWidget(area, dock)
        return dock

    def context(self) -> dict[str, bool]:
        return {"has_layers": bool(self.doc.layers), "can_undo": bool(self.doc.can_undo),
                "can_redo": bool(self.doc.can_redo), "has_project_io": seams_has_project_io()}

    def _build_actions(self) -> None:
        menus = {name: self.menuBar().addMenu(f"&{name}") for name in MENU_ORDER}
        handlers = {
            "file.new": self.new_project, "file.open": self.open_project, "file.save": self.save_project,
            "file.save_as": lambda: self.save_project(ask=True), "file.export_maps": self.ask_export_maps,
            "file.export_maps_exr": lambda: self.ask_export_maps("exr"),
            "file.export_image": self.ask_export_image, "file.export_gltf": self.ask_export_gltf,
            "file.quit": self.close, "file.open_face": self.ask_open_face,
            "view.mode_fast": lambda: self.set_render_mode("fast"),
            "view.mode_reference": lambda: self.set_render_mode("reference"),
            "view.mode_lightweight": lambda: self.set_render_mode("lightweight"), "edit.undo": self.undo, "edit.redo": self.redo,
            "brush.smaller": lambda: self._brush(radius=1 / 1.2), "brush.larger": lambda: self._brush(radius=1.2),
            "brush.weaker": lambda: self._brush(strength=-0.1), "brush.stronger": lambda: self._brush(strength=0.1),
            "brush.eraser": lambda: self._mode("erase"), "brush.smooth": lambda: self._mode("smooth"),
            "brush.mirror": self._toggle_mirror, "view.frame": self.viewport.frame_head,
            "view.split": self._toggle_split, "view.reference": self._toggle_reference,
            "view.overlay": self._toggle_overlay, "help.shortcuts": self.show_shortcuts,
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
        act.triggered.connect(lambda _checked=False: self.save_self_contained())
        self.actions_by_id["file.save_self_contained"] = act
        file_actions = menus["File"].actions()
        after = file_actions.index(self.actions_by_id["file.save_as"]) + 1
        if after < len(file_actions):
            menus["File"].insertAction(file_actions[after], act)
        else:
            menus["File"].addAction(act)
        self.recent_menu = menus["File"].addMenu("Recent Projects")
        self._update_actions()

    def _update_actions(self) -> None:
        ctx = self.context()
        for spec in STUDIO_ACTIONS:
            self.actions_by_id[spec.id].setEnabled(is_enabled(spec, ctx))
        if "file.save_self_contained" in self.actions_by_id:
            self.actions_by_id["file.save_self_contained"].setEnabled(ctx["has_project_io"])
        s = self.settings
        for aid, on in (("brush.eraser", s.brush_mode == "erase"), ("brush.smooth", s.brush_mode == "smooth"),
                        ("brush.mirror", s.brush_mirror), ("view.split", s.split > 0),
                        ("view.reference", s.render_mode == "reference"), ("view.overlay", s.overlay),
                        ("view.mode_fast", s.render_mode == "fast"),
                        ("view.mode_reference", s.render_mode == "reference"),
                        ("view.mode_lightweight", s.render_mode == "lightweight")):
            self.actions_by_id[aid].setChecked(on)
        self.recent_menu.clear()
        for p in self.settings.recent_files:
            act = self.recent_menu.addAction(p)
            act.triggered.connect(lambda _c=False, path=p: self.open_project(Path(path), background=True))

    def _build_toolbars(self) -> None:
        tb = QToolBar("Brush")
        tb.setObjectName("brush_toolbar")
        self.addToolBar(tb)
        self.radius_spin = QDoubleSpinBox()
        self.radius_spin.setRange(0.5, 100.0)
        self.radius_spin.setSuffix(" mm")
        self.strength_spin = QDoubleSpinBox()
        self.strength_spin.setRange(0.05, 1.0)
        self.strength_spin.setSingleStep(0.05)
        self.hardness_spin = QDoubleSpinBox()
        self.hardness_spin.setRange(0.0, 0.95)
        self.hardness_spin.setSingleStep(0.05)
        self.mode_combo = QComboBox()
        self.mode_combo.addItems(["add", "erase", "smooth"])
        self.mirror_check = QCheckBox("Mirror")
        for label, w in (("Radius", self.radius_spin), ("Strength", self.strength_spin),
                         ("Hardness", self.hardness_spin), ("Mode", self.mode_combo)):
            tb.addWidget(QLabel(f" {label} "))
            tb.addWidget(w)
        tb.addWidget(self.mirror_check)
        self.radius_spin.valueChanged.connect(lambda v: self._set(brush_radius_mm=float(v)))
        self.strength_spin.valueChanged.connect(lambda v: self._set(brush_strength=float(v)))
        self.hardness_spin.valueChanged.connect(lambda v: self._set(brush_hardness=float(v)))
        self.mode_combo.currentTextChanged.connect(lambda t: self._set(brush_mode=t))
        self.mirror_check.toggled.connect(lambda on: self._set(brush_mirror=bool(on)))
        vb = QToolBar("View")
        vb.setObjectName("view_toolbar")
        self.addToolBar(vb)
        self.light_combo = QComboBox()
        self.light_combo.addItems(list(LIGHT_PRESETS))
        self.env_combo = QComboBox()
        self.env_combo.addItems(list(ENVIRONMENTS))
        self.render_combo = QComboBox()
        self.render_combo.addItems(list(RENDER_MODES))
        self.debug_combo = QComboBox()
        self.debug_combo.addItems(debug_views())
        self.split_slider = QSlider(Qt.Orientation.Horizontal)
        self.split_slider.setRange(0, 100)
        self.split_slider.setMaximumWidth(140)
        for label, w in (("Light", self.light_combo), ("HDR", self.env_combo), ("Mode", self.render_combo),
                         ("View", self.debug_combo), ("Before|After", self.split_slider)):
            vb.addWidget(QLabel(f" {label} "))
            vb.addWidget(w)
        self.light_combo.currentTextChanged.connect(self._light_preset)
        self.env_combo.currentTextChanged.connect(lambda t: self._set(environment=t))
        self.render_combo.currentTextChanged.connect(self.set_render_mode)
        self.debug_combo.currentIndexChanged.connect(lambda i: self._set(debug_view=int(i)))
        self.split_slider.valueChanged.connect(lambda v: self._set(split=v / 100.0))

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
    def _set(self, **changes: Any) -> None:
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
        self.debug_combo.blockSignals(True)
        self.debug_combo.setCurrentIndex(s.debug_view)
        self.debug_combo.blockSignals(False)
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
        vp.environment = s.environment
        self._update_actions()
        credit = getattr(self.doc.head, "credit", None)
        self.credit_label.setText(f"Head: {credit}" if credit else "")
        self.status.setText(f"brush {s.brush_radius_mm:.1f} mm · strength {s.brush_strength:.2f} · "
                            f"{s.brush_mode}{' · mirror' if s.brush_mirror else ''} · renderer: "
                            f"{seams.backends().get('renderer', '…')}")
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

    def _light_preset(self, name: str) -> None:
        p = LIGHT_PRESETS.get(name, LIGHT_PRESETS["daylight"])
        self._set(light_preset=name, light_azimuth=p["azimuth"], light_elevation=p["elevation"])

    def _light_moved(self, az: float, el: float) -> None:
        self.settings.light_azimuth, self.settings.light_elevation = az, el

    def _brush(self, radius: float = 1.0, strength: float = 0.0) -> None:
        self._set(brush_radius_mm=self.settings.brush_radius_mm * radius,
                  brush_strength=round(self.settings.brush_strength + strength, 2))

    def _mode(self, mode: str) -> None:
        self._set(brush_mode="add" if self.settings.brush_mode == mode else mode)

    def _toggle_mirror(self) -> None:
        self._set(brush_mirror=not self.settings.brush_mirror)

    def _toggle_split(self) -> None:
        self._set(split=0.0 if self.settings.split > 0 else 0.5)

    def set_render_mode(self, mode: str) -> None:
        """Fast | reference | lightweight; the lightweight mode without a captured face asks for one."""
        if mode not in RENDER_MODES:
            return
        if mode == "lightweight" and self.viewport.face is None:
            self.apply()  # the widgets show the mode in use until a face is open
            self.ask_open_face()
            return
        self._set(render_mode=mode)

    def ask_open_face(self) -> None:
        """File → Open Captured Face…: a face folder written by ``sheer capture`` (for this head)."""
        folder = QFileDialog.getExistingDirectory(self, "Open a captured face folder")
        if folder:
            self.open_face(Path(folder))

    def open_face(self, folder: Path, on_done: Any = None) -> None:
        """Read a captured face in a worker, then show it in the lightweight mode."""
        from capture.pipeline import load_face

        def done(face: Any) -> None:
            self.viewport.face = face
            self.face_path = Path(folder)
            self._set(render_mode="lightweight")
            self.statusBar().showMessage(f"Captured face: {folder} (lightweight mode)", 6000)
            if on_done is not None:
                on_done(face)

        run_task(self, "Opening the captured face", lambda p, c: load_face(folder), done,
                 lambda m: dialogs.error(self, "Open captured face", f"The face could not be opened: {m}"))

    def _toggle_reference(self) -> None:
        self._set(render_mode="fast" if self.settings.render_mode == "reference" else "reference")

    def _toggle_overlay(self) -> None:
        self._set(overlay=not self.settings.overlay)

    # ------------------------------------------------------------------ document
    def _skin_colour(self) -> tuple[float, float, float]:
        a = self.doc.head.albedo
        if a is None:
            return (0.6, 0.45, 0.38)
        h, w = a.shape[:2]
        from render.km_pass import srgb_decode

        c = srgb_decode(a[h // 3:2 * h // 3, w // 3:2 * w // 3, :3].reshape(-1, 3).astype(np.float32) / 255.0)
        m = np.median(c, axis=0)
        return (float(m[0]), float(m[1]), float(m[2]))

    def _on_doc_event(self, event: Any) -> None:
        self.setWindowModified(True)
        if getattr(self, "autosaver", None) is not None:
            self.autosaver.mark_dirty()
        if event.kind == "paint":
            # every dab: only queue its tiles (menus and undo state change at the stroke's end, which
            # updates them; undo/redo update them themselves)
            self.viewport.layers_changed(event.layer, list(event.tiles))
            if self._stroke is None:
                self._update_actions()
        else:
            self.refresh_layers()
            self._update_actions()

    def refresh_layers(self) -> None:
        n = len(self.doc.layers)
        self.selected_layer = min(max(self.selected_layer, 0), max(n - 1, 0))
        self.layers_panel.refresh(self.doc.layers, self.library, self.selected_layer)
        self.viewport.debug_layer_index = self.selected_layer
        self.viewport.layers_changed()

    def _wire_layers_panel(self) -> None:
        p = self.layers_panel
        p.add_requested.connect(self.add_layer)
        p.remove_requested.connect(lambda i: self._layer_cmd(lambda: self.doc.remove_layer(i)))
        p.move_requested.connect(self.move_layer)
        p.rename_requested.connect(lambda i, n: self._layer_cmd(lambda: self.doc.set_layer(i, name=n)))
        p.visibility_requested.connect(lambda i, v: self._layer_cmd(lambda: self.doc.set_layer(i, visible=v)))
        p.opacity_requested.connect(lambda i, v: self._layer_cmd(lambda: self.doc.set_layer(i, opacity=v)))
        p.max_thickness_requested.connect(
            lambda i, v: self._layer_cmd(lambda: self.doc.set_layer(i, max_thickness=v)))
        p.material_requested.connect(lambda i, m: self._layer_cmd(lambda: self.doc.set_layer(i, material=m)))
        p.selection_changed.connect(self._select_layer)
        p.import_requested.connect(self.ask_import_map)
        p.export_requested.connect(self.ask_export_map)

    def _select_layer(self, index: int) -> None:
        if index >= 0:
            self.selected_layer = index
            self.viewport.debug_layer_index = index  # the thickness view shows the selected layer
            self.viewport.update()

    def _layer_cmd(self, fn: Any) -> None:
        from core.errors import SheerError

        try:
            fn()
        except (SheerError, ValueError, IndexError) as exc:
            dialogs.error(self, "Layers", str(exc))

    def add_layer(self, material: str) -> None:
        if material not in self.library:
            dialogs.error(self, "Add layer", f"Pick a material from the library first ('{material}' is unknown).")
            return
        m = self.library.get(material)
        self.selected_layer = len(self.doc.layers)
        self._layer_cmd(lambda: self.doc.add_layer(material, name=material,
                                                   max_thickness=float(m.max_thickness_um)))

    def move_layer(self, src: int, dst: int) -> None:
        self.selected_layer = dst
        self._layer_cmd(lambda: self.doc.move_layer(src, dst))

    def undo(self) -> None:
        self.doc.undo()
        self._update_actions()

    def redo(self) -> None:
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
        brush = seams.make_brush(s.brush_radius_mm, s.brush_hardness, s.brush_strength, s.brush_mode,
                                 s.brush_mirror)
        self._stroke_cm = self.doc.stroke(lay, brush)
        self._stroke = self._stroke_cm.__enter__()
        self._stroke_move(point, pressure)

    def _stroke_move(self, point: np.ndarray, pressure: float) -> None:
        if self._stroke is not None:
            self._stroke.dab(point, pressure)

    def _stroke_end(self) -> None:
        if self._stroke_cm is not None:
            cm, self._stroke_cm, self._stroke = self._stroke_cm, None, None
            cm.__exit__(None, None, None)
            self._update_actions()

    # ------------------------------------------------------------------ materials
    def _material_changed(self, name: str | None) -> None:
        self.layers_panel.set_materials(self.library)
        self.refresh_layers()
        self.apply()

    # ------------------------------------------------------------------ project files (seam)
    def _update_title(self) -> None:
        self.setWindowTitle(f"{self.project_name}[*] — Sheer Studio")

    def new_project(self) -> None:
        from core.errors import SheerError

        try:
            seams.apply_look(self.doc, self.library, "bare")
        except SheerError as exc:
            dialogs.error(self, "New project", str(exc))
            return
        self.doc.clear_history()
        if self.autosaver is not None:
            self.autosaver.close()
            self.autosaver.project_path = None
        self.project_path, self.project_name = None, "Untitled"
        self.project, self.look_record = None, {"name": "bare", "tags": []}
        self.setWindowModified(False)
        self._update_title()
        self._update_actions()

    def open_project(self, path: Path | None = None, background: bool = False) -> bool:
        """Open a ``.sheer`` project (asked for when ``path`` is None). ``background``: read and check the
        file in a worker with progress (the dialog and the Recent menu do); returns at once then, else
        returns whether the project was opened. A missing or changed head offers to relink
        (:meth:`_offer_relink`); nothing in the current document changes unless the open succeeds.
        """
        if path is None:
            name, _ = QFileDialog.getOpenFileName(self, "Open project", "", "Sheer projects (*.sheer)")
            if not name:
                return False
            path, background = Path(name), True
        return self._open_attempt(Path(path), background, None, False)

    def _open_attempt(self, path: Path, background: bool, head_path: Path | None, accept: bool) -> bool:
        from app import project_io
        from project.errors import HeadChecksumError, HeadMissingError

        def job(_p: Any = None, _c: Any = None) -> Any:
            try:
                return project_io.read_document(path, head_path=head_path, accept_head_change=accept)
            except (HeadMissingError, HeadChecksumError) as exc:
                return exc

        def done(result: Any) -> bool:
            if isinstance(result, HeadMissingError | HeadChecksumError):
                answer = self._offer_relink(path, result)
                if answer is None:
                    return False
                if answer == "accept":  # keep a head located before: it is the one that changed
                    return self._open_attempt(path, background, head_path, True)
                return self._open_attempt(path, background, answer, False)
            return self._opened(path, *result)

        def failed(message: str) -> None:
            dialogs.error(self, "Open project", f"The project could not be opened: {message}")

        if background:
            run_task(self, "Opening the project", job, done, failed)
            return True
        from core.errors import SheerError

        try:
            result = job()
        except (SheerError, OSError, ValueError) as exc:
            failed(str(exc))
            return False
        return done(result)

    def _offer_relink(self, path: Path, exc: Exception) -> Path | str | None:
        """Ask what to do about a missing or changed head: the head file located (retry with
        ``head_path=``), ``"accept"`` (retry with ``accept_head_change=True``) or None (Cancel).
        """
        from project.errors import HeadChecksumError

        choices = {"locate": "Locate head…"}
        if isinstance(exc, HeadChecksumError):
            what = f"The head of {path.name} changed since the project was saved ({exc.file} differs)."
            choices["accept"] = "Use it anyway"
        else:
            what = f"The head of {path.name} was not found."
        choices["cancel"] = "Cancel"
        answer = dialogs.ask(self, "Relink head", f"{what}\n\n{exc}", choices, "cancel")
        if answer == "accept":
            return "accept"
        if answer != "locate":
            return None
        name, _ = QFileDialog.getOpenFileName(self, "Locate head", str(getattr(exc, "head_path", "") or ""),
                                              "Meshes (*.glb *.gltf *.obj *.ply);;All files (*)")
        return Path(name) if name else None

    def _opened(self, path: Path, project: Any, opened: Any, maps: list[np.ndarray] | None = None) -> bool:
        """Install an opened project. Maps at another resolution than the studio's are resampled if the
        user agrees (in a worker; returns True once started), else the project is not opened.
        """
        from app import project_io
        from core.errors import SheerError

        other = project_io.other_resolution(opened, self.doc) if maps is None else None
        if other is not None:
            want = int(self.doc.resolution)
            answer = dialogs.ask(
                self, "Open project",
                f"The project '{project.name}' was painted at {other}×{other} texels and this studio paints at "
                f"{want}×{want}. Resample its maps to {want}×{want}? (The file is unchanged until you save; "
                f"to keep its maps as they are, start Sheer with --resolution {other}.)",
                {"resample": "Resample", "cancel": "Cancel"}, "cancel")
            if answer != "resample":
                return False
            try:
                project_io.check_compatible(project, opened, self.doc, resample=True)
            except (SheerError, OSError, ValueError) as exc:
                dialogs.error(self, "Open project", f"The project could not be opened: {exc}")
                return False
            run_task(self, "Resampling the project's maps",
                     lambda p, c: project_io.resample_layers(self.doc, opened, p),
                     lambda result: self._opened(path, project, opened, result),
                     lambda m: dialogs.error(self, "Open project", f"The maps could not be resampled: {m}"))
            return True
        try:
            project_io.check_compatible(project, opened, self.doc, resample=maps is not None)
            project_io.install_layers(self.doc, self.library, project, opened, maps)
        except (SheerError, OSError, ValueError) as exc:
            dialogs.error(self, "Open project", f"The project could not be opened: {exc}")
            return False
        self.project, self.project_name, self.project_path = project, str(project.name), path
        self.look_record = project.look
        self._restore_view(project)
        if self.autosaver is not None:
            self.autosaver.project_path = self.project_path.absolute()
            self.autosaver.dirty = False
        self.settings.add_recent(str(path))
        self.layers_panel.set_materials(self.library)
        self.library_dock.refresh_list()
        self.refresh_layers()
        self.setWindowModified(False)
        self._update_title()
        self._update_actions()
        return True

    def view_state(self) -> Any:
        """The lights, camera and look to save (``project_io.ViewState``)."""
        from app import project_io

        return project_io.view_state(self.viewport.camera, self.viewport.lighting, self.settings.environment,
                                     self.look_record)

    def _restore_view(self, project: Any) -> None:
        """Key light, environment and camera from an opened project into the settings and the viewport."""
        from app import project_io

        if project.lights:
            changes: dict[str, Any] = {"environment": project_io.environment_name(project.lights)}
            preset = project_io.closest_preset(project.lights, LIGHT_PRESETS)
            if preset is not None:
                changes["light_preset"] = preset
            angles = project_io.key_light_angles(project.lights)
            if angles is not None:
                changes["light_azimuth"], changes["light_elevation"] = angles
            if changes["environment"] not in ENVIRONMENTS:
                changes["environment"] = "none"
            for key, value in changes.items():
                setattr(self.settings, key, value)
        project_io.restore_camera(self.viewport.camera, project.camera)
        self.apply()

    def save_project(self, ask: bool = False, path: Path | None = None, self_contained: bool | None = None) -> bool:
        """Save (``ask``: Save As); ``self_contained=True`` embeds the head in the file."""
        from app import project_io
        from core.errors import SheerError

        target = path or (None if ask else self.project_path)
        if target is None:
            name, _ = QFileDialog.getSaveFileName(self, "Save project", f"{self.project_name}.sheer",
                                                  "Sheer projects (*.sheer)")
            if not name:
                return False
            target = Path(name) if name.endswith(".sheer") else Path(name + ".sheer")
        target = Path(target)
        try:
            project = project_io.snapshot(self.doc, self.library, target.stem, self.project, self.view_state())
            saved = project_io.save_project_file(project, target, self_contained)
        except (SheerError, OSError, ValueError) as exc:
            dialogs.error(self, "Save project", f"The project could not be saved: {exc}")
            return False
        self.project, self.project_path, self.project_name = project, saved, saved.stem
        if self.autosaver is not None:
            self.autosaver.saved(saved)
        self.settings.add_recent(str(saved))
        self.setWindowModified(False)
        self._update_title()
        self._update_actions()
        return True

    def save_self_contained(self, path: Path | None = None) -> bool:
        """Save the project with the head embedded (asks where when ``path`` is None)."""
        return self.save_project(ask=path is None, path=path, self_contained=True)

    # ------------------------------------------------------------------ autosave and recovery
    def _snapshot(self) -> Any:
        from app import project_io

        return project_io.snapshot(self.doc, self.library, self.project_name, self.project, self.view_state())

    def _autosave_tick(self) -> None:
        """Every few seconds: when unsaved changes are due, snapshot here and write in a worker."""
        a = self.autosaver
        if a is None or not a.due() or getattr(self, "_autosaving", False):
            return
        try:
            project = self._snapshot()
        except Exception as exc:  # never interrupt the user for an autosave
            log.warning("autosave snapshot failed: %s", exc)
            return
        self._autosaving = True

        def done(path: Any) -> None:
            self._autosaving = False
            self.statusBar().showMessage(f"Autosaved to {path}", 3000)

        def failed(msg: str) -> None:
            self._autosaving = False
            log.warning("autosave failed: %s", msg)

        run_task(self, "Autosave", lambda p, c: a.autosave_now(project), done, failed, show_progress=False)

    def offer_recovery(self) -> None:
        """After a crash: offer the newest recovery file left by a session that did not end normally."""
        from app import project_io
        from core.errors import SheerError

        pending = project_io.pending_recoveries()
        if not pending:
            return
        info = pending[0]
        what = info.original.name if info.original else "untitled work"
        answer = dialogs.ask(self, "Recover unsaved work",
                             f"Sheer did not close normally. Recover {what} autosaved at {info.saved_at}?",
                             {"recover": "Recover", "discard": "Discard", "later": "Later"}, "later")
        if answer == "discard":
            info.path.unlink(missing_ok=True)
            return
        if answer != "recover":
            return
        try:
            from project.recovery import recover

            project = recover(info)
            self.project_name = project_io.load_project_into(self.doc, self.library, project)
        except (SheerError, OSError, ValueError) as exc:
            dialogs.error(self, "Recover unsaved work", f"The recovery file could not be opened: {exc}")
            return
        self.project_path = info.original
        self.project, self.look_record = project, project.look
        self._restore_view(project)
        self.layers_panel.set_materials(self.library)
        self.library_dock.refresh_list()
        self.refresh_layers()
        self.setWindowModified(True)
        self._update_title()
        info.path.unlink(missing_ok=True)

    # ------------------------------------------------------------------ exports
    def _ask_folder(self, title: str) -> str:
        return QFileDialog.getExistingDirectory(self, title)

    def ask_export_maps(self, fmt: str = "png") -> None:
        folder = self._ask_folder("Export layer maps to folder")
        if folder:
            self.export_maps(Path(folder), fmt=fmt)

    def export_maps(self, folder: Path, on_done: Any = None, fmt: str = "png") -> None:
        run_task(self, "Exporting layer maps", lambda p, c: export_maps(self.doc, folder, p, c, fmt),
                 on_done or (lambda r: self.statusBar().showMessage(f"Maps exported: {r}", 6000)),
                 lambda m: dialogs.error(self, "Export maps", m))

    def ask_export_gltf(self) -> None:
        path, _ = QFileDialog.getSaveFileName(self, "Export glTF", "face.glb", "glTF binary (*.glb);;glTF (*.gltf)")
        if path:
            self.export_gltf(Path(path))

    def export_gltf(self, path: Path, on_done: Any = None) -> None:
        run_task(self, "Exporting glTF", lambda p, c: export_gltf(self.doc, self.library, path, p, c),
                 on_done or (lambda r: self.statusBar().showMessage(f"glTF exported: {r}", 6000)),
                 lambda m: dialogs.error(self, "Export glTF", m))

    def ask_export_image(self) -> None:
        sizes = ["1280x720", "1920x1080", "2048x2048", "3840x2160"]
        size, ok = QInputDialog.getItem(self, "Rendered image", "Size", sizes, 0, True)
        if not ok:
            return
        path, _ = QFileDialog.getSaveFileName(self, "Export rendered image", "render.png", "PNG (*.png)")
        if path:
            try:
                w, h = (int(x) for x in size.lower().split("x"))
            except ValueError:
                dialogs.error(self, "Export image", f"'{size}' is not a size like 1920x1080.")
                return
            self.export_image(Path(path), (w, h))

    def export_image(self, path: Path, size: tuple[int, int], on_done: Any = None) -> None:
        import copy
        import dataclasses

        cam, light = copy.deepcopy(self.viewport.camera), copy.deepcopy(self.viewport.lighting)
        layers = [dataclasses.replace(inp, thickness=np.array(inp.thickness))
                  for inp in layer_inputs(self.doc, self.library)]
        mode, env, face = self.settings.render_mode, self.settings.environment, self.viewport.face
        layout = getattr(self.doc, "layout", None)
        run_task(self, "Rendering image",
                 lambda p, c: render_image(self.doc.head, layers, cam, light, size, path, mode, env, layout, p, c,
                                           face),
                 on_done or (lambda r: self.statusBar().showMessage(f"Image saved: {r}", 6000)),
                 lambda m: dialogs.error(self, "Export image", m))

    def ask_import_map(self, index: int) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Import thickness map", "",
                                              "Thickness maps (*.png *.exr)")
        if path:
            self.import_map(index, Path(path))

    def import_map(self, index: int, path: Path) -> bool:
        from PIL import Image, UnidentifiedImageError

        from core.errors import SheerError

        lay = self.doc.layers[index]
        if hasattr(self.doc, "import_layer"):
            try:
                self.doc.import_layer(index, path)
            except (SheerError, OSError, ValueError) as exc:
                dialogs.error(self, "Import map", f"The map could not be imported: {exc}")
                return False
            self.refresh_layers()
            return True
        try:
            with Image.open(path) as im:
                arr = np.asarray(im)
        except (OSError, UnidentifiedImageError) as exc:
            dialogs.error(self, "Import map", f"{path}: not a readable image ({exc}).")
            return False
        if arr.ndim != 2 or arr.shape != lay.thickness.shape:
            dialogs.error(self, "Import map", f"{path}: the map must be a greyscale image of "
                          f"{lay.thickness.shape[1]}×{lay.thickness.shape[0]} texels, got {arr.shape}.")
            return False
        scale = 65535.0 if arr.dtype == np.uint16 else 255.0
        new = (arr.astype(np.float32) / scale * float(lay.max_thickness)).astype(np.float32)
        seams.set_thickness(self.doc, lay, new)
        self.refresh_layers()
        return True

    def ask_export_map(self, index: int) -> None:
        if hasattr(self.doc, "export_layer"):
            name, _ = QFileDialog.getSaveFileName(self, "Export thickness map",
                                                  f"{self.doc.layers[index].name}.png",
                                                  "16-bit PNG (*.png);;OpenEXR (*.exr)")
            if name:
                run_task(self, "Exporting map", lambda p, c: self.doc.export_layer(index, Path(name)),
                         lambda r: self.statusBar().showMessage(f"Map exported: {name}", 6000),
                         lambda m: dialogs.error(self, "Export map", m))
            return
        folder = self._ask_folder("Export this layer's map to folder")
        if folder:
            lay = self.doc.layers[index]

            class _One:
                head = self.doc.head
                layers = [lay]

            run_task(self, "Exporting map", lambda p, c: export_maps(_One, Path(folder), p, c),
                     lambda r: self.statusBar().showMessage(f"Map exported: {r}", 6000),
                     lambda m: dialogs.error(self, "Export map", m))

    # ------------------------------------------------------------------ help
    def show_about(self) -> None:
        from core.assets import ASSET_CREDITS

        credits = "".join(f"<li>{v}</li>" for v in ASSET_CREDITS.values())
        used = ", ".join(f"{k}: {v}" for k, v in seams.backends().items())
        text = (f"<h3>Sheer Studio</h3><p>A physically based makeup design studio: Kubelka–Munk cosmetic "
                f"layers over subsurface-scattering skin (after Huang et al. 2013).</p>"
                f"<p><b>Head scan:</b> {self.doc.head.credit or 'none'}</p>"
                f"<p><b>Sample assets</b><ul>{credits}</ul></p>"
                f"<p><small>Components in use: {used}</small></p>")
        box = QDialog(self)
        box.setWindowTitle("About Sheer")
        lay = QVBoxLayout(box)
        label = QLabel(text)
        label.setWordWrap(True)
        label.setTextFormat(Qt.TextFormat.RichText)
        lay.addWidget(label)
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok)
        buttons.accepted.connect(box.accept)
        lay.addWidget(buttons)
        self._exec_dialog(box)

    def show_shortcuts(self) -> None:
        rows = shortcut_sheet()
        box = QDialog(self)
        box.setWindowTitle("Keyboard Shortcuts")
        table = QTableWidget(len(rows), 3)
        table.setHorizontalHeaderLabels(["Where", "Action", "Shortcut"])
        for r, row in enumerate(rows):
            for c, text in enumerate(row):
                table.setItem(r, c, QTableWidgetItem(text))
        table.resizeColumnsToContents()
        lay = QVBoxLayout(box)
        lay.addWidget(table)
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok)
        buttons.accepted.connect(box.accept)
        lay.addWidget(buttons)
        box.resize(560, 520)
        self._exec_dialog(box)

    def _exec_dialog(self, box: QDialog) -> None:
        if dialogs.AUTO_DISMISS_MS is not None:
            QTimer.singleShot(dialogs.AUTO_DISMISS_MS, box.accept)
        box.exec()
        box.deleteLater()

    # ------------------------------------------------------------------ close
    def closeEvent(self, event: QCloseEvent) -> None:
        self._stroke_end()
        if self.isWindowModified() and self.doc.layers:
            answer = dialogs.ask(self, "Unsaved changes", f"Save the changes to {self.project_name}?",
                                 {"save": "Save", "discard": "Discard", "cancel": "Cancel"}, "save")
            if answer == "cancel" or (answer == "save" and not self.save_project()):
                event.ignore()
                return
        self.autosave_timer.stop()
        if self.autosaver is not None:
            self.autosaver.close()
        save_settings(self.qsettings, self.settings)
        self.qsettings.setValue("window/geometry", self.saveGeometry())
        self.qsettings.setValue("window/state", self.saveState())
        self.qsettings.sync()
        from app.workers import wait_all

        wait_all(20000)
        self.viewport.release_gl()
        event.accept()


def seams_has_project_io() -> bool:
    from app import project_io

    return project_io.available()
