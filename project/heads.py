"""Head references: which files make up a head, their SHA-256, embedding them, finding them again.

A project names its head by the SHA-256 of every head file (the mesh, its metadata sidecar and the
textures the sidecar names), so a head edited or replaced since the project was saved is noticed
(:class:`HeadChecksumError`) and a moved one can be relinked (:class:`HeadMissingError`). The head
itself is loaded by :mod:`painting.head` (from files, or from the embedded bytes in
:mod:`project.document`); this module only hashes, copies and finds its files.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from pathlib import Path
from typing import Any

from painting.head import (
    MAX_HEAD_FILE_BYTES,
    SAMPLE_HEAD,
    SIDECAR_SUFFIX,
    find_sidecar,
    load_metadata,
    resolve_texture_path,
)
from project.container import check_entry_name
from project.errors import HeadChecksumError, HeadMissingError, ProjectError
from project.model import HeadRef


def sha256_file(path: Path, limit: int = MAX_HEAD_FILE_BYTES) -> str:
    """Hex SHA-256 of a file, read in 1 MiB blocks (:class:`ProjectError` for files over ``limit`` bytes)."""
    h = hashlib.sha256()
    size = 0
    with open(path, "rb") as fh:
        while block := fh.read(1 << 20):
            size += len(block)
            if size > limit:
                raise ProjectError(f"{path}: head file over {limit:,} bytes")
            h.update(block)
    return h.hexdigest()


def head_file_set(mesh_path: Path) -> dict[str, Path]:
    """The files that make up the head at ``mesh_path``: key (path relative to the mesh's folder) → path.

    The mesh, its metadata sidecar (keyed ``<mesh>.sheer-head.json`` wherever it was found) and the
    textures the metadata names with relative paths (found beside the mesh or beside the sidecar, as
    :func:`painting.head.resolve_texture_path` does), keyed by that relative path.
    """
    files: dict[str, Path] = {mesh_path.name: mesh_path}
    sidecar = find_sidecar(mesh_path)
    if sidecar is not None:
        files[mesh_path.name + SIDECAR_SUFFIX] = sidecar
        meta = load_metadata(mesh_path)
        for rel in (meta.albedo, meta.normal_map, meta.specular_map, meta.roughness_map, meta.skin_mask):
            if rel is None:
                continue
            key = rel.replace(os.sep, "/")
            path = resolve_texture_path(rel, mesh_path, sidecar)
            if check_entry_name(key) is None and path.is_file():
                files[key] = path
    return files


def _asset_key(mesh_path: Path) -> str | None:
    """``mesh_path`` relative to an assets folder of the search path, or None."""
    from core.assets import assets_search_path

    resolved = mesh_path.resolve()
    for folder in assets_search_path():
        with contextlib.suppress(OSError, ValueError):
            return resolved.relative_to(folder.resolve()).as_posix()
    return None


def make_head_ref(mesh_path: str | Path | None = None, embed: bool = False) -> HeadRef:
    """Reference the head at ``mesh_path`` (default: the sample head), hashing its files.

    ``embed`` also keeps the files' bytes (a head to save inside the project).
    """
    if mesh_path is None:
        from core.assets import find_asset

        mesh_path = find_asset(SAMPLE_HEAD)
    path = Path(mesh_path).absolute()
    if not path.is_file():
        raise HeadMissingError(f"{path}: head mesh not found", path)
    files = head_file_set(path)
    digests = {key: sha256_file(p) for key, p in files.items()}
    data = {key: p.read_bytes() for key, p in files.items()} if embed else None
    return HeadRef(name=load_metadata(path).name, mesh_path=path, asset=_asset_key(path), mesh=path.name,
                   files=digests, data=data)


def embed_head(ref: HeadRef) -> HeadRef:
    """The same head with its files' bytes, each checked against the recorded SHA-256."""
    if ref.data is not None:
        return ref
    if ref.mesh_path is None:
        raise ProjectError(f"head '{ref.name}': neither embedded nor on disk")
    folder_files = head_file_set(ref.mesh_path)
    data: dict[str, bytes] = {}
    for key, digest in ref.files.items():
        if key not in folder_files:
            raise HeadChecksumError(f"{ref.mesh_path}: head file {key!r} is gone", ref.mesh_path, key, digest)
        blob = folder_files[key].read_bytes()
        actual = hashlib.sha256(blob).hexdigest()
        if actual != digest:
            raise HeadChecksumError(f"{folder_files[key]}: head file changed since the project was saved "
                                    f"(SHA-256 {actual[:12]}…, expected {digest[:12]}…)",
                                    ref.mesh_path, key, digest, actual)
        data[key] = blob
    return HeadRef(ref.name, ref.mesh_path, ref.asset, ref.mesh, dict(ref.files), data)


def verify_head(ref: HeadRef, source: str) -> None:
    """Check every recorded head file's SHA-256 on disk; ``source`` names the project in messages.

    Raises:
        HeadChecksumError: a file is missing or changed (the studio offers to relink or accept).
    """
    assert ref.mesh_path is not None
    try:
        on_disk = head_file_set(ref.mesh_path)
    except ProjectError:
        raise
    except Exception as exc:  # a sidecar that no longer parses is a changed head
        raise HeadChecksumError(f"{source}: head {ref.mesh_path}: {exc}", ref.mesh_path) from None
    for key, digest in ref.files.items():
        path = on_disk.get(key)
        if path is None:
            raise HeadChecksumError(f"{source}: head file {key!r} of {ref.mesh_path} is missing (relink the head)",
                                    ref.mesh_path, key, digest, None)
        actual = sha256_file(path)
        if actual != digest:
            raise HeadChecksumError(
                f"{source}: head file {path} changed since the project was saved (SHA-256 {actual[:12]}…, "
                f"expected {digest[:12]}…): relink the head or accept the change", ref.mesh_path, key, digest, actual)


def _resolve_head_path(record: dict[str, Any], project_dir: Path | None) -> Path | None:
    """The mesh a ``head`` record of project.json points to.

    Its path (relative to ``project_dir``), else its asset path on the asset search path; the first
    candidate when none exists, None without candidates.
    """
    candidates: list[Path] = []
    if record["path"] is not None:
        p = Path(record["path"])
        if not p.is_absolute() and project_dir is not None:
            p = project_dir / p
        candidates.append(p)
    if record["asset"] is not None and check_entry_name(record["asset"]) is None:
        from core.assets import assets_search_path

        candidates += [folder / record["asset"] for folder in assets_search_path()]
    candidates = [Path(os.path.normpath(c.absolute())) for c in candidates]
    for c in candidates:
        if c.is_file():
            return c
    return candidates[0] if candidates else None


def referenced_head(record: dict[str, Any], label: str, project_dir: Path | None, head_path: str | Path | None,
                    accept_head_change: bool, verify: bool) -> HeadRef:
    """The :class:`HeadRef` of a validated, not embedded ``head`` record of project.json.

    Args:
        record: the ``head`` object.
        label: names the project in messages.
        project_dir: the project's folder (a relative ``head.path`` is relative to it), or None.
        head_path: relink: this mesh instead of the recorded one (its files keep their recorded
            checksums, re-keyed to its file name).
        accept_head_change: take the head on disk as it is now (its new checksums).
        verify: look for the head and check its files' SHA-256; False only resolves the path.

    Raises:
        HeadMissingError: the mesh is not found (relink). HeadChecksumError: a file changed.
    """
    files = dict(record["files"])
    relinked = head_path is not None
    mesh_path = Path(head_path).absolute() if relinked else _resolve_head_path(record, project_dir)
    ref = HeadRef(record["name"], mesh_path, record["asset"], record["mesh"], files, None)
    if not verify:
        return ref
    if mesh_path is None or not mesh_path.is_file():
        raise HeadMissingError(f"{label}: head mesh {record['path'] or record['asset']!r} not found "
                               f"(looked at {mesh_path}): relink the head", mesh_path)
    if relinked and mesh_path.name != record["mesh"]:
        # a relinked head may have another file name: re-key the mesh
        files = {(mesh_path.name if k == record["mesh"] else k): v for k, v in files.items()}
        sidecar_old = record["mesh"] + SIDECAR_SUFFIX
        if sidecar_old in files:
            files[mesh_path.name + SIDECAR_SUFFIX] = files.pop(sidecar_old)
        ref = HeadRef(record["name"], mesh_path, record["asset"], mesh_path.name, files, None)
    if accept_head_change:
        fresh = make_head_ref(mesh_path)
        return HeadRef(fresh.name, mesh_path, fresh.asset, fresh.mesh, fresh.files, None)
    verify_head(ref, label)
    return ref
