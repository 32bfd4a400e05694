"""The one bridge between a :class:`project.model.Project` (the file) and a :class:`painting.Document`.

:func:`document_from_project` rebuilds a document from a project (the head from disk or from the
project's embedded bytes, the embedded materials as its library, every layer with its map copied
bit-exactly, no undo history); :func:`project_from_document` makes the project to save. No other
module of :mod:`project` imports :mod:`painting.document`.

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

from core.errors import SheerError
from painting.head import HeadError, load_head, load_head_from_bytes
from project.errors import ProjectError
from project.heads import make_head_ref
from project.model import HeadRef, Project, ProjectLayer

if TYPE_CHECKING:
    from pathlib import Path

    from km.library import Library
    from painting.atlas import UVLayout
    from painting.document import Document
    from painting.head import Head


def layout_digest(layout: UVLayout) -> str:
    """SHA-256 (hex) of a paint layout's UVs (float64) and triangles (int64)."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(layout.uv, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(layout.faces, dtype=np.int64).tobytes())
    return h.hexdigest()


def layout_record(layout: UVLayout) -> dict[str, str]:
    """The ``layout`` block of project.json for a document's layout (``source``, ``sha256``)."""
    return {"source": str(layout.source), "sha256": layout_digest(layout)}


def project_library(project: Project) -> Library:
    """A ``km.Library`` of the project's embedded materials."""
    import km

    mats = [km.Material.from_json(m, where=f"materials[{n!r}]") for n, m in project.materials.items()]
    return km.Library(mats, name=f"{project.name} (embedded materials)")


def project_head(project: Project, head_path: str | Path | None = None) -> Head:
    """The head a project paints on: ``head_path`` (a relink), else the embedded or referenced head.

    Raises:
        ProjectError: no head to load, or the head's files cannot be used (the
            :class:`painting.head.HeadError`'s message, after the project's file, else its name).
    """
    try:
        if head_path is not None:
            return load_head(head_path)
        if project.head.data is not None:
            return load_head_from_bytes(project.head.data, project.head.mesh)
        if project.head.mesh_path is None:
            raise ProjectError(f"project '{project.name}': no head to load")
        return load_head(project.head.mesh_path)
    except HeadError as exc:
        raise ProjectError(f"{_where(project)}: {exc}") from None


def _where(project: Project) -> str:
    """Names the project in messages: its file, when it came from one, else its name."""
    return str(project.source_path) if project.source_path is not None else f"project '{project.name}'"


def document_from_project(project: Project, head_path: str | Path | None = None, **doc_kwargs: Any) -> Document:
    """Build a ``painting.Document`` with the project's head, materials and layers (no undo history).

    Args:
        project: the opened project.
        head_path: a mesh replacing the recorded head (after a relink).
        **doc_kwargs: passed to ``Document`` (``progress``, ``cache``, ``history_budget``, ``library``
            to use instead of the embedded materials …).

    Raises:
        ProjectError: the head cannot be loaded, or gives another paint layout than the one the maps
            were painted on.
    """
    from painting.document import Document
    from painting.layout import AtlasError

    head = project_head(project, head_path)
    doc_kwargs.setdefault("library", project_library(project))
    try:
        doc = Document(head, resolution=project.resolution, **doc_kwargs)
    except AtlasError as exc:  # a head that loads but cannot be painted (e.g. only degenerate triangles)
        raise ProjectError(f"{_where(project)}: the head cannot be painted: {exc}") from None
    if project.layout is not None:
        actual = layout_record(doc.layout)
        if actual != project.layout:
            raise ProjectError(
                f"{_where(project)}: the head's paint layout changed since the project was saved "
                f"(saved: {project.layout['source']} {project.layout['sha256'][:12]}…, now: {actual['source']} "
                f"{actual['sha256'][:12]}…): the maps would not line up")
    for pl in project.layers:
        layer = doc.add_layer(pl.material, resolution=pl.resolution, name=pl.name,
                              max_thickness=pl.max_thickness_um)
        if np.any(pl.thickness):
            doc.set_thickness(layer, pl.thickness, detail="open")
        doc.set_layer(layer, visible=bool(pl.visible), opacity=float(pl.opacity))
        if pl.mask is not None or pl.mask_channel is not None:
            from painting.mask import LayerMask

            try:
                recipe = None if pl.mask is None else LayerMask.from_json(pl.mask, "mask")
                doc.set_layer_mask(layer, recipe, pl.mask_channel)
            except SheerError as exc:
                raise ProjectError(f"{_where(project)}: layer {pl.name!r}: {exc}") from None
    doc.clear_history()
    return doc


def project_from_document(doc: Document, *, name: str = "Untitled", base: Project | None = None,
                          head: HeadRef | None = None, lights: list[dict[str, Any]] | None = None,
                          camera: dict[str, Any] | None = None, look: dict[str, Any] | None = None,
                          encoding: str = "exr-float32") -> Project:
    """A :class:`Project` holding ``doc``'s layers (maps copied).

    Args:
        doc: the document.
        name: the project's name; "Untitled" keeps ``base``'s name.
        base: the project the document was opened from (or last saved as); its head reference,
            lights, camera, look and name are kept unless given.
        head: the head reference; default ``base``'s, else the head at ``doc.head.path`` (hashing its
            files).
        lights: the project's lights (plain JSON, see :class:`Project`); default ``base``'s, else none.
        camera: the project's camera (plain JSON) or None; default ``base``'s.
        look: the look metadata (``name``, ``description``, ``tags``) or None; default ``base``'s.
        encoding: every layer map's encoding (one of :data:`project.model.ENCODINGS`).

    Each layer's material is embedded from ``layer.material_object`` (a ``km.Material``).
    """
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
                                   max_thickness_um=float(layer.max_thickness_um), encoding=encoding,
                                   mask=None if layer.mask is None else layer.mask.to_json(),
                                   mask_channel=None if layer.mask_channel is None
                                   else np.array(layer.mask_channel, dtype=np.float32, copy=True)))

    def keep(value: Any, attr: str, default: Any) -> Any:
        return value if value is not None else getattr(base, attr) if base is not None else default

    return Project(
        name=name if base is None or name != "Untitled" else base.name,
        head=head, resolution=int(doc.resolution), layers=layers, materials=materials,
        lights=keep(lights, "lights", []), camera=keep(camera, "camera", None), look=keep(look, "look", None),
        layout=layout_record(doc.layout),
    )
