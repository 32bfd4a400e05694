"""The ``.sheer`` project format: one file holding a painted look, opened strictly, saved atomically.

A project is a zip (see ``docs/FORMAT.md``) of ``project.json``, each layer's thickness map, the
materials it uses, lights, camera, look, and the head it is painted on (referenced by checksums, or
embedded). Quick start::

    from project import open_project, save_project, document_from_project, project_from_document
    project = open_project("look.sheer")          # every check; writes nothing
    doc = document_from_project(project)          # a painting.Document, maps bit-exact
    save_project(project_from_document(doc, base=project), "look.sheer")   # atomic, keeps .bak

Modules, bottom up (no module imports one listed after it):

- :mod:`project.errors`: :class:`ProjectError` and its kinds (container, version, migration, head).
- :mod:`project.container`: the zip policy (entry names, links, sizes, zip bombs) and the writer.
- :mod:`project.migrations`: ``schema_version`` steps from older files.
- :mod:`project.model`: :class:`Project`, :class:`ProjectLayer`, :class:`HeadRef`, the constants.
- :mod:`project.heads`: head references (the head files' SHA-256, embedding, relinking).
- :mod:`project.schema`: project.json's strict parsing, JSON Schema and cross-field rules.
- :mod:`project.recovery_files`: where autosave files live; removing them.
- :mod:`project.io`: reading and writing ``.sheer`` files (the maps through :mod:`painting.maps_io`).
- :mod:`project.recovery`: autosave and crash recovery.
- :mod:`project.export`: maps, materials, a manifest and OpenRaster for other tools.
- :mod:`project.document`: the only bridge to a ``painting.Document`` (the head loaded by
  :mod:`painting.head`, from files or from the embedded bytes).

May import: :mod:`core`, :mod:`km` and :mod:`painting`; never Qt, GL, :mod:`render` or :mod:`app`. The
public names below are exported lazily (:func:`core.lazy.install_lazy`), so ``import project`` is cheap.
"""

from __future__ import annotations

from core.lazy import install_lazy

#: public name -> module that defines it
_EXPORTS: dict[str, str] = {
    # errors
    "ProjectError": "project.errors",
    "ProjectContainerError": "project.errors",
    "ProjectVersionError": "project.errors",
    "MigrationError": "project.errors",
    "HeadMissingError": "project.errors",
    "HeadChecksumError": "project.errors",
    # the model
    "SCHEMA_VERSION": "project.migrations",
    "Project": "project.model",
    "ProjectLayer": "project.model",
    "HeadRef": "project.model",
    "MIMETYPE": "project.model",
    "DEFAULT_RESOLUTION": "project.model",
    "ENCODINGS": "project.model",
    # head references
    "make_head_ref": "project.heads",
    "embed_head": "project.heads",
    "head_file_set": "project.heads",
    "sha256_file": "project.heads",
    # files
    "open_project": "project.io",
    "read_project": "project.io",
    "save_project": "project.io",
    "project_bytes": "project.io",
    "project_version": "project.io",
    "new_project": "project.io",
    "export_project": "project.export",
    # autosave and recovery
    "Autosaver": "project.recovery",
    "RecoveryInfo": "project.recovery",
    "autosave": "project.recovery",
    "find_recovery": "project.recovery",
    "list_recoveries": "project.recovery",
    "recover": "project.recovery",
    "discard_recovery": "project.recovery_files",
    "recovery_path": "project.recovery_files",
    "stale_temporaries": "project.recovery_files",
    "remove_stale_temporaries": "project.recovery_files",
    # the painting document
    "document_from_project": "project.document",
    "project_from_document": "project.document",
    "layout_record": "project.document",
}

__getattr__, __dir__, __all__ = install_lazy(__name__, _EXPORTS)
