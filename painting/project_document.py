"""Adapter between a :class:`painting.project.Project` and the painting ``Document`` (issue 4).

Kept apart so the file format does not depend on the document's internals: only the document's
public API is used (``Document.from_head``, ``add_layer``, ``layer.thickness`` …). Until the document
exists this module still gives the atlas size :func:`painting.project.new_project` needs.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from painting.project_errors import ProjectError


def _document_class() -> Any:
    try:
        from painting import document as document_module  # type: ignore[attr-defined]
    except ImportError:
        return None
    return getattr(document_module, "Document", None)


def atlas_size_for_head(mesh_path: Path | None) -> tuple[int, int]:
    """(H, W) of the painting atlas for a head (texels)."""
    from painting.project import DEFAULT_ATLAS_SIDE

    return (DEFAULT_ATLAS_SIDE, DEFAULT_ATLAS_SIDE)


def document_from_project(project: Any, head_path: str | Path | None = None) -> Any:
    """Build a ``painting.Document`` holding the project's layers."""
    cls = _document_class()
    if cls is None:
        raise ProjectError("painting.Document is not available in this build")
    raise ProjectError("painting.Document integration is not available yet")


def project_from_document(doc: Any, **kwargs: Any) -> Any:
    """Build a :class:`painting.project.Project` from a ``painting.Document``."""
    raise ProjectError("painting.Document integration is not available yet")
