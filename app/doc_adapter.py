"""The studio's view of ``painting.Document`` (issue 4): the small differences between it and the shape
the UI was written against are absorbed here (``can_undo`` as a property, events with layer *indices*,
writing a whole map as one undo step, the built-in looks from ``resources/looks``).
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator
    from pathlib import Path


@dataclass
class Event:
    kind: str
    layer: int | None = None
    tiles: list[tuple[int, int]] = field(default_factory=list)


class DocumentAdapter:
    """Wraps a ``painting.Document``; attribute access falls through to it."""

    def __init__(self, doc: Any) -> None:
        self.doc = doc

    @classmethod
    def from_head(cls, path: str | Path | None, resolution: int, library: Any,
                  progress: Callable[[str, float], None] | None = None) -> DocumentAdapter:
        """Load the head and build the document (cleaning, UV check or xatlas unwrap, bake): ``progress``
        gets (stage, fraction); safe to call from a worker thread.
        """
        from painting import Document

        return cls(Document.from_head(path, resolution=resolution, library=library, progress=progress))

    def __getattr__(self, name: str) -> Any:
        return getattr(self.doc, name)

    @property
    def head(self) -> Any:
        return self.doc.head

    @property
    def layers(self) -> list[Any]:
        return self.doc.layers

    @property
    def resolution(self) -> int:
        return int(self.doc.resolution)

    @property
    def can_undo(self) -> bool:
        v = self.doc.can_undo
        return bool(v() if callable(v) else v)

    @property
    def can_redo(self) -> bool:
        v = self.doc.can_redo
        return bool(v() if callable(v) else v)

    def add_layer(self, material: str, name: str | None = None, max_thickness: float | None = None) -> Any:
        return self.doc.add_layer(material, name=name, max_thickness=max_thickness)

    def remove_layer(self, index: int) -> None:
        self.doc.remove_layer(index)

    def move_layer(self, src: int, dst: int) -> None:
        self.doc.move_layer(src, dst)

    def set_layer(self, index: int, **changes: Any) -> None:
        self.doc.set_layer(index, **changes)

    @contextlib.contextmanager
    def stroke(self, layer: Any, brush: Any) -> Iterator[Any]:
        with self.doc.stroke(layer, brush) as s:
            yield s

    def undo(self) -> None:
        self.doc.undo()

    def redo(self) -> None:
        self.doc.redo()

    def clear_history(self) -> None:
        self.doc.clear_history()

    def set_thickness(self, layer: Any, values: np.ndarray) -> None:
        self.doc.set_thickness(layer, np.asarray(values, np.float32))

    def subscribe(self, callback: Callable[[Event], None]) -> Callable[[], None]:
        def translate(ev: Any) -> None:
            if ev.kind == "history":
                return
            index = None
            if ev.layer is not None:
                index = next((i for i, lay in enumerate(self.doc.layers) if lay.id == ev.layer), None)
            kind = "paint" if ev.kind == "paint" else "layers"
            callback(Event(kind, index, [tuple(t) for t in ev.tiles]))

        return self.doc.subscribe(translate)

    def apply_look(self, name: str) -> None:
        from painting.looks import apply_look

        apply_look(self.doc, name)


def make_brush(radius_mm: float, hardness: float, strength: float, mode: str, mirror: bool) -> Any:
    from painting import Brush

    return Brush(radius_mm=float(radius_mm), hardness=float(hardness), strength=float(strength),
                 mode=mode, mirror=bool(mirror))
