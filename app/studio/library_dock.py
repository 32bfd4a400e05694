"""The material library editor, a dock beside the studio's viewport.

Search/filter, property edits, spectral plots with pyqtgraph (legends, units, hover read-out), a thickness
slider for R0/T, swatches (in the pan, as applied on the reference skin or lip, on this head, over black and
white) and the stated coverage, measurement import with a report of
rejected rows, Duncan mixing with a live swatch, atomic save. Emits ``material_changed(name)``.

Every edit is the document's (:mod:`painting.document_materials`): one step of its undo history (Ctrl+Z,
or this dock's Undo), and every layer of an edited material wears the edit, so the viewport shows it, the
document is modified and a saved project embeds it. The library's own file is another matter: the studio
starts from the shipped library with the user's saved library file over it (:func:`user_library_path`,
:func:`app.session.load_library`); Save Library writes that file, and quitting with library edits not
written offers to (:meth:`LibraryDock.offer_to_save`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from PySide6.QtCore import QStandardPaths, Qt, Signal
from PySide6.QtWidgets import (
    QComboBox,
    QDoubleSpinBox,
    QFileDialog,
    QFormLayout,
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QListWidget,
    QPushButton,
    QSizePolicy,
    QSlider,
    QVBoxLayout,
    QWidget,
)

from app.studio import dialogs
from app.studio.layers_panel import applied_rgb, colours_ready, material_rgb, swatch_icon, swatch_of
from app.studio.library_edits import EDITABLE, duncan_mix
from app.studio.number_fields import NumberField
from km.coverage import LIP_CATEGORIES

if TYPE_CHECKING:
    from collections.abc import Callable

    from km.material import Material
    from km.measurements import ImportResult
    from painting import ChangeEvent, Document


def user_library_path() -> Path:
    """The user's material library file (``library.json`` in the application's data folder).

    The studio starts from the shipped library with this file's materials over it; Save Library writes
    it (the shipped library is never overwritten).
    """
    base = QStandardPaths.writableLocation(QStandardPaths.StandardLocation.AppDataLocation)
    return Path(base or ".") / "library.json"


class LibraryDock(QWidget):
    """The material library editor (see the module docstring); every edit is a step of the document's history.

    Args:
        document: the document whose library (``document.library``, the studio's) is edited.
        skin_rgb: the skin's linear RGB in [0, 1], the background of the "on this head" swatch (skin products).
        parent: the parent widget.

    Attributes:
        in_use: tells whether a material name is used by a layer (set by the window; such a material
            cannot be deleted).
    """

    material_changed = Signal(object)  # a material name, or None when the set of materials changed

    def __init__(self, document: Document, skin_rgb: tuple[float, float, float],
                 parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.doc = document
        self.library = document.library
        self.skin = skin_rgb
        self._saved: list[Material] = self.library.materials  # as its file has them (see ``modified``)
        self._edited = False
        self.current: str | None = None
        self._loading = False
        self.search = QLineEdit()
        self.search.setPlaceholderText("Search materials…")
        self.category = QComboBox()
        self.list = QListWidget()
        form = self._build_form()
        sw = self._build_views()
        mix = self._build_mix()
        buttons = self._build_buttons()
        filt = QHBoxLayout()
        filt.addWidget(self.search, 2)
        filt.addWidget(self.category, 1)
        lay = QVBoxLayout(self)
        lay.addLayout(filt)
        lay.addWidget(self.list, 1)
        lay.addLayout(form)
        lay.addLayout(self.refl_holder, 2)
        lay.addLayout(self.coef_holder, 1)
        lay.addWidget(self.readout)
        th = QHBoxLayout()
        th.addWidget(QLabel("Thickness for R0/T"))
        th.addWidget(self.thickness, 1)
        th.addWidget(self.thickness_label)
        lay.addLayout(th)
        lay.addLayout(sw)
        lay.addLayout(mix)
        lay.addWidget(self.mix_button)
        lay.addLayout(buttons)
        self.search.textChanged.connect(lambda _t: self.refresh_list())
        self.category.currentIndexChanged.connect(lambda _i: self.refresh_list())
        self.list.currentTextChanged.connect(self.select)
        self.name_edit.editingFinished.connect(self._rename)
        self.category_edit.activated.connect(lambda _i: self.edit("category", self.category_edit.currentText()))
        self.category_edit.lineEdit().editingFinished.connect(
            lambda: self.edit("category", self.category_edit.currentText()))
        self.doc.subscribe(self._on_doc_event)
        self.refresh_list()

    def _build_form(self) -> QFormLayout:
        """The selected material's fields: name, category, thicknesses, roughness, IOR and the spectra's scales."""
        self.name_edit = QLineEdit()
        self.category_edit = QComboBox()
        self.category_edit.setEditable(True)
        self.spins: dict[str, QDoubleSpinBox] = {}
        for attr, (lo, hi, suffix, step) in {
            "thickness_um": (0.1, 10000.0, " µm", 1.0), "max_thickness_um": (0.1, 10000.0, " µm", 1.0),
            "roughness": (0.01, 1.0, "", 0.05), "ior": (1.0, 3.0, "", 0.01)}.items():
            s = NumberField()
            s.setRange(lo, hi)
            s.setSingleStep(step)
            s.setDecimals(2)
            s.setSuffix(suffix)
            s.editingFinished.connect(lambda a=attr, w=s: self.edit(a, float(w.value())))
            self.spins[attr] = s
        self.scales: dict[str, QDoubleSpinBox] = {}
        for arr, tip in (("K", "absorption × (darker / deeper shade)"), ("S", "scattering × (more coverage)")):
            sp = NumberField()
            sp.setRange(0.1, 10.0)
            sp.setSingleStep(0.1)
            sp.setValue(1.0)
            sp.setPrefix("× ")
            sp.setToolTip(tip)
            sp.editingFinished.connect(lambda a=arr, w=sp: self.scale_spectrum(a, float(w.value())))
            self.scales[arr] = sp
        scale_row = QHBoxLayout()
        scale_row.addWidget(QLabel("K"))
        scale_row.addWidget(self.scales["K"])
        scale_row.addWidget(QLabel("S"))
        scale_row.addWidget(self.scales["S"])
        form = QFormLayout()
        form.addRow("Name", self.name_edit)
        form.addRow("Category", self.category_edit)
        form.addRow("Default thickness", self.spins["thickness_um"])
        form.addRow("Max thickness", self.spins["max_thickness_um"])
        form.addRow("Roughness", self.spins["roughness"])
        form.addRow("IOR", self.spins["ior"])
        form.addRow("Scale spectra", scale_row)
        return form

    def _build_views(self) -> QGridLayout:
        """The plots' places (built later, :meth:`build_plots`), the readout, the thickness slider; the swatches' grid."""
        # plots
        # the pyqtgraph plots are built after the viewport's first frame (build_plots): importing
        # pyqtgraph costs about a second of start-up
        self.refl_plot: Any = None
        self.coef_plot: Any = None
        self.refl_holder = QVBoxLayout()
        self.coef_holder = QVBoxLayout()
        self.readout = QLabel("Hover a plot for values")
        self.readout.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        # wrapped within the dock's width: a long read-out must never widen the dock (and shrink the view)
        self.readout.setWordWrap(True)
        self.readout.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Preferred)
        self.thickness = QSlider(Qt.Orientation.Horizontal)
        self.thickness.setRange(1, 200)
        self.thickness.setValue(10)
        self.thickness_label = QLabel()
        self.thickness.valueChanged.connect(lambda _v: self.update_views())
        # swatches: the material's own colours (its default thickness), then the contrast card (the slider's)
        self.swatches = {k: QLabel(k) for k in ("in the pan", "as applied", "on this head", "over black",
                                                 "over white")}
        self.coverage_label = QLabel()
        self.coverage_label.setWordWrap(True)
        sw = QGridLayout()
        for i, lab in enumerate(self.swatches.values()):
            lab.setMinimumSize(64, 40)
            lab.setAlignment(Qt.AlignmentFlag.AlignCenter)
            sw.addWidget(lab, i // 3, i % 3)
        sw.addWidget(self.coverage_label, 1, 2)
        return sw

    def _head_background(self, category: str) -> tuple[float, float, float]:
        """The "on this head" swatch's background, linear RGB: the head's skin, or its bare lips for a lip product.

        The lips: the median albedo of the head's ``lips`` region, else the reference lip.
        """
        from km.coverage import reference_background
        from km.srgb import srgb_decode

        if category not in LIP_CATEGORIES:
            return self.skin
        if getattr(self, "_lip", None) is None:  # once: the dock's document keeps its head
            self._lip = tuple(float(c) for c in reference_background(category))
            try:
                albedo = self.doc.head.albedo
                lips = self.doc.region_values("lips", albedo.shape[0]) >= 0.95
                if albedo.shape[0] == albedo.shape[1] and lips.any():
                    self._lip = tuple(float(c) for c in np.median(srgb_decode(albedo[lips] / 255.0), axis=0))
            except Exception:  # noqa: BLE001 — no document, no albedo or no lips region: the reference lip
                pass
        return self._lip  # type: ignore[return-value]

    def _build_mix(self) -> QHBoxLayout:
        """The shade variant's row: the partner, the amount and the mix's swatch (its button below it)."""
        self.mix_with = QComboBox()
        self.mix_amount = QSlider(Qt.Orientation.Horizontal)
        self.mix_amount.setRange(0, 100)
        self.mix_amount.setValue(50)
        self.mix_swatch = QLabel("mix")
        self.mix_swatch.setMinimumSize(64, 28)
        self.mix_swatch.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.mix_button = QPushButton("Create Shade Variant")
        self.mix_with.currentIndexChanged.connect(lambda _i: self._update_mix())
        self.mix_amount.valueChanged.connect(lambda _v: self._update_mix())
        self.mix_button.clicked.connect(self.create_variant)
        mix = QHBoxLayout()
        mix.addWidget(QLabel("Mix with"))
        mix.addWidget(self.mix_with, 1)
        mix.addWidget(self.mix_amount, 1)
        mix.addWidget(self.mix_swatch)
        return mix

    def _build_buttons(self) -> QGridLayout:
        """Duplicate, Delete, Import Measurement…, Undo, Redo and Save Library, in two rows."""
        self.duplicate_button = QPushButton("Duplicate")
        self.delete_button = QPushButton("Delete")
        self.duplicate_button.clicked.connect(self.duplicate_current)
        self.delete_button.clicked.connect(self.delete_current)
        self.in_use: Callable[[str], bool] = lambda name: False  # the window tells which materials its layers use
        self.import_button = QPushButton("Import Measurement…")
        self.undo_button = QPushButton("Undo")
        self.redo_button = QPushButton("Redo")
        self.save_button = QPushButton("Save Library")
        self.undo_button.clicked.connect(lambda: self._document_edit("Undo", self.doc.undo))
        self.redo_button.clicked.connect(lambda: self._document_edit("Redo", self.doc.redo))
        self.undo_button.setToolTip("Undo the last edit (the document's: Edit → Undo)")
        self.redo_button.setToolTip("Redo the last undone edit (the document's: Edit → Redo)")
        self.undo_button.setEnabled(self.doc.can_undo)
        self.redo_button.setEnabled(self.doc.can_redo)
        self.import_button.clicked.connect(self._ask_import)
        self.save_button.clicked.connect(lambda: self.save())
        buttons = QGridLayout()
        for i, b in enumerate((self.duplicate_button, self.delete_button, self.import_button,
                               self.undo_button, self.redo_button, self.save_button)):
            buttons.addWidget(b, i // 3, i % 3)
        return buttons

    # ------------------------------------------------------------------ model → view
    def refresh_list(self) -> None:
        """Rebuild the categories, the filtered list and the mix partners from the library."""
        if self._loading:
            return
        self._loading = True
        for w in (self.category, self.category_edit, self.mix_with, self.list):
            w.blockSignals(True)
        cats = sorted({str(m.category) for m in self.library})
        cur_cat = self.category.currentText()
        self.category.clear()
        self.category.addItems(["all categories", *cats])
        if cur_cat in cats:
            self.category.setCurrentText(cur_cat)
        self.category_edit.clear()
        self.category_edit.addItems(cats)
        text = self.search.text().strip().lower()
        cat = self.category.currentText()
        self.list.clear()
        for m in self.library:
            if text and text not in m.name.lower() and text not in str(m.category).lower():
                continue
            if cat != "all categories" and str(m.category) != cat:
                continue
            self.list.addItem(m.name)
            self.list.item(self.list.count() - 1).setIcon(swatch_icon(swatch_of(m), 16))
        self.mix_with.clear()
        self.mix_with.addItems(self.library.names())
        for w in (self.category, self.category_edit, self.mix_with, self.list):
            w.blockSignals(False)
        self._loading = False
        names = [self.list.item(i).text() for i in range(self.list.count())]
        if self.current in names:
            self.list.setCurrentRow(names.index(self.current))
        elif names:
            self.list.setCurrentRow(0)
        if self.list.currentItem() is not None:
            self.select(self.list.currentItem().text())

    def select(self, name: str) -> None:
        """Show material ``name`` (ignored when it is not in the library)."""
        if self._loading or not name or name not in self.library:
            return
        self.current = name
        for i in range(self.list.count()):
            if self.list.item(i).text() == name and self.list.currentRow() != i:
                self.list.blockSignals(True)
                self.list.setCurrentRow(i)
                self.list.blockSignals(False)
        self.load_fields()
        self.update_views()

    def load_fields(self) -> None:
        """Show the current material's properties in the editing fields."""
        if self.current is None:
            return
        m = self.library.get(self.current)
        self._loading = True
        self.name_edit.setText(m.name)
        self.category_edit.setCurrentText(str(m.category))
        for attr, spin in self.spins.items():
            spin.setValue(float(getattr(m, attr)))
        self._loading = False

    def build_plots(self) -> None:
        """Create the spectral plots (idempotent)."""
        if self.refl_plot is not None:
            return
        import pyqtgraph as pg

        pg.setConfigOptions(antialias=True)
        from app.studio.plots import legend_below, plain_axis

        self.refl_plot = pg.PlotWidget()
        self.refl_plot.setLabel("bottom", "wavelength", units="nm")
        plain_axis(self.refl_plot, "left", "R, T (fraction)")  # (a longer label is cut at this height)
        self.refl_plot.setYRange(0, 1)
        legend_below(self.refl_plot, 2)
        self.coef_plot = pg.PlotWidget()
        self.coef_plot.setLabel("bottom", "wavelength", units="nm")
        plain_axis(self.coef_plot, "left", "S, K (mm⁻¹)")
        legend_below(self.coef_plot, 2)
        for p in (self.refl_plot, self.coef_plot):
            p.setMinimumHeight(150)
            p.showGrid(x=True, y=True, alpha=0.2)
        self.refl_plot.setMinimumHeight(230)  # its legend's rows under it, and its label whole
        self.coef_plot.setMinimumHeight(180)
        self.refl_plot.scene().sigMouseMoved.connect(lambda pos: self._hover(self.refl_plot, pos))
        self.coef_plot.scene().sigMouseMoved.connect(lambda pos: self._hover(self.coef_plot, pos))
        self.refl_holder.addWidget(self.refl_plot)
        self.coef_holder.addWidget(self.coef_plot)
        self.update_views()

    def update_views(self) -> None:
        """Redraw the current material's swatches and plots at the slider's thickness (µm)."""
        if self.refl_plot is not None:
            self.refl_plot.clear()
            self.coef_plot.clear()
        if self.current is None or self.current not in self.library or not colours_ready():
            return
        m = self.library.get(self.current)
        wl = np.asarray(m.wavelengths, float)
        t_um = float(self.thickness.value())
        self.thickness_label.setText(f"{t_um:.0f} µm")
        R, T = m.rt(t_um)
        self._curves = {"R∞": m.r_inf(), f"R0 @ {t_um:.0f} µm": R, f"T @ {t_um:.0f} µm": T}
        self._coefs = {"S (per mm)": np.asarray(m.S, float), "K (per mm)": np.asarray(m.K, float)}
        self._wl = wl
        d_um = float(m.thickness_um)
        self._paint_swatch(self.swatches["in the pan"], material_rgb(m),
                           "in the pan or bullet: the opaque product's colour (R∞)")
        self._paint_swatch(self.swatches["as applied"], applied_rgb(m),
                           f"as applied: {d_um:g} µm (its default thickness) on the reference "
                           f"{'lip' if m.category in LIP_CATEGORIES else 'skin'} (the sample head's)")
        self._paint_swatch(self.swatches["on this head"], applied_rgb(m, self._head_background(m.category)),
                           f"on this head: {d_um:g} µm on its {'lips' if m.category in LIP_CATEGORIES else 'skin'}")
        for key, bg in (("over black", (0.0, 0.0, 0.0)), ("over white", (1.0, 1.0, 1.0))):
            self._paint_swatch(self.swatches[key], material_rgb(m, t_um, bg), f"{key} at {t_um:.0f} µm (the slider's)")
        cov = m.coverage
        self.coverage_label.setText(f"{cov.level} coverage · contrast ratio {m.contrast_ratio():.2f} at {d_um:g} µm")
        self.coverage_label.setToolTip(f"states: {cov.level}"
                                       + (f", {cov.contrast_ratio:g}" if cov.contrast_ratio is not None else "")
                                       + f" — {cov.provenance}")
        self._update_mix()
        if self.refl_plot is None:
            return
        import pyqtgraph as pg

        pens = {"R∞": pg.mkPen("#e0a050", width=2), f"R0 @ {t_um:.0f} µm": pg.mkPen("#50a0e0", width=2),
                f"T @ {t_um:.0f} µm": pg.mkPen("#70d070", width=2, style=Qt.PenStyle.DashLine)}
        for name, y in list(self._curves.items()):
            self.refl_plot.plot(wl, y, pen=pens[name], name=name)
        meas = getattr(m, "measurement", None)
        if meas is not None:
            mw = np.asarray(meas.wavelengths, float)
            d_um = float(meas.D_mm) * 1000.0
            for key, colour, label in (("R_inf", "#ff6060", "R∞ measured"),
                                       ("R", "#c080ff", f"R measured ({d_um:g} µm)"),
                                       ("Rg", "#ffffff", "Rg (background)")):
                y = np.asarray(getattr(meas, key), float)
                self.refl_plot.plot(mw, y, pen=None, symbol="o", symbolSize=4, symbolBrush=colour, name=label)
                self._curves[label] = np.interp(wl, mw, y)
        self.coef_plot.plot(wl, self._coefs["S (per mm)"], pen=pg.mkPen("#d0d0d0", width=2), name="S (per mm)")
        self.coef_plot.plot(wl, self._coefs["K (per mm)"], pen=pg.mkPen("#e06060", width=2), name="K (per mm)")

    @staticmethod
    def _paint_swatch(label: QLabel, rgb: tuple[int, int, int], what: str = "") -> None:
        fg = "#000" if sum(rgb) > 380 else "#fff"
        label.setStyleSheet(f"background: rgb{rgb}; color: {fg}; border: 1px solid #444;")
        label.setToolTip(f"{what}: sRGB {rgb}" if what else f"sRGB {rgb}")

    def _hover(self, plot: Any, pos: Any) -> None:
        if not hasattr(self, "_wl") or not plot.sceneBoundingRect().contains(pos):
            return
        x = plot.plotItem.vb.mapSceneToView(pos).x()
        curves = self._curves if plot is self.refl_plot else self._coefs
        vals = " · ".join(f"{k} {np.interp(x, self._wl, v):.3f}" for k, v in curves.items())
        self.readout.setText(f"λ {x:.0f} nm: {vals}")  # (wrapped within the dock, see _build_views)

    def _update_mix(self) -> None:
        other = self.mix_with.currentText()
        if self.current is None or other not in self.library or self.current not in self.library:
            return
        m = duncan_mix(self.library.get(self.current), self.library.get(other),
                       self.mix_amount.value() / 100.0, "mix")
        self._paint_swatch(self.mix_swatch, material_rgb(m))
        self.mix_swatch.setText(f"{100 - self.mix_amount.value()}:{self.mix_amount.value()}")

    # ------------------------------------------------------------------ edits (the document's, undoable)
    def _on_doc_event(self, event: ChangeEvent) -> None:
        if event.kind == "library":
            self._edited = True
            self.changed(event.detail or None)
        elif event.kind == "history":
            self.undo_button.setEnabled(self.doc.can_undo)
            self.redo_button.setEnabled(self.doc.can_redo)

    def changed(self, name: str | None) -> None:
        """After an edit of the library (or its undo): show ``name`` and tell the window (``material_changed``)."""
        if name is not None:
            self.current = name
        self.refresh_list()
        self.load_fields()
        self.update_views()
        self.save_button.setText("Save Library*" if self.modified else "Save Library")
        self.material_changed.emit(name)

    def _document_edit(self, title: str, fn: Callable[[], object]) -> bool:
        """Run the document edit ``fn``; one it refuses is an error message (the fields show the truth)."""
        from core.errors import SheerError

        try:
            fn()
        except (SheerError, ValueError) as exc:
            dialogs.error(self, title, str(exc))
            self.load_fields()
            return False
        return True

    def edit(self, attr: str, value: object) -> None:
        """Set property ``attr`` (one of :data:`EDITABLE`) of the current material; one document step.

        A value the material refuses (or a default thickness above the maximum) is an error message.
        """
        if self._loading or self.current is None:
            return
        m = self.library.get(self.current)
        old = getattr(m, attr)
        if old == value or (attr == "category" and not str(value).strip()):
            return
        if attr == "max_thickness_um" and value < float(m.thickness_um):
            dialogs.error(self, "Material", "The maximum thickness cannot be below the default thickness.")
            self.load_fields()
            return
        if attr == "thickness_um" and value > float(m.max_thickness_um):
            dialogs.error(self, "Material", "The default thickness cannot exceed the maximum thickness.")
            self.load_fields()
            return
        name = self.current
        self._document_edit("Material", lambda: self.doc.replace_material(
            name, m.replace(**{attr: EDITABLE[attr](value)}), f"{attr} of {name}"))

    def scale_spectrum(self, which: str, factor: float) -> None:
        """Multiply the current material's K (absorption) or S (scattering) by ``factor``; one step."""
        self.scales[which].blockSignals(True)
        self.scales[which].setValue(1.0)
        self.scales[which].blockSignals(False)
        if self._loading or self.current is None or abs(factor - 1.0) < 1e-6 or which not in ("S", "K"):
            return
        name = self.current
        m = self.library.get(name)
        scaled = np.asarray(getattr(m, which), float) * factor
        self._document_edit("Material", lambda: self.doc.replace_material(
            name, m.replace(**{which: scaled}), f"{which} × {factor:g} of {name}"))

    def _rename(self) -> None:
        if self._loading or self.current is None:
            return
        new = self.name_edit.text().strip()
        if not new or new == self.current:
            return
        if new in self.library and new.casefold() != self.current.casefold():
            dialogs.error(self, "Rename material", f"A material named '{new}' already exists.")
            self.name_edit.setText(self.current)
            return
        old = self.current
        if not self._document_edit("Rename material", lambda: self.doc.replace_material(
                old, self.library.get(old).replace(name=new), f"rename {old}")):
            self.name_edit.setText(old)

    def duplicate_current(self) -> None:
        """Add a copy of the current material ("… copy", numbered when taken); one document step."""
        if self.current is None:
            return
        base = f"{self.current} copy"
        name, n = base, 2
        while name in self.library:
            name, n = f"{base} {n}", n + 1
        copy = self.library.get(self.current).replace(name=name)
        self._document_edit("Duplicate material", lambda: self.doc.add_materials([copy], f"add {name}"))

    def delete_current(self) -> None:
        """Delete the current material (refused while a layer uses it); one document step."""
        if self.current is None:
            return
        if self.in_use(self.current):
            dialogs.error(self, "Delete material",
                          f"'{self.current}' is used by a layer; change that layer's material first.")
            return
        name = self.current
        self._document_edit("Delete material", lambda: self.doc.remove_material(name))

    def create_variant(self) -> None:
        """Add the Duncan mix of the current material and the chosen partner at the slider's share; undoable."""
        other = self.mix_with.currentText()
        if self.current is None or other not in self.library:
            return
        c = self.mix_amount.value()
        base = f"{self.current} + {other} {c}%"
        name, n = base, 2
        while name in self.library:
            name, n = f"{base} ({n})", n + 1
        try:
            mixed = duncan_mix(self.library.get(self.current), self.library.get(other), c / 100.0, name)
        except ValueError as exc:
            dialogs.error(self, "Shade variant", str(exc))
            return
        self._document_edit("Shade variant", lambda: self.doc.add_materials([mixed], f"add {name}"))

    def _ask_import(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Import measurement", "",
                                              "Measurements (*.csv *.txt *.cgats *.cgt);;All files (*)")
        if path:
            self.import_measurement(Path(path), background=True)

    def import_measurement(self, path: Path, background: bool = False) -> bool:
        """Import the materials of a measurement file (CSV or X-Rite/CGATS) as one undoable step.

        A file that cannot be read, or that yields no material → an error dialog, library unchanged;
        rejected rows are reported. ``background``: read and invert in a worker (progress, Cancel) and
        return at once.
        """
        from core.errors import SheerError
        from km.measurement_files import import_file

        if background:
            from app.workers import run_task

            run_task(self, "Importing measurements", lambda p, c: import_file(path),
                     lambda result: self._finish_import(path, result),
                     lambda msg: dialogs.error(self, "Import measurement", f"The file could not be imported: {msg}"))
            return True
        try:
            result = import_file(path)
        except (SheerError, OSError, ValueError) as exc:
            dialogs.error(self, "Import measurement", f"The file could not be imported: {exc}")
            return False
        return self._finish_import(path, result)

    def _finish_import(self, path: Path, result: ImportResult) -> bool:
        if not result.accepted:
            dialogs.error(self, "Import measurement",
                          f"{Path(path).name}: no material could be imported "
                          f"({len(result.rejected)} rows or samples rejected).", result.report())
            return False
        materials = []
        for m in result.accepted:
            if m.name in self.library:
                m = m.replace(name=self.library.unique_name(m.name))
            materials.append(m)
        if not self._document_edit("Import measurement",
                                   lambda: self.doc.add_materials(materials, f"import {Path(path).name}")):
            return False
        if result.rejected:
            dialogs.info(self, "Import measurement",
                         f"Imported {len(materials)} material(s); {len(result.rejected)} rows or samples "
                         f"were rejected (see details).", result.report())
        return True

    def default_save_path(self) -> Path:
        """Where a library is saved when it has no file of its own (:func:`user_library_path`)."""
        return user_library_path()

    def save_target(self) -> Path:
        """The file Save Library writes: the library's own, else :meth:`default_save_path`.

        Never the shipped default library (a user copy is saved instead).
        """
        from core.assets import RESOURCES_DIR

        own = self.library.path
        if own is not None and Path(own).resolve().is_relative_to(RESOURCES_DIR):
            own = None  # the shipped default library is never overwritten: save a user copy
        return Path(own) if own is not None else self.default_save_path()

    def save(self, path: Path | None = None) -> Path | None:
        """Save the library atomically: to ``path``, else :meth:`save_target`.

        Returns the file written, or None after showing why it could not be.
        """
        target = path or self.save_target()
        try:
            Path(target).parent.mkdir(parents=True, exist_ok=True)
            saved = self.library.save(Path(target))
        except (OSError, ValueError) as exc:
            dialogs.error(self, "Save library", f"The library could not be saved: {exc}")
            return None
        self._saved, self._edited = self.library.materials, False
        self.save_button.setText("Save Library")
        return Path(saved or target)

    # ------------------------------------------------------------------ unsaved edits
    def changed_names(self) -> list[str]:
        """The materials edited, added or removed since the library was loaded or saved (library order)."""
        saved = {id(m) for m in self._saved}
        now = self.library.materials
        kept = {m.name.casefold() for m in now}
        return ([m.name for m in now if id(m) not in saved]
                + [m.name for m in self._saved if m.name.casefold() not in kept])

    @property
    def modified(self) -> bool:
        """The library holds edits its file has not (an edit undone back to the saved state is none)."""
        now = self.library.materials
        return self._edited and (len(now) != len(self._saved)
                                 or any(a is not b for a, b in zip(now, self._saved)))

    def offer_to_save(self) -> bool:
        """Before the studio quits: offer to save library edits not yet written (Save, Discard, Cancel).

        Returns:
            False when the user cancelled (or chose Save and the library could not be saved).
        """
        if not self.modified:
            return True
        names = self.changed_names()
        shown = ", ".join(names[:4]) + (f" and {len(names) - 4} more" if len(names) > 4 else "")
        answer = dialogs.ask(self.window(), "Unsaved library changes",
                             f"The material library has changes not saved to {self.save_target()} ({shown}). "
                             f"Save them?", {"save": "Save", "discard": "Discard", "cancel": "Cancel"},
                             "save")
        if answer == "cancel":
            return False
        return answer == "discard" or self.save() is not None
