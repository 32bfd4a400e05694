"""The one document → GPU path: a :class:`DocumentBinding` keeps a renderer's layers equal to a document's.

Data flows one way: the document's change events are queued here as they happen, and :meth:`flush`
(called once per frame, before drawing, with the renderer's GL context current) pushes exactly those
changes to the renderer:

- ``"paint"`` events: the touched tiles, as (row, col) of :data:`painting.tiles.TILE`² blocks (the
  convention of :mod:`painting.tiles`), merged per layer *id* (the id stays valid while layers move); at
  the flush each id is looked up once and only those tiles are re-evaluated in texture space;
- ``"layers"`` and ``"material"`` events: every layer is read again (:func:`layer_inputs`) and evaluated
  (a material edited in the document's library is a ``"material"`` event of each layer of it);
- ``"history"`` and ``"library"`` events change nothing on screen.

Layer masks (:mod:`painting.mask`) are applied here, at upload: a masked layer's thickness goes to the
renderer multiplied by its mask. The binding keeps that product per masked layer and, for dirty tiles,
recomputes only those tiles (so a dab on a masked layer, or on its mask's channel, stays as cheap as on
any layer); the tiles still go through ``km.update_tiles``, so the lighting cache follows.

The renderer's layer *i* is the document's layer *i*, hidden ones included (``visible=False``), so a
document index is also the renderer's. Without a ``library`` the renderer draws each layer's own material
(``layer.material_object``, what a project saves); a library given is looked up first, by name (a catalogue
job's materials): a change made to it outside the document has no event, and
:meth:`DocumentBinding.invalidate` asks for a full re-evaluation.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from painting.mask import layer_mask_values
from painting.tiles import TILE
from render.km_pass import LayerInput

if TYPE_CHECKING:
    from collections.abc import Callable

    from km.library import Library
    from painting import ChangeEvent, Document, Layer
    from render.renderer import Renderer


def masked_thickness(layer: Layer) -> np.ndarray:
    """The thickness a layer is rendered with (µm).

    Its map × its mask (a new float32 array), or the live map when it has no mask.
    """
    mask = layer_mask_values(layer)
    return layer.thickness if mask is None else np.multiply(layer.thickness, mask, dtype=np.float32)


def layer_inputs(doc: Document, library: Library | None = None,
                 maps: dict[int, np.ndarray] | None = None) -> list[LayerInput]:
    """Every layer of ``doc`` as a :class:`render.km_pass.LayerInput`, bottom first.

    Hidden layers are kept with ``visible=False``, so index *i* is document layer *i*. The thickness is
    the layer's live map (µm), not a copy, unless the layer has a mask (then :func:`masked_thickness`).

    Args:
        doc: the document.
        library: where materials are looked up by name first (the studio's library: edits there show at
            once); without one, or for a name it lacks, the layer's own material object is used.
        maps: thickness to use per layer id instead (the binding's masked maps), or None.

    Returns:
        One input per layer. A layer whose material is nowhere is kept (indices) but not drawn.
    """
    out = []
    for lay in doc.layers:
        if library is not None and lay.material in library:
            mat = library.get(lay.material)
        else:
            mat = lay.material_object
        visible = bool(lay.visible) and mat is not None
        if mat is None:
            mat = next(iter(library if library is not None else doc.library))
        thickness = maps[lay.id] if maps is not None and lay.id in maps else masked_thickness(lay)
        out.append(LayerInput(mat, thickness, float(lay.opacity), visible, str(lay.name)))
    return out


class DocumentBinding:
    """Follows one document's change events and pushes them to one renderer, once per frame.

    Attributes:
        doc: the document followed.
        renderer: the renderer kept in sync (its ``set_layers`` and ``km.update_tiles``).
        library: the material library looked up first (see :func:`layer_inputs`), or None.
        dirty: tiles to re-evaluate, (row, col) per layer id, since the last :meth:`flush`.
        full: every layer is to be read again at the next :meth:`flush`.
    """

    def __init__(self, doc: Document, renderer: Renderer, library: Library | None = None,
                 on_change: Callable[[], None] | None = None) -> None:
        """Subscribe to ``doc``; the first :meth:`flush` evaluates every layer.

        Args:
            doc: the document to follow.
            renderer: the renderer to keep in sync.
            library: see :func:`layer_inputs`.
            on_change: called after every change queued (e.g. a view asking for a frame); not for
                ``"history"`` events.
        """
        self.doc = doc
        self.renderer = renderer
        self.library = library
        self.on_change = on_change
        self.dirty: dict[int, set[tuple[int, int]]] = {}
        self.full = True
        self._masked: dict[int, np.ndarray] = {}  # layer id -> its thickness × its mask, as uploaded
        self._unsubscribe: Callable[[], None] | None = doc.subscribe(self._on_event)

    def _on_event(self, event: ChangeEvent) -> None:
        if event.kind in ("history", "library"):
            return
        if event.kind == "paint" and event.layer is not None:
            if not self.full:
                self.dirty.setdefault(event.layer, set()).update((int(r), int(c)) for r, c in event.tiles)
        else:
            self.invalidate()
            return
        if self.on_change is not None:
            self.on_change()

    @property
    def pending(self) -> bool:
        """Changes are queued for the next :meth:`flush`."""
        return self.full or bool(self.dirty)

    def invalidate(self) -> None:
        """Read and evaluate every layer at the next :meth:`flush` (e.g. a library material was edited)."""
        self.full, self.dirty = True, {}
        if self.on_change is not None:
            self.on_change()

    def flush(self) -> bool:
        """Push the queued changes to the renderer (call once per frame, its GL context current).

        Returns:
            True if anything was pushed.
        """
        if not self.pending:
            return False
        layers = self.doc.layers
        index = {lay.id: i for i, lay in enumerate(layers)}
        held = self.renderer.km.layers
        # a painted layer the renderer does not hold as it is now (layer count or map size changed)
        if any(index.get(lid, len(held)) >= len(held) or held[index[lid]].thickness.shape
               != layers[index[lid]].thickness.shape for lid in self.dirty):
            self.full = True
        if self.full:
            self._masked = {lay.id: masked_thickness(lay) for lay in layers if lay.has_mask}
            self.renderer.set_layers(layer_inputs(self.doc, self.library, self._masked))
        else:
            for lid, tiles in self.dirty.items():
                lay = layers[index[lid]]
                order = sorted(tiles)
                thickness = lay.thickness
                if lid in self._masked:
                    thickness = self._masked[lid]
                    self._remask(lay, thickness, order)
                self.renderer.km.update_tiles(index[lid], thickness, order)
        self.full, self.dirty = False, {}
        return True

    @staticmethod
    def _remask(layer: Layer, out: np.ndarray, tiles: list[tuple[int, int]]) -> None:
        """Recompute ``out`` (the layer's masked thickness) on ``tiles`` only."""
        mask = layer_mask_values(layer, tiles)
        n = out.shape[0] // TILE
        t = np.asarray(tiles, dtype=np.int64).reshape(-1, 2)
        src = layer.thickness.reshape(n, TILE, n, TILE)[t[:, 0], :, t[:, 1], :]
        out.reshape(n, TILE, n, TILE)[t[:, 0], :, t[:, 1], :] = src if mask is None else src * mask

    def close(self) -> None:
        """Stop following the document (queued changes are dropped)."""
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None
        self.full, self.dirty = False, {}
