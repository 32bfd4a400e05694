"""The layers panel: a view of the document's layers that sends commands back (it holds no truth).

Top of the list = top layer. Drag to reorder, double-click to rename, tick to show/hide; opacity,
maximum thickness, material, delete, import/export of the thickness map; a swatch of each layer's material
as applied (on the reference skin or lip at its default thickness); the
selected layer's mask (:class:`app.studio.mask_editor.MaskEditor`, once :meth:`LayersPanel.attach_document`
has named the document).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from PySide6.QtCore import Qt, QTimer, Signal, SignalInstance
from PySide6.QtGui import QColor, QDropEvent, QIcon, QPixmap
from PySide6.QtWidgets import (
    QAbstractItemView,
    QComboBox,
    QFormLayout,
    QHBoxLayout,
    QListWidget,
    QListWidgetItem,
    QPushButton,
    QSlider,
    QVBoxLayout,
    QWidget,
)

from app.studio.number_fields import NumberField

if TYPE_CHECKING:
    from app.studio.mask_editor import MaskEditor
    from km.library import Library
    from km.material import Material
    from painting import Document
    from painting.layer import Layer


def material_rgb(material: Material, thickness_um: float | None = None,
                 background: tuple[float, float, float] | None = None) -> tuple[int, int, int]:
    """The sRGB colour (0..255 per channel) of a km material as a swatch shows it.

    Its opaque colour (R∞) when ``thickness_um`` is None, else a layer of ``thickness_um`` µm over
    ``background`` (linear RGB in [0, 1]; black when None). The spectra and colours are ``km``'s
    (``Material.swatch_rgb``, ``Material.rt``, km's spectral → RGB matrix, ``km.over``).
    """
    import km
    from km.cache import spectral_rgb_matrix_cached
    from km.srgb import srgb_encode

    if thickness_um is None:
        srgb = material.swatch_rgb("opaque")
    elif background is None or not any(background):
        srgb = material.swatch_rgb("black", thickness_um)
    else:
        r0, t = material.rt(float(thickness_um))
        m = spectral_rgb_matrix_cached(np.asarray(material.wavelengths, float))  # = km.spectrum_to_rgb's
        r_rgb = np.asarray(r0, float) @ m
        t_rgb = np.asarray(t, float) @ m
        bg = np.clip(np.asarray(background, float), 0.0, 1.0)
        lin = km.over(np.clip(r_rgb, 0.0, 1.0), np.clip(t_rgb, 0.0, 1.0), bg)
        srgb = srgb_encode(np.clip(np.asarray(lin, float), 0.0, 1.0))
    return tuple(int(round(float(c) * 255)) for c in np.clip(srgb, 0.0, 1.0))  # type: ignore[return-value]


def applied_rgb(material: Material, background: tuple[float, float, float] | np.ndarray | None = None
                ) -> tuple[int, int, int]:
    """The sRGB colour (0..255 per channel) of a layer of ``material`` at its default thickness, as applied.

    On ``background`` (linear RGB in [0, 1]), else on the reference skin or lip of its category
    (``km.Material.applied_rgb``: composed as the renderer composes a texel, so the swatch is what the
    viewport shows under a white light).
    """
    from km.srgb import srgb_encode

    lin = material.applied_rgb("reference" if background is None else np.asarray(background, float))
    srgb = srgb_encode(np.clip(np.asarray(lin, float), 0.0, 1.0))
    return tuple(int(round(float(c) * 255)) for c in np.clip(srgb, 0.0, 1.0))  # type: ignore[return-value]


def applied_swatch_of(material: Material) -> tuple[int, int, int] | None:
    """The material as applied on its reference skin or lip (:func:`applied_rgb`), or None (see colours_ready)."""
    return applied_rgb(material) if colours_ready() else None


def colours_ready() -> bool:
    """Whether km's spectral → RGB matrix of the materials' grid is at hand without colour-science.

    It is when it is in km's disk cache, or colour-science is loaded. The first run on a machine makes
    it in a worker at start-up (render.view.preload_renderer: colour-science with matplotlib takes
    seconds); until then the swatches are grey placeholders, so the window never waits for it.
    """
    import sys

    from km.cache import spectral_rgb_matrix_ready
    from km.spectra import DEFAULT_GRID

    return "km.colour" in sys.modules or spectral_rgb_matrix_ready(DEFAULT_GRID.wavelengths)


def swatch_of(material: Material) -> tuple[int, int, int] | None:
    """The material's opaque colour, or None until km's colour maths is loaded (see colours_ready)."""
    return material_rgb(material) if colours_ready() else None


def swatch_icon(rgb: tuple[int, int, int] | None, size: int = 28) -> QIcon:
    """A square icon of ``rgb`` (a neutral grey placeholder for None)."""
    pm = QPixmap(size, size)
    pm.fill(QColor(*(rgb if rgb is not None else (128, 128, 128))))
    icon = QIcon(pm)
    icon.addPixmap(pm, QIcon.Mode.Selected)  # keep the true colour on the selected row
    return icon


class LayerList(QListWidget):
    """The layers as list rows (top layer first) that can be reordered by dragging.

    A drop emits ``moved(from row, to row)`` once the drag has finished; the list itself is rebuilt from
    the document's answer.
    """

    moved = Signal(int, int)  # (from row, to row)

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setDragDropMode(QAbstractItemView.DragDropMode.InternalMove)
        self.setDefaultDropAction(Qt.DropAction.MoveAction)
        self._drag_row = -1

    def startDrag(self, actions: Qt.DropAction) -> None:  # noqa: N802
        """Remember the row being dragged."""
        self._drag_row = self.currentRow()
        super().startDrag(actions)

    def dropEvent(self, event: QDropEvent) -> None:  # noqa: N802
        """Report the move of the dragged row (after Qt has moved the item)."""
        src = self._drag_row
        super().dropEvent(event)
        dst = self.currentRow()
        if src >= 0 and dst >= 0 and src != dst:
            # after the drag has finished: the document's answer rebuilds this list
            QTimer.singleShot(0, lambda: self.moved.emit(src, dst))


class LayersPanel(QWidget):
    """The document's layers as a list (top layer first) with their controls.

    The panel holds no truth: every change is a request signal (document indices, 0 = bottom layer) the
    window turns into a document command; the document's change events then :meth:`refresh` the panel.
    The selected layer's fields (material, opacity, maximum thickness) show that layer, whenever the
    selection changes, and a field sends a request only when the user changed its value.
    """

    add_requested = Signal(str)
    remove_requested = Signal(int)
    move_requested = Signal(int, int)
    rename_requested = Signal(int, str)
    visibility_requested = Signal(int, bool)
    opacity_requested = Signal(int, float)
    max_thickness_requested = Signal(int, float)
    material_requested = Signal(int, str)
    import_requested = Signal(int)
    export_requested = Signal(int)
    selection_changed = Signal(int)

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._count = 0
        self._updating = False
        self._layers: list[Layer] = []  # the document's layers shown (bottom first), as last refreshed
        self._shown: dict[str, object] = {}  # the selected layer's values as its fields show them
        self.list = LayerList()
        self.list.setIconSize(self.list.iconSize().expandedTo(self.list.iconSize() * 1.6))
        self.material = QComboBox()
        self.add_button = QPushButton("Add Layer")
        self.delete_button = QPushButton("Delete")
        self.import_button = QPushButton("Import Map…")
        self.export_button = QPushButton("Export Map…")
        self.opacity = QSlider(Qt.Orientation.Horizontal)
        self.opacity.setRange(0, 100)
        self.max_thickness = NumberField()
        self.max_thickness.setRange(0.1, 500.0)
        self.max_thickness.setSuffix(" µm")
        self.layer_material = QComboBox()
        top = QHBoxLayout()
        top.addWidget(self.material, 1)
        top.addWidget(self.add_button)
        form = QFormLayout()
        form.addRow("Material", self.layer_material)
        form.addRow("Opacity", self.opacity)
        form.addRow("Max thickness", self.max_thickness)
        buttons = QHBoxLayout()
        for b in (self.delete_button, self.import_button, self.export_button):
            buttons.addWidget(b)
        self.mask_editor: MaskEditor | None = None
        lay = QVBoxLayout(self)
        lay.addLayout(top)
        lay.addWidget(self.list, 1)
        lay.addLayout(form)
        lay.addLayout(buttons)
        self._box = lay
        self.add_button.clicked.connect(lambda: self.add_requested.emit(self.material.currentText()))
        self.delete_button.clicked.connect(lambda: self._emit_current(self.remove_requested))
        self.import_button.clicked.connect(lambda: self._emit_current(self.import_requested))
        self.export_button.clicked.connect(lambda: self._emit_current(self.export_requested))
        self.list.moved.connect(lambda a, b: self.move_requested.emit(self.doc_index(a), self.doc_index(b)))
        self.list.itemChanged.connect(self._item_changed)
        self.list.currentRowChanged.connect(lambda _r: self._updating or self._show_selected())
        self.list.currentRowChanged.connect(lambda r: self.selection_changed.emit(self.doc_index(r)))
        self.list.currentRowChanged.connect(lambda _r: self._updating or self._refresh_mask())
        # one undo step per gesture: while the handle is dragged, only its release counts
        self.opacity.sliderReleased.connect(lambda: self._field_edited("opacity"))
        self.opacity.valueChanged.connect(
            lambda _v: None if self.opacity.isSliderDown() else self._field_edited("opacity"))
        self.max_thickness.editingFinished.connect(lambda: self._field_edited("max_thickness"))
        self.layer_material.activated.connect(lambda _i: self._field_edited("material"))

    def attach_document(self, doc: Document) -> MaskEditor:
        """Edit the selected layer's mask in ``doc`` (adds the mask editor below the layer's controls)."""
        from app.studio.mask_editor import MaskEditor

        if self.mask_editor is None:
            self.mask_editor = MaskEditor(doc, self.current_index)
            self._box.addWidget(self.mask_editor)
        self._refresh_mask()
        return self.mask_editor

    @property
    def paint_mask(self) -> bool:
        """Strokes paint the selected layer's mask (the mask editor's "Paint mask"), not its thickness."""
        return self.mask_editor is not None and self.mask_editor.paint_mask

    def _refresh_mask(self) -> None:
        if self.mask_editor is not None:
            self.mask_editor.refresh()

    def doc_index(self, row: int) -> int:
        """The document index (0 = bottom) of list row ``row`` (0 = top); -1 for no row."""
        return -1 if row < 0 else self._count - 1 - row

    def current_index(self) -> int:
        """The document index of the selected layer; -1 when none is selected."""
        return self.doc_index(self.list.currentRow())

    def _field_values(self) -> dict[str, object]:
        return {"opacity": self.opacity.value(), "max_thickness": float(self.max_thickness.value()),
                "material": self.layer_material.currentText()}

    def _field_edited(self, field: str) -> None:
        """The user left or moved a field of the selected layer: request its value, if it is another."""
        value = self._field_values()[field]
        if self._updating or value == self._shown.get(field):
            return  # e.g. tabbing through a field: nothing asked for
        self._shown[field] = value
        if field == "opacity":
            self._emit_current(self.opacity_requested, self.opacity.value() / 100.0)
        elif field == "max_thickness":
            self._emit_current(self.max_thickness_requested, value)
        else:
            self._emit_current(self.material_requested, value)

    def _show_selected(self) -> None:
        """Show the selected layer's material, opacity and maximum thickness in its fields."""
        i = self.current_index()
        if not 0 <= i < len(self._layers):
            self._shown = {}
            return
        lay = self._layers[i]
        was, self._updating = self._updating, True
        self.opacity.setValue(int(round(lay.opacity * 100)))
        self.max_thickness.setValue(float(lay.max_thickness))
        self.layer_material.setCurrentText(lay.material)
        self._updating = was
        self._shown = self._field_values()

    def _emit_current(self, signal: SignalInstance, *extra: object) -> None:
        if self._updating:
            return
        i = self.current_index()
        if i >= 0:
            signal.emit(i, *extra)

    def _item_changed(self, item: QListWidgetItem) -> None:
        if self._updating:
            return
        # read everything first: a request rebuilds the list (and deletes this item)
        i = self.doc_index(self.list.row(item))
        name = item.text().strip()
        renamed = bool(name) and item.data(Qt.ItemDataRole.UserRole) != name
        visible = item.checkState() == Qt.CheckState.Checked
        toggled = item.data(Qt.ItemDataRole.UserRole + 1) != visible
        if renamed:
            self.rename_requested.emit(i, name)
        elif toggled:
            self.visibility_requested.emit(i, visible)

    def set_materials(self, library: Library) -> None:
        """Offer ``library``'s materials (with swatches) for new layers and for the selected layer."""
        current = self.material.currentText()
        self._updating = True
        for combo in (self.material, self.layer_material):
            combo.clear()
            for m in library:
                combo.addItem(swatch_icon(swatch_of(m), 16), m.name)
        if current:
            self.material.setCurrentText(current)
        self._updating = False

    def refresh(self, layers: list[Layer], library: Library, select: int | None = None) -> None:
        """Rebuild from the document's layers (bottom first), selecting document index ``select``.

        With ``select`` None the selection is kept; it is clamped to the layers there are.
        """
        keep = self.current_index() if select is None else select
        self._updating = True
        self.list.clear()
        self._count = len(layers)
        self._layers = list(layers)
        for lay in reversed(layers):
            item = QListWidgetItem(lay.name)
            item.setFlags(item.flags() | Qt.ItemFlag.ItemIsEditable | Qt.ItemFlag.ItemIsUserCheckable
                          | Qt.ItemFlag.ItemIsDragEnabled)
            item.setCheckState(Qt.CheckState.Checked if lay.visible else Qt.CheckState.Unchecked)
            item.setData(Qt.ItemDataRole.UserRole, lay.name)
            item.setData(Qt.ItemDataRole.UserRole + 1, bool(lay.visible))
            item.setToolTip(f"{lay.material} · opacity {lay.opacity:.0%} · max {lay.max_thickness:g} µm")
            if lay.material in library:  # the material as applied (a layer of it on the reference skin or lip)
                item.setIcon(swatch_icon(applied_swatch_of(library.get(lay.material))))
            self.list.addItem(item)
        if self._count:
            keep = min(max(keep, 0), self._count - 1)
            self.list.setCurrentRow(self._count - 1 - keep)
        self._show_selected()
        for w in (self.delete_button, self.import_button, self.export_button, self.opacity,
                  self.max_thickness, self.layer_material):
            w.setEnabled(self._count > 0)
        self._updating = False
        self._refresh_mask()
