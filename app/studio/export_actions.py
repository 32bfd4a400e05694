"""The studio's exports and layer-map transfers.

File → Export Layer Maps / glTF / Rendered Image / OpenRaster, and a layer's thickness map exported or
imported from the Layers panel.

:class:`ExportActions` asks where (file dialogs) and runs the work of :mod:`app.export` in worker threads
with a progress dialog; results go to the status bar, failures to a message box.
"""

from __future__ import annotations

import copy
import dataclasses
import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PySide6.QtCore import QObject, Signal
from PySide6.QtWidgets import (
    QComboBox,
    QDialog,
    QDialogButtonBox,
    QFileDialog,
    QFormLayout,
    QLabel,
    QMainWindow,
    QWidget,
)

from app.export import export_gltf, export_maps, render_image
from app.studio import dialogs
from app.workers import run_task
from render.binding import layer_inputs

if TYPE_CHECKING:
    from collections.abc import Callable

    from app.session import Session
    from app.settings import StudioSettings
    from app.view.viewport import Viewport

#: The sizes File → Export Rendered Image offers (width×height in pixels; any other may be typed).
IMAGE_SIZES: tuple[str, ...] = ("1280x720", "1920x1080", "2048x2048", "3840x2160")
#: The side of a rendered image, in pixels (:func:`app.export.render_image` refuses others).
IMAGE_SIDE = (16, 8192)


def parse_image_size(text: str) -> tuple[int, int] | None:
    """``"1920x1080"`` (or ``1920 × 1080``) → (1920, 1080); None unless both sides are within :data:`IMAGE_SIDE`."""
    match = re.fullmatch(r"\s*(\d{1,5})\s*[xX×*]\s*(\d{1,5})\s*", text)
    if match is None:
        return None
    w, h = int(match.group(1)), int(match.group(2))
    lo, hi = IMAGE_SIDE
    return (w, h) if lo <= w <= hi and lo <= h <= hi else None


class ImageSizeDialog(QDialog):
    """File → Export Rendered Image's first question, the size: one of :data:`IMAGE_SIZES` or a typed one.

    OK stays disabled, and a line says why, until the text is a size (``WIDTHxHEIGHT``, each side within
    :data:`IMAGE_SIDE`): "abc" is refused here, before any file is asked for.
    """

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Export Rendered Image")
        self.setMinimumWidth(420)  # the title in full, in any window manager's title bar
        self.combo = QComboBox()
        self.combo.setEditable(True)
        self.combo.addItems(list(IMAGE_SIZES))
        self.combo.setToolTip("width × height in pixels, e.g. 1920x1080 (16 to 8192 on a side)")
        self.hint = QLabel()
        self.buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel)
        self.buttons.accepted.connect(self.accept)
        self.buttons.rejected.connect(self.reject)
        form = QFormLayout(self)
        form.addRow("Size (pixels)", self.combo)
        form.addRow(self.hint)
        form.addRow(self.buttons)
        self.combo.currentTextChanged.connect(self._check)
        self._check(self.combo.currentText())

    def size_chosen(self) -> tuple[int, int] | None:
        """The size typed or chosen, or None while it is not one."""
        return parse_image_size(self.combo.currentText())

    def _check(self, text: str) -> None:
        ok = parse_image_size(text) is not None
        self.buttons.button(QDialogButtonBox.StandardButton.Ok).setEnabled(ok)
        lo, hi = IMAGE_SIDE
        self.hint.setText("width x height in pixels" if ok else f"Type a size like 1920x1080 ({lo}–{hi} pixels a side).")

    def accept(self) -> None:
        """Close with OK, only with a valid size (Enter in the field cannot pass a wrong one)."""
        if self.size_chosen() is not None:
            super().accept()


class ExportActions(QObject):
    """Exports and map transfers of one studio window.

    Args:
        window: the studio window (parent of dialogs; its status bar shows results).
        session: the library and the document to export.
        viewport: the window's view (camera, key light and captured face of a rendered image).
        settings: the window's settings (render mode and environment of a rendered image).
    """

    #: A layer's map was replaced by an imported file.
    map_imported = Signal()

    def __init__(self, window: QMainWindow, session: Session, viewport: Viewport,
                 settings: StudioSettings) -> None:
        super().__init__(window)
        self._window = window
        self.doc = session.document
        self.library = session.library
        self.viewport = viewport
        self.settings = settings

    def _report(self, what: str) -> Callable[[object], None]:
        return lambda result: self._window.statusBar().showMessage(f"{what}: {result}", 6000)

    def _fail(self, title: str) -> Callable[[str], None]:
        return lambda message: dialogs.error(self._window, title, message)

    def _ask_save_path(self, title: str, name: str, filters: str) -> Path | None:
        """The file picked in a save dialog titled ``title`` that proposes ``name``, or None when cancelled."""
        path, _ = QFileDialog.getSaveFileName(self._window, title, name, filters)
        return Path(path) if path else None

    # ------------------------------------------------------------------ layer maps
    def ask_export_maps(self, fmt: str = "png") -> None:
        """Ask for a folder, then :meth:`export_maps` there."""
        folder = QFileDialog.getExistingDirectory(self._window, "Export layer maps to folder")
        if folder:
            self.export_maps(Path(folder), fmt=fmt)

    def export_maps(self, folder: Path, on_done: Callable[[object], None] | None = None, fmt: str = "png") -> None:
        """Write every layer's thickness map and a manifest to ``folder`` (in a worker).

        Args:
            folder: the destination (created when missing).
            on_done: called with the result on the GUI thread (default: a status-bar message).
            fmt: ``"png"`` (16-bit, scale in µm in the manifest) or ``"exr"`` (32-bit float µm).
        """
        run_task(self._window, "Exporting layer maps", lambda p, c: export_maps(self.doc, folder, p, c, fmt),
                 on_done or self._report("Maps exported"), self._fail("Export maps"))

    def ask_export_map(self, index: int) -> None:
        """Ask for a file, then write layer ``index``'s map there (16-bit PNG or OpenEXR, in a worker)."""
        name, _ = QFileDialog.getSaveFileName(self._window, "Export thickness map",
                                              f"{self.doc.layers[index].name}.png",
                                              "16-bit PNG (*.png);;OpenEXR (*.exr)")
        if name:
            run_task(self._window, "Exporting map", lambda p, c: self.doc.export_layer(index, Path(name)),
                     lambda _r: self._report("Map exported")(name), self._fail("Export map"))

    def ask_import_map(self, index: int) -> None:
        """Ask for a map file, then :meth:`import_map` it into layer ``index``."""
        path, _ = QFileDialog.getOpenFileName(self._window, "Import thickness map", "",
                                              "Thickness maps (*.png *.exr)")
        if path:
            self.import_map(index, Path(path))

    def import_map(self, index: int, path: Path) -> bool:
        """Replace layer ``index``'s map with a file written by Export (one undo step).

        Returns:
            Whether the map was imported (False: the file was refused and a message shown).
        """
        from core.errors import SheerError

        try:
            self.doc.import_layer(index, path)
        except (SheerError, OSError, ValueError) as exc:
            dialogs.error(self._window, "Import map", f"The map could not be imported: {exc}")
            return False
        self.map_imported.emit()
        return True

    # ------------------------------------------------------------------ glTF
    def ask_export_gltf(self) -> None:
        """Ask for a file, then :meth:`export_gltf` there."""
        path = self._ask_save_path("Export glTF", "face.glb", "glTF binary (*.glb);;glTF (*.gltf)")
        if path:
            self.export_gltf(path)

    def export_gltf(self, path: Path, on_done: Callable[[object], None] | None = None) -> None:
        """Write the head with the made-up colour baked into its texture as glTF (in a worker)."""
        run_task(self._window, "Exporting glTF", lambda p, c: export_gltf(self.doc, self.library, path, p, c),
                 on_done or self._report("glTF exported"), self._fail("Export glTF"))

    # ------------------------------------------------------------------ rendered image
    def ask_export_image(self) -> None:
        """Ask for a size, then a file, then :meth:`export_image`.

        The size's dialog (:class:`ImageSizeDialog`) accepts only a valid one, before any file is asked for.
        """
        dialog = ImageSizeDialog(self._window)
        if not dialog.exec():
            return
        size = dialog.size_chosen()
        path = self._ask_save_path("Export rendered image", "render.png", "PNG (*.png)")
        if path and size is not None:
            self.export_image(path, size)

    # ------------------------------------------------------------------ OpenRaster
    def ask_export_ora(self) -> None:
        """Ask for a file, then :meth:`export_ora` there."""
        path = self._ask_save_path("Export OpenRaster", "layers.ora", "OpenRaster (*.ora)")
        if path:
            self.export_ora(path)

    def export_ora(self, path: Path, on_done: Callable[[object], None] | None = None) -> None:
        """Write the layers as OpenRaster for GIMP and Krita, in a worker.

        :func:`project.export.document_ora_bytes`: each cosmetic in its colour with its coverage as alpha,
        and the thickness maps as hidden data layers.
        """
        from core.atomicio import atomic_write_bytes
        from project.export import document_ora_bytes

        doc, name = self.doc, Path(path).stem
        layers = [(lay.name, lay.material_object, np.array(lay.effective_thickness()), float(lay.max_thickness),
                   float(lay.opacity), bool(lay.visible)) for lay in doc.layers]  # copies: painting goes on

        def job(progress: Callable[[float, str], None], _cancelled: Callable[[], bool]) -> Path:
            progress(0.1, "colouring the layers")
            atomic_write_bytes(Path(path), document_ora_bytes(name, layers))
            return Path(path)

        run_task(self._window, "Exporting OpenRaster", job, on_done or self._report("OpenRaster exported"),
                 self._fail("Export OpenRaster"))

    def export_image(self, path: Path, size: tuple[int, int],
                     on_done: Callable[[object], None] | None = None) -> None:
        """Render the current view offscreen at ``size`` (width, height in pixels) to a PNG (in a worker).

        The camera, key light, layers (maps copied), render mode, environment and captured face are
        taken now, so painting on meanwhile does not change the image.
        """
        vp = self.viewport
        cam, light = copy.deepcopy(vp.camera), copy.deepcopy(vp.lighting)
        layers = [dataclasses.replace(inp, thickness=np.array(inp.thickness))
                  for inp in layer_inputs(self.doc, self.library)]
        mode, env, face = self.settings.render_mode, self.settings.environment, vp.face
        layout = self.doc.layout
        run_task(self._window, "Rendering image",
                 lambda p, c: render_image(self.doc.head, layers, cam, light, size, path, mode, env, layout, p, c,
                                           face),
                 on_done or self._report("Image saved"), self._fail("Export image"))
