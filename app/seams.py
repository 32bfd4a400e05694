"""Adapters between the studio and the packages it builds on (``km``, ``painting``, ``render``,
``painting.project``).

Each function returns the real implementation when this build has it and otherwise the stand-in from
:mod:`app.fallback` / :mod:`app.preview_renderer`, so the UI code is written once against one shape of
API. :func:`backends` says which one is in use (shown in the About box and the bench JSON).
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

import numpy as np

from app.fallback import FallbackBrush, FallbackDocument, FallbackLibrary

_USED: dict[str, str] = {}


def _has(module: str, attr: str) -> bool:
    try:
        mod = importlib.import_module(module)
        getattr(mod, attr)
        return True
    except (ImportError, AttributeError):
        return False


def backends() -> dict[str, str]:
    """Which implementation each seam used: {"library": "km"|"stand-in", ...}."""
    return dict(_USED)


def load_library() -> Any:
    """The material library (``km.default_library()`` when available)."""
    if _has("km.library", "default_library"):
        try:
            from km.library import default_library

            lib = default_library()
            _USED["library"] = "km"
            return lib
        except Exception:  # a half-written km must not stop the studio
            pass
    _USED["library"] = "stand-in"
    return FallbackLibrary.default()


def real_document_available() -> bool:
    import os

    return os.environ.get("SHEER_DOCUMENT", "auto").strip().lower() != "stand-in" and _has("painting", "Document")


def open_document(head_path: str | Path | None = None, resolution: int = 512, library: Any = None,
                  progress: Any = None) -> Any:
    """The painting document for a head: ``painting.Document`` (through :mod:`app.doc_adapter`) when this
    build has it, else the stand-in."""
    if real_document_available():
        from km.errors import SheerError

        try:
            from app.doc_adapter import DocumentAdapter

            doc = DocumentAdapter.from_head(head_path, resolution, library, progress)
            _USED["document"] = "painting.Document"
            return doc
        except SheerError:
            raise
        except Exception as exc:
            if type(exc).__name__ == "Cancelled":  # app.workers.Cancelled from the progress callback
                raise
            import logging

            logging.getLogger("sheer.app").warning("painting.Document failed (%s); using the stand-in", exc)
    _USED["document"] = "stand-in"
    return FallbackDocument.from_head(head_path, resolution)


def make_brush(radius_mm: float, hardness: float, strength: float, mode: str, mirror: bool) -> Any:
    if _USED.get("document") == "painting.Document":
        from app.doc_adapter import make_brush as real

        return real(radius_mm, hardness, strength, mode, mirror)
    return FallbackBrush(radius_mm=radius_mm, hardness=hardness, strength=strength, mode=mode, mirror=mirror)


def set_thickness(doc: Any, layer: Any, values: np.ndarray) -> None:
    """Replace a layer's whole map as one undo step."""
    doc.set_thickness(layer, np.asarray(values, np.float32))


def _viewport_choice() -> str:
    """``SHEER_VIEWPORT=preview`` forces the stand-in renderer; ``real`` insists on ``render.Renderer``."""
    import os

    return os.environ.get("SHEER_VIEWPORT", "auto").strip().lower()


def real_renderer_available() -> bool:
    return _viewport_choice() != "preview" and _has("render.renderer", "Renderer")


def create_renderer(ctx: Any, head: Any, resolution: int, lazy: bool = False) -> Any:
    """The viewport renderer drawing into the widget's framebuffer: ``render.Renderer`` through
    :mod:`app.render_adapter` when this build has it, else the stand-in preview. ``lazy``: the real
    renderer is attached later (see :class:`app.render_adapter.DualRenderer`)."""
    from app.preview_renderer import PreviewRenderer

    if real_renderer_available():
        try:
            from app.render_adapter import DualRenderer, RealViewportRenderer

            real = RealViewportRenderer(ctx, head, resolution) if not lazy else None
            _USED["renderer"] = "render.Renderer (stand-in preview while moving)"
            return DualRenderer(real, PreviewRenderer(ctx, head, resolution))
        except Exception as exc:
            if _viewport_choice() == "real":
                raise
            import logging

            logging.getLogger("sheer.app").warning("render.Renderer failed (%s); using the preview", exc)
    _USED["renderer"] = "stand-in preview"
    return PreviewRenderer(ctx, head, resolution)


def debug_views() -> list[str]:
    """Names of the viewport's debug views (index 0 is the normal image)."""
    if real_renderer_available():
        try:
            from app.render_adapter import debug_views as real

            return real()
        except Exception:
            pass
    from app.preview_renderer import DEBUG_VIEWS

    return list(DEBUG_VIEWS)


def materials_by_category(library: Any) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for m in library:
        out.setdefault(str(m.category), []).append(m.name)
    return out


# ------------------------------------------------------------------------------------------ looks
_LIPS = [(x, y) for x in np.arange(-0.36, 0.37, 0.06) for y in (0.32, 0.42, 0.55, 0.63)
         if abs(x) < 0.42 - 0.25 * abs(y - 0.47)]
# A look is a list of (category, material, anchor points (x, y) seen from the front, radius mm, passes).
LOOKS: dict[str, list[tuple[str, str, list[tuple[float, float]], float, int]]] = {
    "bare": [],
    "natural": [
        ("foundation", "Foundation Beige",
         [(x, y) for y in np.arange(0.0, 2.4, 0.25) for x in np.arange(-1.2, 1.25, 0.3)], 16.0, 1),
        ("blush", "Blush Peach", [(-0.95, 0.95), (0.95, 0.95)], 14.0, 1),
        ("lipstick", "Lipstick Pink", _LIPS, 5.0, 1),
    ],
    "evening": [
        ("foundation", "Foundation Ivory",
         [(x, y) for y in np.arange(0.0, 2.4, 0.25) for x in np.arange(-1.2, 1.25, 0.3)], 16.0, 1),
        ("eyeshadow", "Eyeshadow Plum", [(-0.62, 1.68), (0.62, 1.68), (-0.8, 1.75), (0.8, 1.75)], 9.0, 2),
        ("blush", "Blush Berry", [(-1.0, 0.95), (1.0, 0.95)], 12.0, 1),
        ("lipstick", "Lipstick Berry", _LIPS, 5.0, 2),
    ],
    "red-lip": [
        ("lipstick", "Lipstick Classic Red",
         _LIPS, 5.0, 3),
    ],
}


def _front_points(doc: Any, xy: list[tuple[float, float]]) -> list[np.ndarray]:
    """Surface points seen from the front at (x, y) anchors (mesh units)."""
    if hasattr(doc, "front_point"):
        pts = [doc.front_point(x, y) for x, y in xy]
        return [p for p in pts if p is not None]
    mesh = doc.head.trimesh()
    origins = np.array([[x, y, 10.0] for x, y in xy])
    dirs = np.tile([0.0, 0.0, -1.0], (len(xy), 1))
    locs, ray_idx, _ = mesh.ray.intersects_location(origins, dirs, multiple_hits=False)
    return [locs[i] for i in np.argsort(ray_idx)]


def apply_look(doc: Any, library: Any, name: str) -> None:
    """Replace the document's layers with the look ``name`` (unknown → SheerError)."""
    from km.errors import SheerError

    if hasattr(doc, "apply_look"):
        for i in reversed(range(len(doc.layers))):
            doc.remove_layer(i)
        doc.apply_look(name)
        return
    if name not in LOOKS:
        raise SheerError(f"unknown look '{name}' (known: {', '.join(LOOKS)})")
    for i in reversed(range(len(doc.layers))):
        doc.remove_layer(i)
    for category, material, xy, radius, passes in LOOKS[name]:
        if material not in library:
            candidates = [m.name for m in library if m.category == category]
            if not candidates:
                continue
            material = candidates[0]
        mat = library.get(material)
        layer = doc.add_layer(material, name=category.title(), max_thickness=float(mat.max_thickness_um))
        brush = make_brush(radius, 0.3, 0.6, "add", False)
        points = _front_points(doc, xy)
        with doc.stroke(layer, brush) as s:
            for _ in range(passes):
                for p in points:
                    s.dab(p)
