"""Adapter between the studio's document and ``painting.project`` (the ``.sheer`` format of issue 6):
open, save, autosave snapshots and crash recovery.

Converts layers (name, material name, thickness µm, visibility, opacity, maximum thickness) and the
materials they use (embedded as ``km.Material.to_json()``). Maps of another size are resampled to the
document's resolution.
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


def load_project_into(doc: Any, library: Any, source: Path | Any) -> str:
    """Replace the document's layers with a project's (a path, or a ``Project`` already opened); materials
    the library lacks are added from the project's embedded copies. Returns the project's name. Raises
    ``ProjectError`` (a SheerError) for a bad file; the document is unchanged then."""
    from app import seams
    from painting.project import open_project

    project = open_project(source) if isinstance(source, str | Path) else source
    _check_same_head(project, doc)
    for lay in project.layers:
        if lay.material not in library and lay.material in project.materials:
            library.add(project.material(lay.material))
    for i in reversed(range(len(doc.layers))):
        doc.remove_layer(i)
    for i, lay in enumerate(project.layers):
        new = doc.add_layer(lay.material, name=lay.name, max_thickness=float(lay.max_thickness_um))
        seams.set_thickness(doc, new, _resample(np.asarray(lay.thickness), new.thickness.shape[0]))
        doc.set_layer(i, visible=bool(lay.visible), opacity=float(lay.opacity))
    doc.clear_history()
    return str(project.name)


def _check_same_head(project: Any, doc: Any) -> None:
    """Refuse a project painted on another head (its maps would land on the wrong mesh)."""
    from km.errors import SheerError
    from painting.project import make_head_ref

    ref = make_head_ref(doc.head.path)
    key_mine = ref.files.get(ref.mesh)
    key_theirs = project.head.files.get(project.head.mesh)
    if key_mine is not None and key_theirs is not None and key_mine != key_theirs:
        raise SheerError(f"the project '{project.name}' was painted on another head ({project.head.name}); "
                         f"start Sheer with that head (sheer --head MESH --project FILE) to open it")


def snapshot(doc: Any, library: Any, name: str) -> Any:
    """A ``painting.project.Project`` of the document now (maps copied)."""
    from painting.project import Project, ProjectLayer, make_head_ref

    res = doc.layers[0].thickness.shape if doc.layers else (doc.resolution, doc.resolution)
    layers = [ProjectLayer(name=lay.name, material=lay.material, thickness=np.array(lay.thickness, np.float32),
                           visible=bool(lay.visible), opacity=float(lay.opacity),
                           max_thickness_um=float(lay.max_thickness)) for lay in doc.layers]
    materials = {lay.material: library.get(lay.material).to_json() for lay in doc.layers
                 if lay.material in library and hasattr(library.get(lay.material), "to_json")}
    return Project(name=name, head=make_head_ref(doc.head.path), atlas_size=(int(res[0]), int(res[1])),
                   layers=layers, materials=materials)


def save_document(doc: Any, library: Any, path: Path, name: str) -> Path:
    """Save the document as a ``.sheer`` project (atomic, with ``.bak``; removes its recovery file)."""
    from painting.project import save_project

    return save_project(snapshot(doc, library, name), path)


def make_autosaver(snap: Any, project_path: Path | None, interval_s: float) -> Any:
    """A ``painting.recovery.Autosaver`` (None when this build has no project support)."""
    try:
        from painting.recovery import Autosaver
    except ImportError:
        return None
    return Autosaver(snap, project_path, interval_s=interval_s)


def pending_recoveries() -> list[Any]:
    """Recovery files left by sessions that did not end normally (not another running studio's)."""
    try:
        from painting.recovery import list_recoveries
    except ImportError:
        return []
    return [r for r in list_recoveries() if not r.owner_alive and r.error is None]
