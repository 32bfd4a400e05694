"""The studio's Shade Finder dock: which foundation of the library matches this skin, under which lights.

The skin comes from the head's albedo (:meth:`painting.head.Head.skin_rgb`, the median of its middle third,
as the library dock's "on this head" swatch) or from a colour typed as sRGB ``R,G,B``; it is fitted with the
biophysical skin model (:func:`km.skin.fit_skin`) and every foundation is ranked on it (:func:`shade.match.match_shades`): the
table shows each shade's swatch over that skin, its best thickness, ΔE2000 under the chosen light and
under daylight / the store's light / warm indoor light, and the metamerism warning in plain words.
"Apply to foundation layer" gives the document's foundation layer (the first layer whose material is
a foundation; a new one when there is none) the chosen shade, as one undoable step; the painted
thickness map is kept (the finder's best thickness is shown beside it). pyqtgraph plots show the
fitted skin's spectrum, the target and the made-up skin, and the coverage of the library over a
population of skins (L* against hue angle, coloured by the best ΔE2000), computed in a worker.

Not here yet: picking the skin by clicking the face in the viewport (it needs a pick signal from the
viewport, which another change is reworking); the head's albedo is used instead.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QComboBox,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)

if TYPE_CHECKING:
    from collections.abc import Callable

    from app.session import Session
    from km.skin import SkinFit
    from shade.coverage import Coverage
    from shade.match import ShadeMatch

#: choices offered (any CIE name works in the CLI)
ILLUMINANTS = ("D65", "D50", "A", "F2", "F11")
STORE_LIGHTS = ("F11", "F2", "F7", "LED-B3", "LED-B4")
TARGETS = ("own", "lighter", "darker", "warmer", "cooler")
#: skins of the studio's coverage run (the CLI's default is 1,000)
COVERAGE_SKINS = 400
_COLUMNS = ("", "Shade", "µm", "ΔE00", "D65", "store", "A", "Note")
#: the spectra plot's pens: the fitted skin's, and the made-up skin's (dashed)
SKIN_PEN, SHADE_PEN = "#e0a050", "#50a0e0"


class ShadeFinder(QWidget):
    """The Shade Finder panel (see the module docstring).

    Args:
        session: the studio's session (its library and document).
        head_skin: returns the head's skin colour, linear sRGB (3 floats in [0, 1]).

    Attributes:
        fit: the current skin fit (None before the first match).
        results: the ranked shades of the last match.
        coverage: the last coverage run (None before one).
    """

    def __init__(self, session: Session, head_skin: Callable[[], tuple[float, float, float]],
                 pick_on_face: Callable[[], None] | None = None) -> None:
        super().__init__()
        self.session = session
        self.head_skin = head_skin
        self.fit: SkinFit | None = None
        self.results: list[ShadeMatch] = []
        self.coverage: Coverage | None = None
        self._target_r: np.ndarray | None = None
        self.spectra_plot: Any = None
        self.coverage_plot: Any = None

        self.rgb_edit = QLineEdit()
        self.rgb_edit.setPlaceholderText("sRGB R,G,B (0-255)")
        self.rgb_edit.returnPressed.connect(self.match_typed)
        head_button = QPushButton("Use the head's skin")
        head_button.clicked.connect(self.match_head)
        self.pick_button = QPushButton("Pick the skin on the face")
        self.pick_button.setToolTip("then click the skin in the view: its colour (the head's albedo there, "
                                    "a 2 mm median) is matched")
        self.pick_button.setEnabled(pick_on_face is not None)
        if pick_on_face is not None:
            self.pick_button.clicked.connect(lambda: (pick_on_face(), self.status.setText(
                "Click the skin on the face in the view (cheek or jaw, away from hair and lips).")))
        match_button = QPushButton("Match")
        match_button.clicked.connect(self.match_typed)
        self.illuminant = self._combo(ILLUMINANTS)
        self.store_light = self._combo(STORE_LIGHTS)
        self.target = self._combo(TARGETS)
        self.status = QLabel("Pick a skin: the head's, one on the face, or type its colour.")
        self.status.setWordWrap(True)
        self.table = QTableWidget(0, len(_COLUMNS))
        self.table.setHorizontalHeaderLabels(_COLUMNS)
        self.table.setSelectionBehavior(QTableWidget.SelectionBehavior.SelectRows)
        self.table.setSelectionMode(QTableWidget.SelectionMode.SingleSelection)
        self.table.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        self.table.verticalHeader().setVisible(False)
        self.table.itemSelectionChanged.connect(self._plot_spectra)
        self.apply_button = QPushButton("Apply to foundation layer")
        self.apply_button.setEnabled(False)
        self.apply_button.clicked.connect(self.apply_selected)
        coverage_button = QPushButton("Coverage of the range…")
        coverage_button.clicked.connect(self.start_coverage)
        self.coverage_label = QLabel()
        self.coverage_label.setWordWrap(True)
        self.plots = QVBoxLayout()

        row = QHBoxLayout()
        row.addWidget(self.rgb_edit, 1)
        row.addWidget(match_button)
        form = QFormLayout()
        form.addRow("Light", self.illuminant)
        form.addRow("Store light", self.store_light)
        form.addRow("Target", self.target)
        layout = QVBoxLayout(self)
        buttons = QHBoxLayout()
        buttons.addWidget(head_button)
        buttons.addWidget(self.pick_button)
        layout.addLayout(buttons)
        layout.addLayout(row)
        layout.addLayout(form)
        layout.addWidget(self.status)
        layout.addWidget(self.table, 2)
        layout.addWidget(self.apply_button)
        layout.addLayout(self.plots, 2)
        layout.addWidget(coverage_button)
        layout.addWidget(self.coverage_label)

    def _combo(self, items: tuple[str, ...]) -> QComboBox:
        box = QComboBox()
        box.addItems(list(items))
        box.currentIndexChanged.connect(lambda _i: self.rematch())
        return box

    # ------------------------------------------------------------------ matching
    def match_head(self) -> None:
        """Fit the head's skin colour and rank the shades."""
        self.match_linear(np.asarray(self.head_skin(), dtype=np.float64), "the head's skin")

    def match_typed(self) -> None:
        """Fit the typed sRGB colour and rank the shades (a malformed entry is said in the status line)."""
        from km.srgb import srgb_decode

        try:
            rgb = np.array([float(v) for v in self.rgb_edit.text().split(",")])
        except ValueError:
            rgb = np.zeros(0)
        if rgb.shape != (3,) or not ((rgb >= 0) & (rgb <= 255)).all():
            self.status.setText("Type the skin colour as R,G,B with values 0-255 (sRGB).")
            return
        self.match_linear(srgb_decode(rgb / 255.0), f"sRGB {self.rgb_edit.text().strip()}")

    def match_linear(self, linear_rgb: np.ndarray, label: str) -> None:
        """Fit ``linear_rgb`` (linear sRGB) and rank the shades; errors are shown in the status line."""
        from core.errors import SheerError
        from km.skin import fit_skin

        try:
            self.fit = fit_skin(linear_rgb=linear_rgb)
        except SheerError as exc:
            self.status.setText(str(exc))
            return
        self._label = label
        self.rematch()

    def rematch(self) -> None:
        """Rank the shades again for the current skin, light and target (nothing before a skin is fitted)."""
        from core.errors import SheerError
        from shade.match import ShadeBank, confidence, foundations, make_target, match_shades

        if self.fit is None:
            return
        try:
            bank = ShadeBank.from_materials(foundations(self.session.library))
            target = make_target(self.target.currentText(), self.fit)
            lights = tuple(dict.fromkeys(("D65", self.store_light.currentText(), "A")))
            self.results = match_shades(self.fit.reflectance, target.reflectance, bank,
                                        illuminant=self.illuminant.currentText(), lights=lights)
        except SheerError as exc:
            self.results = []
            self.status.setText(str(exc))
            self._fill_table()
            return
        self._target_r = target.reflectance
        p = self.fit.params
        sure = confidence(self.fit)  # the command line's and the kiosk's reading of the same fit
        self.status.setText(f"{self._label}: melanin {100 * p.melanin:.1f} %, blood {100 * p.blood:.2f} %, "
                            f"scattering ×{p.scattering:.2f}; {sure.level} confidence: {sure.words}")
        self._fill_table()

    def _fill_table(self) -> None:
        self.table.setRowCount(len(self.results))
        store = self.store_light.currentText()
        for row, s in enumerate(self.results):
            swatch = QTableWidgetItem()
            swatch.setBackground(QColor(s.swatch_hex))
            swatch.setToolTip(f"{s.name} at {s.thickness_um:.1f} µm over this skin ({s.swatch_hex}, D65)")
            by = s.de2000_by_illuminant
            cells = [swatch, QTableWidgetItem(s.name), QTableWidgetItem(f"{s.thickness_um:.1f}"),
                     QTableWidgetItem(f"{s.de2000:.2f}"), QTableWidgetItem(f"{by['D65']:.2f}"),
                     QTableWidgetItem(f"{by[store]:.2f}"), QTableWidgetItem(f"{by['A']:.2f}"),
                     QTableWidgetItem(s.metamerism_words())]
            for col, item in enumerate(cells):
                self.table.setItem(row, col, item)
        self.table.resizeColumnsToContents()
        if self.results:
            self.table.selectRow(0)
            self._plot_spectra()  # the selection may not have changed (same row), the shades have
        self.apply_button.setEnabled(bool(self.results))

    def selected(self) -> ShadeMatch | None:
        """The shade selected in the table (the best one after a match)."""
        rows = self.table.selectionModel().selectedRows()
        return self.results[rows[0].row()] if rows and rows[0].row() < len(self.results) else None

    # ------------------------------------------------------------------ applying
    def apply_selected(self) -> None:
        """Give the foundation layer the selected shade (one undo step; a new layer when there is none)."""
        from core.errors import SheerError

        shade = self.selected()
        if shade is None:
            return
        doc, lib = self.session.document, self.session.library
        index = next((i for i, lay in enumerate(doc.layers)
                      if lay.material in lib and lib.get(lay.material).category == "foundation"), None)
        try:
            if index is None:
                doc.add_layer(shade.name, name=shade.name, max_thickness=float(lib.get(shade.name).max_thickness_um))
                done = f"added a layer of {shade.name}"
            else:
                doc.set_layer(index, material=shade.name)
                done = f"layer '{doc.layers[index].name}' is now {shade.name}"
        except (SheerError, ValueError) as exc:
            self.status.setText(f"Cannot apply {shade.name}: {exc}")
            return
        self.status.setText(f"{done}; the finder's best thickness is {shade.thickness_um:.1f} µm.")

    # ------------------------------------------------------------------ plots
    def _build_plots(self) -> None:
        if self.spectra_plot is not None:
            return
        import pyqtgraph as pg  # imported on first use: it costs about a second

        from app.studio.plots import legend_below, plain_axis

        self.spectra_plot = pg.PlotWidget()
        self.spectra_plot.setLabel("bottom", "wavelength", units="nm")
        plain_axis(self.spectra_plot, "left", "reflectance")  # a fraction (0.2–0.6), never "200–600"
        legend_below(self.spectra_plot, 3)
        self.spectra_plot.setMinimumHeight(170)
        self.spectra_plot.showGrid(x=True, y=True, alpha=0.2)
        self.plots.addWidget(self.spectra_plot)

    def _build_coverage_plot(self) -> None:
        """The coverage's plot, made with the first coverage: until then there is nothing to plot."""
        if self.coverage_plot is not None:
            return
        import pyqtgraph as pg

        from app.studio.plots import plain_axis

        self.coverage_plot = pg.PlotWidget()
        plain_axis(self.coverage_plot, "bottom", "hue angle h_ab (°)")
        plain_axis(self.coverage_plot, "left", "L*")
        self.coverage_plot.setMinimumHeight(160)
        self.coverage_plot.showGrid(x=True, y=True, alpha=0.2)
        self.plots.addWidget(self.coverage_plot)

    def _plot_spectra(self) -> None:
        import pyqtgraph as pg

        shade = self.selected()
        if self.fit is None or shade is None:
            return
        self._build_plots()
        wl = self.fit.grid.wavelengths
        self.spectra_plot.clear()
        # fixed, distinct colours: the shade's own colour is a skin tone too, as the skin's is
        self.spectra_plot.plot(wl, self.fit.reflectance, pen=pg.mkPen(SKIN_PEN, width=2), name="fitted skin")
        if self._target_r is not None and self.target.currentText() != "own":
            self.spectra_plot.plot(wl, self._target_r, pen=pg.mkPen("#909090", width=1, style=Qt.PenStyle.DashLine),
                                   name="target")
        self.spectra_plot.plot(wl, shade.reflectance, pen=pg.mkPen(SHADE_PEN, width=2, style=Qt.PenStyle.DashLine),
                               name=f"{shade.name} @ {shade.thickness_um:.0f} µm")

    def start_coverage(self) -> None:
        """Compute the library's coverage of :data:`COVERAGE_SKINS` skins in a worker, then plot it."""
        from app.studio import dialogs
        from app.workers import run_task

        illuminant = self.illuminant.currentText()  # read here: the job runs in a pool thread
        run_task(self, "Coverage of the foundation range",
                 lambda _progress, _cancelled: self.compute_coverage(illuminant=illuminant),
                 self.show_coverage, lambda msg: dialogs.error(self, "Shade Finder", msg))

    def compute_coverage(self, skins: int = COVERAGE_SKINS, illuminant: str = "D65") -> Coverage:
        """The coverage of the library's foundations over ``skins`` skins (any thread; no widget touched)."""
        from shade.coverage import coverage
        from shade.match import ShadeBank, foundations

        bank = ShadeBank.from_materials(foundations(self.session.library))
        return coverage(bank, skins, illuminant=illuminant)

    def show_coverage(self, cov: Coverage) -> None:
        """Plot a coverage (L* against hue, coloured by the best ΔE2000) and name the gap's suggested shade."""
        import pyqtgraph as pg

        self.coverage = cov
        self._build_plots()
        self._build_coverage_plot()
        cmap = pg.colormap.get("viridis")
        scale = np.clip(cov.best_de2000 / max(2.0 * cov.threshold, 1e-9), 0.0, 1.0)
        colours = cmap.map(1.0 - scale, mode="qcolor")
        self.coverage_plot.clear()
        self.coverage_plot.addItem(pg.ScatterPlotItem(cov.hue_deg, cov.lab[:, 0], size=5, pen=None,
                                                      brush=[pg.mkBrush(c) for c in colours]))
        text = (f"{len(cov.best_de2000)} skins, {100 * cov.served_fraction:.0f} % within ΔE00 {cov.threshold:g} "
                "(yellow: served, dark: not)")
        if cov.gap is not None:
            gap = cov.gap.gap_skins
            self.coverage_plot.addItem(pg.ScatterPlotItem(cov.hue_deg[gap], cov.lab[gap, 0], size=9,
                                                          pen=pg.mkPen("r"), brush=None))
            recipe = " + ".join(f"{100 * c:.0f} % {n}" for n, c in cov.gap.recipe.items())
            text += (f". Largest gap (red): {gap.size} skins; a new shade of {recipe} would take their mean "
                     f"ΔE00 from {cov.gap.mean_de_before:.1f} to {cov.gap.mean_de_after:.1f}.")
        self.coverage_label.setText(text)
