"""The studio's exports and layer-map transfers.

File → Export Layer Maps / glTF / Rendered Image, and a layer's thickness map exported or imported from
the Layers panel.

:class:`ExportActions` asks where (file dialogs) and runs the work of :mod:`app.export` in worker threads
with a progress dialog; results go to the status bar, failures to a message box.
"""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PySide6.QtCore import QObject, Signal
from PySide6.QtWidgets import QFileDialog, QInputDialog, QMainWindow

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
        path, _ = QFileDialog.getSaveFileName(self._window, "Export glTF", "face.glb",
                                              "glTF binary (*.glb);;glTF (*.gltf)")
        if path:
            self.export_gltf(Path(path))

    def export_gltf(self, path: Path, on_done: Callable[[object], None] | None = None) -> None:
        """Write the head with the made-up colour baked into its texture as glTF (in a worker)."""
        run_task(self._window, "Exporting glTF", lambda p, c: export_gltf(self.doc, self.library, path, p, c),
                 on_done or self._report("glTF exported"), self._fail("Export glTF"))

    # ------------------------------------------------------------------ rendered image
    def ask_export_image(self) -> None:
        """Ask for a size and a file, then :meth:`export_image`."""
        size, ok = QInputDialog.getItem(self._window, "Rendered image", "Size", list(IMAGE_SIZES), 0, True)
        if not ok:
            return
        path, _ = QFileDialog.getSaveFileName(self._window, "Export rendered image", "render.png", "PNG (*.png)")
        if path:
            try:
                w, h = (int(x) for x in size.lower().split("x"))
            except ValueError:
                dialogs.error(self._window, "Export image", f"'{size}' is not a size like 1920x1080.")
                return
            self.export_image(Path(path), (w, h))

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
