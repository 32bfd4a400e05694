"""Adapters between the studio and the packages it builds on (``km``, ``painting``, ``render``,
``painting.project``).

Each function returns the real implementation when this build has it and otherwise the stand-in from
:mod:`app.fallback` / :mod:`app.preview_renderer`, so the UI code is written once against one shape of
API. :func:`backends` says which one is in use (shown in the About box and the bench JSON).
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator
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


def open_document(head_path: str | Path | None = None, resolution: int = 512) -> Any:
    """The painting document for a head (the stand-in until ``painting.Document`` lands)."""
    _USED["document"] = "stand-in"
    return FallbackDocument.from_head(head_path, resolution)


def make_brush(radius_mm: float, hardness: float, strength: float, mode: str, mirror: bool) -> Any:
    return FallbackBrush(radius_mm=radius_mm, hardness=hardness, strength=strength, mode=mode, mirror=mirror)


def create_renderer(ctx: Any, head: Any, resolution: int) -> Any:
    """The viewport renderer drawing into the widget's framebuffer."""
    from app.preview_renderer import PreviewRenderer

    _USED["renderer"] = "stand-in preview"
    return PreviewRenderer(ctx, head, resolution)


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


def _front_points(head: Any, xy: list[tuple[float, float]]) -> Iterator[np.ndarray]:
    mesh = head.trimesh()
    origins = np.array([[x, y, 10.0] for x, y in xy])
    dirs = np.tile([0.0, 0.0, -1.0], (len(xy), 1))
    locs, ray_idx, _ = mesh.ray.intersects_location(origins, dirs, multiple_hits=False)
    for i in np.argsort(ray_idx):
        yield locs[i]


def apply_look(doc: Any, library: Any, name: str) -> None:
    """Replace the document's layers with the look ``name`` (unknown → SheerError)."""
    from km.errors import SheerError

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
        points = list(_front_points(doc.head, xy))
        with doc.stroke(layer, brush) as s:
            for _ in range(passes):
                for p in points:
                    s.dab(p)
