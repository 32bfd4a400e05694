"""The studio's toolbars: the brush bar and, on a row of its own under it, the view bar.

The brush bar: radius, strength, hardness, mode, mirror, the facial region the brush keeps to (region,
inside/avoid, Fill); the view bar: light, HDR environment, render mode, Before|After and the Regions
overlay's menu (outlines drawn over the view). Every control says what it does in its tooltip
(:data:`TOOLTIPS`); the renderer's debug views are View → Developer's, not the view bar's.

Two rows, as desktop editors set a tool's options apart from the view's: in one row the two bars need
1720 px since the brush bar's regions (issue #16), so at the studio's 1600 px (the screenshots') the
Before|After slider hid behind the toolbar's » extension button. In two rows every control shows down to the window's minimum width: 856 px with the docks (the
brush bar needs 794 px and the view bar 818–846 px with Xvfb's default font; the brush bar needed 967 px
while it held the Regions menu and a "Region" label, so below 967 px its region picker hid behind »), and
without them no less than the toolbars need (:class:`WholeToolBar`).
Mixed into :class:`app.studio.main_window.StudioWindow`, which owns the settings the controls change;
:meth:`StudioToolbars.restore_layout` keeps a layout saved by an older version (both bars in one row)
from coming back.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from PySide6.QtCore import QByteArray, QSize, Qt
from PySide6.QtWidgets import QCheckBox, QComboBox, QLabel, QSlider, QToolBar, QWidget

from app.settings import ENVIRONMENTS, LIGHT_PRESETS
from app.studio.number_fields import NumberField
from app.studio.region_picker import RegionPicker
from render.view import RENDER_MODES

if TYPE_CHECKING:
    from collections.abc import Callable

    from PySide6.QtCore import QSettings

    from app.view.viewport import Viewport
    from painting import Document

#: the version of the saved dock and toolbar layout (QMainWindow.saveState); a layout saved under another
#: version is not restored. 1: the View toolbar on its own row (a layout of version 0 kept it beside the
#: brush bar, where it overflows below 1720 px)
WINDOW_STATE_VERSION = 1

#: What each control of the two bars does, as its tooltip says (on the control and on its label).
TOOLTIPS: dict[str, str] = {
    "Radius": "Brush radius on the skin, in millimetres ( [ and ] make it smaller and larger)",
    "Strength": "How far one stroke builds the layer up towards its full thickness (Shift+[ and Shift+])",
    "Hardness": "The share of the radius painted at full strength: 0 a soft edge, 0.95 a hard one",
    "Mode": "add builds the layer up, erase takes it away (E), smooth evens it out (S)",
    "Mirror": "Paint the mirror image across the face's midline too (X)",
    "Light": "The key light's preset (Ctrl+drag on the view moves the light)",
    "HDR": "An HDR environment around the head, or none",
    "Render": "fast: separable subsurface scattering; reference: sum of Gaussians, slower (R); "
              "lightweight: a captured face (File → Open Captured Face…)",
    "Before|After": "Drag to show the face without makeup on the left part of the view (B)",
}


class WholeToolBar(QToolBar):
    """A toolbar that never hides controls behind its » extension button while it lies in a row.

    Its minimum width is its full width (the sum of its controls', as :meth:`sizeHint` reports them), so the
    window's minimum width includes each row of toolbars in full: whatever the font, the docks shown or the
    Regions button's count, the window cannot be made narrower than its toolbars. Upright (docked at a side)
    it keeps QToolBar's own minimum.
    """

    def minimumSizeHint(self) -> QSize:  # noqa: N802 (Qt's name)
        """The full size while horizontal (see the class doc), else QToolBar's."""
        full, least = self.sizeHint(), super().minimumSizeHint()
        if self.orientation() == Qt.Orientation.Horizontal:
            return QSize(full.width(), least.height())
        return least


class StudioToolbars:
    """The brush and view toolbars of :class:`app.studio.main_window.StudioWindow`.

    A mixin: the window holds the document, the viewport and the settings the controls change.
    """

    # what the window provides (see app.studio.main_window.StudioWindow)
    doc: Document
    viewport: Viewport
    qsettings: QSettings
    selected_layer: int

    if TYPE_CHECKING:  # what the window implements (never defined here: they would shadow QMainWindow's)
        def change_settings(self, **changes: object) -> None: ...  # noqa: D102
        def layer_command(self, fn: Callable[[], object]) -> None: ...  # noqa: D102
        def use_light_preset(self, name: str) -> None: ...  # noqa: D102
        def set_render_mode(self, mode: str) -> None: ...  # noqa: D102
        def addToolBar(self, toolbar: QToolBar) -> None: ...  # noqa: D102, N802
        def addToolBarBreak(self, area: Qt.ToolBarArea) -> None: ...  # noqa: D102, N802
        def restoreState(self, state: QByteArray, version: int = 0) -> bool: ...  # noqa: D102, N802

    def restore_layout(self) -> bool:
        """Put the docks and toolbars where the saved layout has them; True if there was one to restore.

        A layout saved under another :data:`WINDOW_STATE_VERSION` is ignored (the built-in layout stays).
        """
        state = self.qsettings.value("window/state")
        return isinstance(state, QByteArray) and self.restoreState(state, WINDOW_STATE_VERSION)

    def build_toolbars(self) -> None:
        """Make the brush bar and, on a row of its own under it, the view bar (the window calls it once)."""
        tb = WholeToolBar("Brush")
        tb.setObjectName("brush_toolbar")
        self.addToolBar(tb)
        self.radius_spin = NumberField()
        self.radius_spin.setRange(0.5, 100.0)
        self.radius_spin.setSuffix(" mm")
        self.strength_spin = NumberField()
        self.strength_spin.setRange(0.05, 1.0)
        self.strength_spin.setSingleStep(0.05)
        self.hardness_spin = NumberField()
        self.hardness_spin.setRange(0.0, 0.95)
        self.hardness_spin.setSingleStep(0.05)
        self.mode_combo = QComboBox()
        self.mode_combo.addItems(["add", "erase", "smooth"])
        self.mirror_check = QCheckBox("Mirror")
        self.mirror_check.setToolTip(TOOLTIPS["Mirror"])
        for label, w in (("Radius", self.radius_spin), ("Strength", self.strength_spin),
                         ("Hardness", self.hardness_spin), ("Mode", self.mode_combo)):
            _add_labelled(tb, label, w, TOOLTIPS[label])
        tb.addWidget(self.mirror_check)
        self.region_picker = RegionPicker(self.doc)  # stay inside / avoid / fill a facial region (issue #16)
        tb.addWidget(self.region_picker)
        self.region_picker.attach_overlay(self.viewport)  # its Regions menu outlines regions on the face
        self.region_picker.fill_requested.connect(
            lambda name: self.doc.layers and self.layer_command(
                lambda: self.doc.fill_region(self.doc.layers[self.selected_layer], name)))
        self.radius_spin.valueChanged.connect(lambda v: self.change_settings(brush_radius_mm=float(v)))
        self.strength_spin.valueChanged.connect(lambda v: self.change_settings(brush_strength=float(v)))
        self.hardness_spin.valueChanged.connect(lambda v: self.change_settings(brush_hardness=float(v)))
        self.mode_combo.currentTextChanged.connect(lambda t: self.change_settings(brush_mode=t))
        self.mirror_check.toggled.connect(lambda on: self.change_settings(brush_mirror=bool(on)))
        # the view's controls on a row of their own under the brush's (see the module doc)
        self.addToolBarBreak(Qt.ToolBarArea.TopToolBarArea)
        vb = WholeToolBar("View")
        vb.setObjectName("view_toolbar")
        self.addToolBar(vb)
        self.light_combo = QComboBox()
        self.light_combo.addItems(list(LIGHT_PRESETS))
        self.env_combo = QComboBox()
        self.env_combo.addItems(list(ENVIRONMENTS))
        self.render_combo = QComboBox()
        self.render_combo.addItems(list(RENDER_MODES))
        self.split_slider = QSlider(Qt.Orientation.Horizontal)
        self.split_slider.setRange(0, 100)
        self.split_slider.setMaximumWidth(140)
        for label, w, tip in (("Light", self.light_combo, "Light"), ("HDR", self.env_combo, "HDR"),
                              ("Mode", self.render_combo, "Render"),
                              ("Before|After", self.split_slider, "Before|After")):
            _add_labelled(vb, label, w, TOOLTIPS[tip])
        vb.addWidget(self.region_picker.overlay_button)  # the Regions overlay: outlines drawn over the view
        self.light_combo.currentTextChanged.connect(self.use_light_preset)
        self.env_combo.currentTextChanged.connect(lambda t: self.change_settings(environment=t))
        self.render_combo.currentTextChanged.connect(self.set_render_mode)
        self.split_slider.valueChanged.connect(lambda v: self.change_settings(split=v / 100.0))


def _add_labelled(bar: QToolBar, label: str, widget: QWidget, tip: str) -> None:
    """Add `` label `` and ``widget`` to ``bar``, both with the tooltip ``tip``."""
    text = QLabel(f" {label} ")
    text.setToolTip(tip)
    widget.setToolTip(tip)
    bar.addWidget(text)
    bar.addWidget(widget)
