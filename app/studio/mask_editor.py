"""The layers panel's mask editor: the selected layer's mask from facial regions, inverted, feathered, painted.

A :class:`MaskEditor` shows the selected layer's :class:`painting.mask.LayerMask` recipe — regions in
order, each added (∪, union) or taken away (−, subtract) — with **Invert** and **Feather** (mm), and edits
it through :meth:`painting.Document.set_layer_mask` (one undo step per edit; the paint channel is kept).
**Paint mask** turns the brush's target to the mask's paint channel (:meth:`painting.Document.mask_stroke`:
add reveals, erase hides); the window asks :attr:`MaskEditor.paint_mask` when a stroke begins. **Clear**
removes the recipe and the channel. Regions the head lacks are not offered. Errors are one-line messages.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from PySide6.QtCore import Qt
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QGridLayout,
    QGroupBox,
    QListWidget,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from app.studio.number_fields import NumberField

if TYPE_CHECKING:
    from collections.abc import Callable

    from painting import Document
    from painting.layer import Layer

#: How each recipe op is shown in the list.
OP_SIGN = {"union": "∪", "subtract": "−"}


class MaskEditor(QGroupBox):
    """The selected layer's mask (see the module docstring).

    Args:
        doc: the document whose layers' masks are edited.
        layer_index: returns the selected layer's document index (-1 for none).
    """

    def __init__(self, doc: Document, layer_index: Callable[[], int], parent: QWidget | None = None) -> None:
        super().__init__("Mask", parent)
        self.doc = doc
        self.layer_index = layer_index
        self._updating = False
        self.entries = QListWidget()
        self.entries.setMaximumHeight(72)
        self.region_combo = QComboBox()
        self.add_button = QPushButton("∪ Add")
        self.add_button.setToolTip("Show the layer inside this region too (union)")
        self.subtract_button = QPushButton("− Subtract")
        self.subtract_button.setToolTip("Hide the layer inside this region")
        self.remove_button = QPushButton("Remove")
        self.remove_button.setToolTip("Remove the selected region from the mask")
        self.invert_check = QCheckBox("Invert")
        self.feather_spin = NumberField()
        self.feather_spin.setRange(0.0, 50.0)
        self.feather_spin.setSingleStep(0.5)
        self.feather_spin.setSuffix(" mm")
        self.feather_spin.setToolTip("Extra soft edge of the mask (mm)")
        self.paint_check = QCheckBox("Paint mask")
        self.paint_check.setToolTip("Strokes paint this layer's mask: add reveals, erase hides")
        self.clear_button = QPushButton("Clear")
        self.clear_button.setToolTip("Remove the mask (its regions and its painted channel)")
        grid = QGridLayout()
        grid.addWidget(self.region_combo, 0, 0, 1, 3)
        grid.addWidget(self.add_button, 1, 0)
        grid.addWidget(self.subtract_button, 1, 1)
        grid.addWidget(self.remove_button, 1, 2)
        grid.addWidget(self.invert_check, 2, 0)
        grid.addWidget(self.feather_spin, 2, 1, 1, 2)
        grid.addWidget(self.paint_check, 3, 0, 1, 2)
        grid.addWidget(self.clear_button, 3, 2)
        box = QVBoxLayout(self)
        box.addWidget(self.entries)
        box.addLayout(grid)
        self.add_button.clicked.connect(lambda: self._add("union"))
        self.subtract_button.clicked.connect(lambda: self._add("subtract"))
        self.remove_button.clicked.connect(self._remove)
        self.invert_check.toggled.connect(lambda on: self._edit(invert=bool(on)))
        self.feather_spin.editingFinished.connect(lambda: self._edit(feather_mm=float(self.feather_spin.value())))
        self.clear_button.clicked.connect(self._clear)
        self.refresh_regions()
        self.refresh()

    @property
    def paint_mask(self) -> bool:
        """Strokes paint the selected layer's mask channel instead of its thickness."""
        return self.paint_check.isChecked() and self.paint_check.isEnabled()

    def refresh_regions(self) -> None:
        """Offer the regions the document's head has."""
        self.region_combo.clear()
        for name in self.doc.regions.names():
            self.region_combo.addItem(name.replace("_", " "), name)

    def _layer(self) -> Layer | None:
        i = self.layer_index()
        return self.doc.layers[i] if 0 <= i < len(self.doc.layers) else None

    def refresh(self) -> None:
        """Show the selected layer's mask (everything disabled when no layer is selected)."""
        from painting.mask import LayerMask

        lay = self._layer()
        mask = lay.mask if lay is not None and lay.mask is not None else LayerMask()
        self._updating = True
        self.entries.clear()
        for op, name in mask.regions:
            self.entries.addItem(f"{OP_SIGN.get(op, op)} {name.replace('_', ' ')}")
        self.invert_check.setChecked(bool(mask.invert))
        self.feather_spin.setValue(float(mask.feather_mm))
        on = lay is not None
        for w in (self.entries, self.region_combo, self.add_button, self.subtract_button, self.invert_check,
                  self.feather_spin, self.paint_check):
            w.setEnabled(on)
        self.remove_button.setEnabled(on and bool(mask.regions))
        self.clear_button.setEnabled(on and lay is not None and lay.has_mask)
        self.setTitle(f"Mask of {lay.name}" if lay is not None else "Mask")
        self._updating = False

    def _apply(self, lay: Layer, mask: object, channel: object) -> None:
        from app.studio import dialogs
        from core.errors import SheerError

        try:
            self.doc.set_layer_mask(lay, mask, channel)  # type: ignore[arg-type]
        except (SheerError, ValueError) as exc:
            dialogs.error(self, "Mask", str(exc))
        self.refresh()

    def _edit(self, **changes: object) -> None:
        """Replace the selected layer's recipe with ``changes`` applied (its channel kept)."""
        import dataclasses

        from painting.mask import LayerMask

        lay = self._layer()
        if self._updating or lay is None:
            return
        current = lay.mask if lay.mask is not None else LayerMask()
        new = dataclasses.replace(current, **changes)  # type: ignore[arg-type]
        if new == current:
            return
        self._apply(lay, new, lay.mask_channel)

    def _add(self, op: str) -> None:
        from painting.mask import LayerMask

        lay = self._layer()
        name = self.region_combo.currentData()
        if lay is None or not name:
            return
        current = lay.mask if lay.mask is not None else LayerMask()
        self._edit(regions=(*current.regions, (op, str(name))))

    def _remove(self) -> None:
        lay = self._layer()
        row = self.entries.currentRow()
        if lay is None or lay.mask is None or not 0 <= row < len(lay.mask.regions):
            row = len(lay.mask.regions) - 1 if lay is not None and lay.mask is not None else -1
        if lay is None or lay.mask is None or row < 0:
            return
        regions = tuple(r for i, r in enumerate(lay.mask.regions) if i != row)
        self._edit(regions=regions)

    def _clear(self) -> None:
        lay = self._layer()
        if lay is not None and lay.has_mask:
            self._apply(lay, None, None)

    def keyPressEvent(self, event: object) -> None:  # noqa: N802
        """Delete removes the selected region entry."""
        if getattr(event, "key", lambda: None)() == Qt.Key.Key_Delete:
            self._remove()
            return
        super().keyPressEvent(event)  # type: ignore[arg-type]
