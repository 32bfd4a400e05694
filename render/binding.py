"""The one document → GPU path: a :class:`DocumentBinding` keeps a renderer's layers equal to a document's.

Data flows one way: the document's change events are queued here as they happen, and :meth:`flush`
(called once per frame, before drawing, with the renderer's GL context current) pushes exactly those
changes to the renderer:

- ``"paint"`` events: the touched tiles, as (row, col) of :data:`painting.tiles.TILE`² blocks (the
  convention of :mod:`painting.tiles`), merged per layer *id* (the id stays valid while layers move); at
  the flush each id is looked up once and only those tiles are re-evaluated in texture space;
- ``"layers"`` and ``"material"`` events: every layer is read again (:func:`layer_inputs`) and evaluated;
- ``"history"`` events change nothing on screen.

The renderer's layer *i* is the document's layer *i*, hidden ones included (``visible=False``), so a
document index is also the renderer's. A change made outside the document — a material edited in the
library — has no event: :meth:`DocumentBinding.invalidate` asks for a full re-evaluation.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from render.km_pass import LayerInput

if TYPE_CHECKING:
    from collections.abc import Callable

    from km.library import Library
    from painting import ChangeEvent, Document
    from render.renderer import Renderer


def layer_inputs(doc: Document, library: Library | None = None) -> list[LayerInput]:
    """Every layer of ``doc`` as a :class:`render.km_pass.LayerInput`, bottom first.

    Hidden layers are kept with ``visible=False``, so index *i* is document layer *i*. The thickness is
    the layer's live map (µm), not a copy.

    Args:
        doc: the document.
        library: where materials are looked up by name first (the studio's library: edits there show at
            once); without one, or for a name it lacks, the layer's own material object is used.

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
        out.append(LayerInput(mat, lay.thickness, float(lay.opacity), visible, str(lay.name)))
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
        self._unsubscribe: Callable[[], None] | None = doc.subscribe(self._on_event)

    def _on_event(self, event: ChangeEvent) -> None:
        if event.kind == "history":
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
            self.renderer.set_layers(layer_inputs(self.doc, self.library))
        else:
            for lid, tiles in self.dirty.items():
                self.renderer.km.update_tiles(index[lid], layers[index[lid]].thickness, sorted(tiles))
        self.full, self.dirty = False, {}
        return True

    def close(self) -> None:
        """Stop following the document (queued changes are dropped)."""
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None
        self.full, self.dirty = False, {}
