"""Adapter between a :class:`project.io.Project` (the file) and a :class:`painting.Document` (issue 4).

Only the document's public API is used: ``Document(head, library=…, resolution=…)``, ``add_layer``,
``set_thickness``, ``set_layer``, ``clear_history``, ``layer.thickness`` … So the file format does not
depend on the document's internals.

- Materials: the document gets a ``km.Library`` of the project's embedded copies, so a project opens
  without the library that made it (the studio may merge it into the user's library).
- The paint layout: a project records the layout's source (the mesh's own UVs or an xatlas unwrap)
  and a SHA-256 of its UVs and triangles. If the head gives another layout when the document is
  rebuilt (a different xatlas version, an edited mesh), the maps would land on the wrong texels:
  :func:`document_from_project` refuses with a :class:`ProjectError` instead.
"""

from __future__ import annotations

import hashlib
from typing import TYPE_CHECKING, Any

import numpy as np

from project.errors import ProjectError

if TYPE_CHECKING:
    from pathlib import Path


def layout_digest(layout: Any) -> str:
    """SHA-256 (hex) of a paint layout's UVs (float64) and triangles (int64)."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(layout.uv, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(layout.faces, dtype=np.int64).tobytes())
    return h.hexdigest()


def layout_record(layout: Any) -> dict[str, str]:
    """The ``layout`` block of project.json for a document's layout."""
    return {"source": str(layout.source), "sha256": layout_digest(layout)}


def project_library(project: Any) -> Any:
    """A ``km.Library`` of the project's embedded materials."""
    import km

    mats = [km.Material.from_json(m, where=f"materials[{n!r}]") for n, m in project.materials.items()]
    return km.Library(mats, name=f"{project.name} (embedded materials)")


def document_from_project(project: Any, head_path: str | Path | None = None, **doc_kwargs: Any) -> Any:
    """Build a ``painting.Document`` with the project's head, materials and layers (no undo history).

    ``head_path`` overrides the recorded head (after a relink); ``doc_kwargs`` go to ``Document``
    (``progress``, ``cache``, ``history_budget`` …). Maps are copied bit-exactly.
    """
    from painting.document import Document
    from painting.head import load_head
    from project.head import load_embedded_head

    if head_path is not None:
        head = load_head(head_path)
    elif project.head.embedded:
        head = load_embedded_head(project.head)
    else:
        if project.head.mesh_path is None:
            raise ProjectError(f"project '{project.name}': no head to load")
        head = load_head(project.head.mesh_path)
    doc_kwargs.setdefault("library", project_library(project))
    doc = Document(head, resolution=project.resolution, **doc_kwargs)
    if project.layout is not None:
        actual = layout_record(doc.layout)
        if actual != project.layout:
            raise ProjectError(
                f"project '{project.name}': the head's paint layout changed since the project was saved "
                f"(saved: {project.layout['source']} {project.layout['sha256'][:12]}…, now: {actual['source']} "
                f"{actual['sha256'][:12]}…): the maps would not line up")
    for pl in project.layers:
        layer = doc.add_layer(pl.material, resolution=pl.resolution, name=pl.name,
                              max_thickness=pl.max_thickness_um)
        if np.any(pl.thickness):
            doc.set_thickness(layer, pl.thickness, detail="open")
        doc.set_layer(layer, visible=bool(pl.visible), opacity=float(pl.opacity))
    doc.clear_history()
    return doc


def project_from_document(doc: Any, *, name: str = "Untitled", base: Any = None, head: Any = None,
                          lights: list[dict[str, Any]] | None = None, camera: dict[str, Any] | None = None,
                          look: dict[str, Any] | None = None, encoding: str = "exr-float32") -> Any:
    """A :class:`project.io.Project` holding ``doc``'s layers (maps copied).

    ``base``: the project the document was opened from; its head reference, lights, camera, look and
    name are kept unless given. Otherwise the head is referenced from ``doc.head.path`` (hashing its
    files). Each layer's material is embedded from ``layer.material_object`` (``km.Material``).
    """
    from project.io import Project, ProjectLayer, make_head_ref

    if head is None:
        head = base.head if base is not None else make_head_ref(doc.head.path)
    materials: dict[str, dict[str, Any]] = {}
    layers = []
    for layer in doc.layers:
        mat = layer.material_object
        if not hasattr(mat, "to_json"):
            raise ProjectError(f"layer {layer.name!r}: material {layer.material!r} cannot be embedded")
        materials[layer.material] = mat.to_json()
        layers.append(ProjectLayer(name=layer.name, material=layer.material,
                                   thickness=np.array(layer.thickness, dtype=np.float32, copy=True),
                                   visible=bool(layer.visible), opacity=float(layer.opacity),
                                   max_thickness_um=float(layer.max_thickness_um), encoding=encoding))

    def keep(value: Any, attr: str, default: Any) -> Any:
        return value if value is not None else getattr(base, attr) if base is not None else default

    return Project(
        name=name if base is None or name != "Untitled" else base.name,
        head=head, resolution=int(doc.resolution), layers=layers, materials=materials,
        lights=keep(lights, "lights", []), camera=keep(camera, "camera", None), look=keep(look, "look", None),
        layout=layout_record(doc.layout),
    )
