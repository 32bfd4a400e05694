"""The brush bar's region picker: keep a stroke inside a facial region, keep it out of one, or fill one.

A :class:`RegionPicker` lists the head's regions (:attr:`painting.Document.regions`; those it lacks are
greyed out with the reason as a tooltip), a mode ("inside" or "avoid") and a **Fill** button that fills
the picked region of the selected layer to the material's default thickness with the region's soft
edge (:meth:`painting.Document.fill_region`, one undo step). The window asks :meth:`brush_options` for
the ``region``/``region_mode`` of each new :class:`painting.Brush`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QComboBox, QHBoxLayout, QLabel, QPushButton, QWidget

from painting.regions import REGION_NAMES

if TYPE_CHECKING:
    from painting import Document

NO_REGION = "(anywhere)"


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
        self.mode_combo = QComboBox()
        self.mode_combo.addItems(["inside", "avoid"])
        self.mode_combo.setToolTip("inside: the stroke stays in the region (fading over its feather); "
                                   "avoid: the stroke never paints it")
        self.fill_button = QPushButton("Fill")
        self.fill_button.setToolTip("Fill the region on the selected layer (soft edge; one undo step)")
        layout = QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        for w in (QLabel(" Region "), self.region_combo, self.mode_combo, self.fill_button):
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
