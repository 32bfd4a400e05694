"""The studio's doors to the packages it builds on: the material library (``km``), the painting document
(``painting``, through :mod:`app.doc_adapter`), brushes and looks. There are no stand-ins: a missing or
broken package is an error the user sees as a message. :func:`backends` says what is in use (shown in
the About box and the bench JSON).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from pathlib import Path

_USED: dict[str, str] = {"renderer": "render.Renderer"}


def backends() -> dict[str, str]:
    """Which implementation each part uses: {"library": "km", "document": "painting.Document", ...}."""
    return dict(_USED)


def load_library() -> Any:
    """The material library (``km.default_library()``)."""
    from km.library import default_library

    lib = default_library()
    _USED["library"] = "km"
    return lib


def open_document(head_path: str | Path | None = None, resolution: int = 2048, library: Any = None,
                  progress: Any = None) -> Any:
    """The painting document for a head (``painting.Document`` through :mod:`app.doc_adapter`)."""
    from app.doc_adapter import DocumentAdapter

    doc = DocumentAdapter.from_head(head_path, resolution, library, progress)
    _USED["document"] = "painting.Document"
    return doc


def make_brush(radius_mm: float, hardness: float, strength: float, mode: str, mirror: bool) -> Any:
    """A ``painting.Brush``."""
    from app.doc_adapter import make_brush as real

    return real(radius_mm, hardness, strength, mode, mirror)


def set_thickness(doc: Any, layer: Any, values: np.ndarray) -> None:
    """Replace a layer's whole map as one undo step."""
    doc.set_thickness(layer, np.asarray(values, np.float32))


def materials_by_category(library: Any) -> dict[str, list[str]]:
    """Material names grouped by category, in library order."""
    out: dict[str, list[str]] = {}
    for m in library:
        out.setdefault(str(m.category), []).append(m.name)
    return out


def apply_look(doc: Any, library: Any, name: str) -> None:
    """Replace the document's layers with the built-in look ``name`` (``resources/looks``; unknown →
    ``painting.looks.LookError``, a SheerError).
    """
    for i in reversed(range(len(doc.layers))):
        doc.remove_layer(i)
    doc.apply_look(name)
