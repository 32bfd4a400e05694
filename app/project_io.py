"""Adapter between the studio's document and ``painting.project`` (the ``.sheer`` format of issue 6).

The studio's document is still the stand-in (:mod:`app.fallback`), so this module converts: layers (name,
material name, thickness µm, visibility, opacity, maximum thickness) and the materials they use (embedded
as ``km.Material.to_json()``). Maps of another size are resampled to the document's resolution.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np


def available() -> bool:
    try:
        from painting.project import open_project, save_project  # noqa: F401
    except ImportError:
        return False
    return True


def _resample(a: np.ndarray, size: int) -> np.ndarray:
    if a.shape == (size, size):
        return a.astype(np.float32, copy=True)
    from PIL import Image

    return np.asarray(Image.fromarray(a.astype(np.float32), mode="F").resize((size, size), Image.BILINEAR),
                      dtype=np.float32)


def load_project_into(doc: Any, library: Any, path: Path) -> str:
    """Replace the document's layers with the project's; materials the library lacks are added from the
    project's embedded copies. Returns the project's name. Raises ``ProjectError`` (a SheerError)."""
    from painting.project import open_project

    project = open_project(path)
    for lay in project.layers:
        if lay.material not in library and lay.material in project.materials:
            library.add(project.material(lay.material))
    for i in reversed(range(len(doc.layers))):
        doc.remove_layer(i)
    from app import seams

    for i, lay in enumerate(project.layers):
        new = doc.add_layer(lay.material, name=lay.name, max_thickness=float(lay.max_thickness_um))
        seams.set_thickness(doc, new, _resample(np.asarray(lay.thickness), new.thickness.shape[0]))
        doc.set_layer(i, visible=bool(lay.visible), opacity=float(lay.opacity))
    doc.clear_history()
    return str(project.name)


def save_document(doc: Any, library: Any, path: Path, name: str) -> Path:
    """Save the document as a ``.sheer`` project (atomic, with ``.bak``)."""
    from painting.project import Project, ProjectLayer, make_head_ref, save_project

    res = doc.layers[0].thickness.shape if doc.layers else (doc.resolution, doc.resolution)
    layers = [ProjectLayer(name=lay.name, material=lay.material, thickness=lay.thickness.astype(np.float32),
                           visible=bool(lay.visible), opacity=float(lay.opacity),
                           max_thickness_um=float(lay.max_thickness)) for lay in doc.layers]
    materials = {lay.material: library.get(lay.material).to_json() for lay in doc.layers
                 if lay.material in library and hasattr(library.get(lay.material), "to_json")}
    project = Project(name=name, head=make_head_ref(doc.head.path), atlas_size=(int(res[0]), int(res[1])),
                      layers=layers, materials=materials)
    return save_project(project, path)
