"""The studio's Looks menu and gallery: a ready-made look added to the head being designed.

Each built-in look (:mod:`painting.looks`, but ``bare``, which has no layer) is an item of the Looks menu
and of the gallery (Looks → Look Gallery…, Ctrl+L), with a thumbnail of the look rendered on the
window's head. Choosing one adds its layers on top of the document's, painted by the look's strokes, as
one undo step (:meth:`painting.Document.grouped`): Ctrl+Z takes the whole look off again.

The thumbnails are rendered once, small, in a worker (:func:`render_thumbnails`: the look painted on a
256² scratch document of the same head, the fast renderer on a headless GL context, framed on the face
as the F key frames it) and kept in the cache folder (:mod:`core.cache`, kind ``looks``), keyed by the
head's paint layout, the look's file and its materials; the next start reads them back.
"""

from __future__ import annotations

import hashlib
import json
import logging
from typing import TYPE_CHECKING, Any

import numpy as np
from PySide6.QtCore import QObject, QSize, Qt
from PySide6.QtGui import QAction, QIcon, QImage, QPixmap
from PySide6.QtWidgets import (
    QDialog,
    QDialogButtonBox,
    QLabel,
    QListWidget,
    QListWidgetItem,
    QMenu,
    QVBoxLayout,
)

from app.workers import run_task

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

    from painting import Document

log = logging.getLogger("sheer.app")

#: A thumbnail's side, in pixels.
THUMB_SIZE = 160
#: Bump when the thumbnails are drawn differently for the same look (camera, light, renderer).
_THUMB_VERSION = 1
#: The scratch document's resolution for the thumbnails (a thumbnail shows no finer detail).
_THUMB_RESOLUTION = 256


def offered_looks() -> list[tuple[str, str]]:
    """(name, description) of every built-in look the menu offers: all but ``bare``, which adds nothing."""
    from core.errors import SheerError
    from painting.looks import available_looks, load_look

    looks = []
    for name in available_looks():
        try:
            look = load_look(name)
        except SheerError as exc:  # (a broken file is left out of the menu, not the studio's start)
            log.warning("look %s left out of the Looks menu: %s", name, exc)
            continue
        if look.layers:
            looks.append((name, look.description))
    return looks


def thumbnail_path(doc: Document, name: str) -> Path:
    """Where the thumbnail of look ``name`` on ``doc``'s head is cached (see the module docstring)."""
    from core.cache import cache_dir
    from painting.looks import load_look, look_path

    h = hashlib.sha256(f"{doc.layout.key}|{THUMB_SIZE}|{_THUMB_VERSION}|".encode())
    h.update(look_path(name).read_bytes())
    for layer in load_look(name).layers:
        try:
            material = doc.library.get(layer.material)
            h.update(json.dumps(material.to_json(), sort_keys=True, default=str).encode())
        except Exception:  # (an unknown material: the look fails to paint anyway)
            h.update(layer.material.encode())
    return cache_dir("looks") / f"thumb-{name}-{h.hexdigest()[:24]}-v{_THUMB_VERSION}.cache"


def cached_thumbnail(doc: Document, name: str) -> np.ndarray | None:
    """The cached thumbnail (uint8 RGB, THUMB_SIZE²) of look ``name`` on ``doc``'s head, or None."""
    from core.cache import load_array

    image = load_array(thumbnail_path(doc, name), _THUMB_VERSION)
    if image is None or image.shape != (THUMB_SIZE, THUMB_SIZE, 3) or image.dtype != np.uint8:
        return None
    return image


def render_thumbnails(doc: Document, names: list[str], progress: Callable[[float, str], None],
                      cancelled: Callable[[], bool]) -> dict[str, np.ndarray]:
    """Render and cache the thumbnails of ``names`` on ``doc``'s head (a worker's job; no Qt widget).

    Returns name → uint8 RGB image; a look that cannot be painted is left out (logged).
    """
    from app.view.camera import Lighting, ViewCamera
    from app.view.viewport import face_box
    from core.cache import save_array
    from core.errors import SheerError
    from painting.document import Document
    from painting.looks import apply_look
    from render.binding import layer_inputs
    from render.context import standalone_context
    from render.view import ViewRenderer

    scratch = Document(doc.head, doc.layout, library=doc.library, resolution=_THUMB_RESOLUTION)
    camera = ViewCamera()
    camera.frame_box(*face_box(doc.head))
    light = Lighting().key_light()
    out: dict[str, np.ndarray] = {}
    ctx = standalone_context(require=330)
    try:
        renderer = ViewRenderer(ctx, doc.head, doc.layout)
        try:
            for i, name in enumerate(names):
                if cancelled():
                    break
                progress(i / max(len(names), 1), f"look {name}")
                try:
                    apply_look(scratch, name)
                except SheerError as exc:
                    log.warning("no thumbnail for look %s: %s", name, exc)
                    continue
                renderer.set_layers(layer_inputs(scratch, doc.library))
                image = np.ascontiguousarray(renderer.render_image((THUMB_SIZE, THUMB_SIZE), camera, light, "fast")[..., :3])
                save_array(thumbnail_path(doc, name), image, _THUMB_VERSION)
                out[name] = image
        finally:
            renderer.release()
    finally:
        ctx.release()
    return out


def _icon(image: np.ndarray) -> QIcon:
    h, w = image.shape[:2]
    data = np.ascontiguousarray(image, dtype=np.uint8)
    qimage = QImage(data.data, w, h, 3 * w, QImage.Format.Format_RGB888).copy()
    return QIcon(QPixmap.fromImage(qimage))


class LooksMenu(QObject):
    """The Looks menu of one studio window (see the module docstring).

    Args:
        window: the :class:`app.studio.main_window.StudioWindow` (its document, :meth:`add_look`).
        menu: the window's Looks menu; the look items go above what it holds (the gallery's item).

    Attributes:
        actions: look name → its menu item.
        thumbnails: look name → its thumbnail (uint8 RGB), as they become available.
    """

    def __init__(self, window: Any, menu: QMenu) -> None:
        super().__init__(window)
        self.window = window
        self.menu = menu
        self.actions: dict[str, QAction] = {}
        self.thumbnails: dict[str, np.ndarray] = {}
        self.gallery: LookGallery | None = None
        self._rendering = False
        menu.setToolTipsVisible(True)
        first = menu.actions()[0] if menu.actions() else None
        for name, description in offered_looks():
            act = QAction(f"Add Look: {name}", menu)
            if first is None:
                menu.addAction(act)
            else:
                menu.insertAction(first, act)
            act.setObjectName(f"looks.add_{name}")
            act.setToolTip(description or name)
            act.setStatusTip(f"Add the look '{name}' as new layers (one undo step): {description}")
            act.triggered.connect(lambda _c=False, n=name: self.window.add_look(n))
            self.actions[name] = act
        if first is not None:
            menu.insertSeparator(first)
        menu.aboutToShow.connect(self.prepare_thumbnails)

    def prepare_thumbnails(self) -> None:
        """Show the cached thumbnails, and render the missing ones in a worker (once)."""
        doc = self.window.doc
        missing = []
        for name in self.actions:
            if name in self.thumbnails:
                continue
            image = cached_thumbnail(doc, name)
            if image is None:
                missing.append(name)
            else:
                self._show(name, image)
        if missing and not self._rendering:
            self._rendering = True

            def done(images: dict[str, np.ndarray]) -> None:
                self._rendering = False
                for name, image in images.items():
                    self._show(name, image)

            def failed(message: str) -> None:
                self._rendering = False
                log.warning("the looks' thumbnails could not be rendered: %s", message)

            run_task(self.window, "Rendering the looks' thumbnails",
                     lambda progress, cancelled: render_thumbnails(doc, missing, progress, cancelled), done, failed,
                     show_progress=False)

    def _show(self, name: str, image: np.ndarray) -> None:
        self.thumbnails[name] = image
        icon = _icon(image)
        self.actions[name].setIcon(icon)
        if self.gallery is not None:
            self.gallery.set_icon(name, icon)

    def show_gallery(self) -> LookGallery:
        """Looks → Look Gallery…: the looks as thumbnails; Add (or a double click) adds the chosen one."""
        if self.gallery is None:
            self.gallery = LookGallery(self.window, self)
        self.prepare_thumbnails()
        self.gallery.show()
        self.gallery.raise_()
        return self.gallery


class LookGallery(QDialog):
    """The looks as a grid of thumbnails with their descriptions; Add puts the chosen one on the head."""

    def __init__(self, window: Any, looks: LooksMenu) -> None:
        super().__init__(window)
        self.setWindowTitle("Look Gallery")
        self.window_ = window
        self.list = QListWidget()
        self.list.setViewMode(QListWidget.ViewMode.IconMode)
        self.list.setIconSize(QSize(THUMB_SIZE, THUMB_SIZE))
        self.list.setGridSize(QSize(THUMB_SIZE + 24, THUMB_SIZE + 40))
        self.list.setResizeMode(QListWidget.ResizeMode.Adjust)
        self.list.setMovement(QListWidget.Movement.Static)
        self.list.setWordWrap(True)
        placeholder = QPixmap(THUMB_SIZE, THUMB_SIZE)
        placeholder.fill(Qt.GlobalColor.darkGray)
        for name, description in offered_looks():
            item = QListWidgetItem(QIcon(placeholder), name)
            item.setData(Qt.ItemDataRole.UserRole, name)
            item.setToolTip(description or name)
            if name in looks.thumbnails:
                item.setIcon(_icon(looks.thumbnails[name]))
            self.list.addItem(item)
        self.description = QLabel("Choose a look: it is added to the head as new layers (Ctrl+Z takes it off).")
        self.description.setWordWrap(True)
        self.buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Close)
        self.add_button = self.buttons.addButton("Add to the Head", QDialogButtonBox.ButtonRole.ApplyRole)
        self.add_button.setEnabled(False)
        self.add_button.clicked.connect(self.add_chosen)
        self.buttons.rejected.connect(self.reject)
        self.list.currentItemChanged.connect(self._chosen)
        self.list.itemDoubleClicked.connect(lambda _item: self.add_chosen())
        lay = QVBoxLayout(self)
        lay.addWidget(self.list, 1)
        lay.addWidget(self.description)
        lay.addWidget(self.buttons)
        self.resize(3 * (THUMB_SIZE + 24) + 40, 2 * (THUMB_SIZE + 40) + 110)

    def set_icon(self, name: str, icon: QIcon) -> None:
        """Show look ``name``'s thumbnail."""
        for i in range(self.list.count()):
            if self.list.item(i).data(Qt.ItemDataRole.UserRole) == name:
                self.list.item(i).setIcon(icon)

    def chosen(self) -> str | None:
        """The look chosen in the grid, or None."""
        item = self.list.currentItem()
        return None if item is None else str(item.data(Qt.ItemDataRole.UserRole))

    def _chosen(self, item: QListWidgetItem | None, _previous: object = None) -> None:
        self.add_button.setEnabled(item is not None)
        if item is not None:
            self.description.setText(f"{item.text()}: {item.toolTip()}")

    def add_chosen(self) -> None:
        """Add the chosen look to the head (one undo step) and close the gallery."""
        name = self.chosen()
        if name is not None:
            self.window_.add_look(name)
            self.accept()
