"""Sheer projects: the ``.sheer`` file (see ``docs/FORMAT.md``), opened strictly and saved atomically.

Public API (what the studio, the kiosk and the command line call)::

    from project.io import (Project, ProjectLayer, HeadRef, open_project, save_project,
                                  new_project, ProjectError, HeadChecksumError, HeadMissingError)
    project = open_project(path)                  # every check of docs/FORMAT.md; writes nothing
    project = open_project(path, head_path=NEW)   # relink a moved head (after HeadMissingError /
                                                  # HeadChecksumError); or accept_head_change=True
    save_project(project, path)                   # atomic, keeps path.bak, removes the autosave
    save_project(project, path, self_contained=True)   # the head's files go into the zip
    doc = project.to_document(); project = Project.from_document(doc, materials=..., ...)

Units: thickness maps float32 (H, W) in micrometres; ``max_thickness_um`` in µm; light and camera
positions in head mesh units; angles in degrees. Every failure to open is a :class:`ProjectError`
(a :class:`core.errors.SheerError` and a ``ValueError``) whose message names the file, the entry or
JSON path, and the problem.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import json
import math
import os
import shutil
from dataclasses import InitVar, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from core.atomicio import atomic_writer
from core.errors import SheerError
from project.container import SafeZipReader, check_entry_name, write_container
from project.errors import (
    HeadChecksumError,
    HeadMissingError,
    MigrationError,
    ProjectContainerError,
    ProjectError,
    ProjectVersionError,
)
from project.maps import (
    check_thickness,
    decode_exr,
    decode_png16,
    encode_exr,
    encode_png16,
    png16_scale,
)
from project.migrations import SCHEMA_VERSION, check_version, migrate

if TYPE_CHECKING:
    from collections.abc import Iterable

__all__ = [
    "SCHEMA_VERSION", "MIMETYPE", "Project", "ProjectLayer", "HeadRef", "open_project", "read_project",
    "save_project", "project_bytes", "new_project", "head_file_set", "sha256_file", "ProjectError",
    "ProjectContainerError", "ProjectVersionError", "MigrationError", "HeadChecksumError",
    "HeadMissingError",
]

#: The first entry of every project (stored, uncompressed), as in OpenDocument/OpenRaster.
MIMETYPE = "application/x-sheer-project"
PROJECT_JSON = "project.json"
#: project.json may not be larger than this (bytes).
MAX_PROJECT_JSON_BYTES = 16 * 1024**2
#: An embedded head file may not be larger than this (bytes).
MAX_HEAD_FILE_BYTES = 256 * 1024**2
#: Layer resolution of a new project (texels per side), as ``painting.Document``'s default.
DEFAULT_RESOLUTION = 2048
#: JSON nesting deeper than this is refused (a material is 4 levels deep).
MAX_JSON_DEPTH = 32
_HEAD_PREFIX = "head/"


# ---------------------------------------------------------------------------------------------- model


@dataclass
class HeadRef:
    """Which head a project paints on.

    Attributes:
        name: display name (from the head metadata).
        mesh_path: absolute path of the mesh file, or None when only embedded.
        asset: the mesh as a sample asset path (``heads/<name>/head.glb``), found through the asset
            search path on any machine, or None.
        mesh: key of the mesh in ``files``.
        files: SHA-256 (hex) of each head file, keyed by its path relative to the mesh's folder (the
            metadata sidecar as ``<mesh>.sheer-head.json`` wherever it was found).
        data: the files' bytes when the head is embedded in the project (same keys), else None.
    """

    name: str
    mesh_path: Path | None
    asset: str | None
    mesh: str
    files: dict[str, str]
    data: dict[str, bytes] | None = None

    @property
    def embedded(self) -> bool:
        return self.data is not None


@dataclass
class ProjectLayer:
    """One cosmetic layer: material name, thickness map float32 (N, N) µm, display settings."""

    name: str
    material: str
    thickness: np.ndarray
    visible: bool = True
    opacity: float = 1.0
    max_thickness_um: float = 100.0
    encoding: str = "exr-float32"

    @property
    def resolution(self) -> int:
        """Texels per side of the map."""
        return int(self.thickness.shape[0])

    def same_as(self, other: ProjectLayer) -> bool:
        """Equal settings and bit-identical maps."""
        return (self.name, self.material, self.visible, self.opacity, self.max_thickness_um, self.encoding) == (
            other.name, other.material, other.visible, other.opacity, other.max_thickness_um, other.encoding
        ) and self.thickness.dtype == other.thickness.dtype and np.array_equal(
            self.thickness.view(np.uint32), other.thickness.view(np.uint32))


@dataclass
class Project:
    """Everything a ``.sheer`` file holds (see ``docs/FORMAT.md``).

    Attributes:
        name: display name.
        head: the head reference (and its bytes when embedded).
        resolution: the document's default layer resolution (texels per side, a multiple of 64 in
            64..8192); each layer has its own (``layer.resolution``), its map is that size square.
        layers: bottom layer first.
        materials: embedded material JSON (``km.Material.to_json()``) by name; see :meth:`material`.
        lights: plain JSON dicts (``type``, ``color``, ``intensity``, ``direction`` / ``position`` /
            ``environment`` / ``rotation_deg``), validated on load; painting never imports render.
        camera: a JSON dict (``position``, ``target``, ``up`` in mesh units, ``fov_deg``, ``near``,
            ``far``) or None.
        look: look metadata (``name``, optional ``description``, ``tags``) or None.
        created_by: the Sheer that wrote it.
        source_path: the file it was opened from, if any.
        source_schema_version: the version the file had (older ones are migrated on open).
        recovery: the ``recovery`` block of an autosave file, else None.
        layout: the paint layout the maps were painted on (``source``: "mesh" or "xatlas",
            ``sha256`` of its UVs and triangles; see :mod:`project.document`), or None when
            not known yet (a new project).
    """

    name: str
    head: HeadRef
    resolution: int = 2048
    layers: list[ProjectLayer] = field(default_factory=list)
    materials: dict[str, dict[str, Any]] = field(default_factory=dict)
    lights: list[dict[str, Any]] = field(default_factory=list)
    camera: dict[str, Any] | None = None
    look: dict[str, Any] | None = None
    created_by: str = ""
    source_path: Path | None = None
    source_schema_version: int = SCHEMA_VERSION
    recovery: dict[str, Any] | None = None
    layout: dict[str, str] | None = None
    #: Deprecated spelling from before per-layer resolutions: (H, W) of the maps; sets ``resolution``.
    atlas_size: InitVar[tuple[int, int] | None] = None

    def __post_init__(self, atlas_size: tuple[int, int] | None) -> None:
        if atlas_size is not None:
            self.resolution = int(atlas_size[0])

    def material(self, name: str) -> Any:
        """The embedded material ``name`` as a ``km.Material``."""
        import km

        if name not in self.materials:
            raise ProjectError(f"project '{self.name}': no material named {name!r}")
        return km.Material.from_json(self.materials[name], where=f"materials[{name!r}]")

    def same_as(self, other: Project) -> bool:
        """Equal content (maps bit-exact), ignoring where each was loaded from."""
        return (
            self.name == other.name and self.resolution == other.resolution
            and self.head.files == other.head.files and self.head.mesh == other.head.mesh
            and self.head.asset == other.head.asset and self.head.embedded == other.head.embedded
            and (self.head.data or {}) == (other.head.data or {})
            and len(self.layers) == len(other.layers)
            and all(a.same_as(b) for a, b in zip(self.layers, other.layers))
            and self.materials == other.materials and self.lights == other.lights
            and self.camera == other.camera and self.look == other.look and self.layout == other.layout
        )

    # ---- the painting document (issue 4); see project.document for the adapter

    def to_document(self, head_path: str | Path | None = None, **doc_kwargs: Any) -> Any:
        """A ``painting.Document`` with this project's layers (see :mod:`project.document`)."""
        from project.document import document_from_project

        return document_from_project(self, head_path, **doc_kwargs)

    @classmethod
    def from_document(cls, doc: Any, **kwargs: Any) -> Project:
        """A project from a ``painting.Document`` (see :mod:`project.document`)."""
        from project.document import project_from_document

        return project_from_document(doc, **kwargs)


# ---------------------------------------------------------------------------------------------- head files


def sha256_file(path: Path, limit: int = MAX_HEAD_FILE_BYTES) -> str:
    """Hex SHA-256 of a file, read in 1 MiB blocks (refuses files over ``limit`` bytes)."""
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
    from painting.head import SIDECAR_SUFFIX, find_sidecar, load_metadata, resolve_texture_path

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
    """Reference the head at ``mesh_path`` (default: the sample head), hashing its files."""
    from painting.head import SAMPLE_HEAD, load_metadata

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
    """The same head with its files' bytes (checked against the recorded SHA-256)."""
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


def _verify_head(ref: HeadRef, source: str) -> None:
    """Check every recorded head file's SHA-256 on disk (raises :class:`HeadChecksumError`)."""
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


# ---------------------------------------------------------------------------------------------- reading


def _strict_json(blob: bytes, where: str) -> Any:
    """Parse JSON refusing NaN/Infinity, non-finite numbers, duplicate keys and deep nesting."""

    def pairs(items: list[tuple[str, Any]]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for key, value in items:
            if key in out:
                raise ProjectError(f"{where}: duplicate key {key!r}")
            out[key] = value
        return out

    def constant(name: str) -> Any:
        raise ProjectError(f"{where}: {name} is not a valid number")

    def number(text: str) -> float:
        value = float(text)
        if not math.isfinite(value):
            raise ProjectError(f"{where}: number {text[:40]} is out of range")
        return value

    try:
        text = blob.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ProjectError(f"{where}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    depth = 0
    deepest = 0
    for ch in text:  # cheap nesting check before the recursive parser sees it
        if ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
    if deepest > MAX_JSON_DEPTH:
        raise ProjectError(f"{where}: JSON nested deeper than {MAX_JSON_DEPTH} levels")
    try:
        return json.loads(text, object_pairs_hook=pairs, parse_constant=constant, parse_float=number)
    except ProjectError:
        raise
    except (json.JSONDecodeError, ValueError, RecursionError) as exc:
        raise ProjectError(f"{where}: invalid JSON ({exc})") from None


_VALIDATOR: Any = None


def schema() -> dict[str, Any]:
    """The JSON Schema of project.json (``resources/project.schema.json``)."""
    from core.assets import resource_path

    return json.loads(resource_path("project.schema.json").read_text(encoding="utf-8"))


def _validator() -> Any:
    global _VALIDATOR
    if _VALIDATOR is None:
        import jsonschema

        _VALIDATOR = jsonschema.Draft202012Validator(schema())
    return _VALIDATOR


def _json_path(parts: Iterable[Any]) -> str:
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "(top level)"


def validate_json(data: Any, where: str) -> None:
    """Check parsed project.json against the schema; the message names the JSON path."""
    import jsonschema

    error = jsonschema.exceptions.best_match(_validator().iter_errors(data))
    if error is None:
        return
    message = error.message
    if len(message) > 200:
        message = message[:200] + "…"
    raise ProjectError(f"{where}: {_json_path(error.absolute_path)}: {message}")


def _check_semantics(data: dict[str, Any], where: str) -> None:
    """What the schema cannot say: cross-field rules (maps by index, materials, camera, lights)."""
    for i, layer in enumerate(data["layers"]):
        ext = "exr" if layer["encoding"] == "exr-float32" else "png"
        expected = f"layers/{i:03d}.{ext}"
        if layer["map"] != expected:
            raise ProjectError(f"{where}: layers[{i}].map: {layer['map']!r}, expected {expected!r}")
        if (layer["encoding"] == "png16") != (layer["scale_um"] is not None):
            raise ProjectError(f"{where}: layers[{i}].scale_um: a number for png16 maps, null for exr-float32")
        if layer["material"] not in data["materials"]:
            raise ProjectError(f"{where}: layers[{i}].material: unknown material {layer['material']!r} "
                               "(not embedded in the project)")
    import km

    for name, mat in data["materials"].items():
        try:
            material = km.Material.from_json(mat, where=f"materials[{name!r}]")
        except SheerError as exc:
            raise ProjectError(f"{where}: {exc}") from None
        if material.name != name:
            raise ProjectError(f"{where}: materials[{name!r}].name: {material.name!r} differs from its key")
    for i, light in enumerate(data["lights"]):
        if "direction" in light and not any(light["direction"]):
            raise ProjectError(f"{where}: lights[{i}].direction: must not be zero")
        if "environment" in light and check_entry_name(light["environment"]):
            raise ProjectError(f"{where}: lights[{i}].environment: {check_entry_name(light['environment'])} "
                               "(a sample-asset path such as environments/studio.exr)")
    cam = data["camera"]
    if cam is not None:
        if cam["far"] <= cam["near"]:
            raise ProjectError(f"{where}: camera.far: must be greater than camera.near")
        if not any(cam["up"]):
            raise ProjectError(f"{where}: camera.up: must not be zero")
        if cam["position"] == cam["target"]:
            raise ProjectError(f"{where}: camera.target: must differ from camera.position")
    head = data["head"]
    if head["mesh"] not in head["files"]:
        raise ProjectError(f"{where}: head.mesh: {head['mesh']!r} is not in head.files")
    for key in head["files"]:
        problem = check_entry_name(key)
        if problem:
            raise ProjectError(f"{where}: head.files: {key!r}: {problem}")
    if head["embedded"]:
        if head["path"] is not None:
            raise ProjectError(f"{where}: head.path: must be null for an embedded head")
    elif head["path"] is None and head["asset"] is None:
        raise ProjectError(f"{where}: head: neither path nor asset given")


def _resolve_head_path(head: dict[str, Any], project_dir: Path | None) -> Path | None:
    candidates: list[Path] = []
    if head["path"] is not None:
        p = Path(head["path"])
        if not p.is_absolute() and project_dir is not None:
            p = project_dir / p
        candidates.append(p)
    if head["asset"] is not None and check_entry_name(head["asset"]) is None:
        from core.assets import assets_search_path

        candidates += [folder / head["asset"] for folder in assets_search_path()]
    candidates = [Path(os.path.normpath(c.absolute())) for c in candidates]
    for c in candidates:
        if c.is_file():
            return c
    return candidates[0] if candidates else None


def read_project(source: str | Path | Any, *, name: str | None = None, project_dir: Path | None = None,
                 head_path: str | Path | None = None, accept_head_change: bool = False,
                 verify_head: bool = True) -> Project:
    """Read a project from a path or a binary file object (see :func:`open_project`)."""
    label = name or str(source)
    with SafeZipReader(source, name=label) as zf:
        return _read(zf, label, project_dir, head_path, accept_head_change, verify_head)


def _read(zf: SafeZipReader, label: str, project_dir: Path | None, head_path: str | Path | None,
          accept_head_change: bool, verify_head: bool) -> Project:
    if PROJECT_JSON not in zf:
        raise ProjectContainerError(f"{label}: missing entry '{PROJECT_JSON}' (not a Sheer project)")
    where = f"{label}: {PROJECT_JSON}"
    raw = _strict_json(zf.read(PROJECT_JSON, MAX_PROJECT_JSON_BYTES), where)
    if not isinstance(raw, dict):
        raise ProjectError(f"{where}: must be a JSON object")
    if "schema_version" not in raw:
        raise ProjectVersionError(f"{where}: missing schema_version")
    source_version = check_version(raw["schema_version"], where)
    data, _steps = migrate(raw, where)
    validate_json(data, where)
    _check_semantics(data, where)

    # the entries: exactly what project.json names (mimetype optional, first)
    expected = {PROJECT_JSON} | {layer["map"] for layer in data["layers"]}
    head = data["head"]
    if head["embedded"]:
        expected |= {_HEAD_PREFIX + key for key in head["files"]}
    names = zf.names()
    if "mimetype" in zf:
        if names[0] != "mimetype":
            raise ProjectContainerError(f"{label}: entry 'mimetype' must be the first entry")
        if zf.read("mimetype", 256) != MIMETYPE.encode():
            raise ProjectContainerError(f"{label}: entry 'mimetype': not {MIMETYPE}")
        expected.add("mimetype")
    extra = [n for n in names if n not in expected]
    if extra:
        raise ProjectContainerError(f"{label}: entry {extra[0]!r}: unexpected entry (not named by project.json)")
    missing = sorted(expected - set(names))
    if missing:
        raise ProjectContainerError(f"{label}: missing entry {missing[0]!r}")

    layers: list[ProjectLayer] = []
    for i, layer in enumerate(data["layers"]):
        entry = layer["map"]
        blob = zf.read(entry)
        at = f"{label}: entry {entry!r} (layer {i} {layer['name']!r})"
        if layer["sha256"] is not None:
            actual = hashlib.sha256(blob).hexdigest()
            if actual != layer["sha256"]:
                raise ProjectError(f"{at}: SHA-256 {actual[:12]}… does not match layers[{i}].sha256 "
                                   f"({layer['sha256'][:12]}…): the map is damaged or belongs to another layer")
        shape = (int(layer["resolution"]), int(layer["resolution"]))
        if layer["encoding"] == "exr-float32":
            thickness = decode_exr(blob, at, shape)
        else:
            thickness = decode_png16(blob, at, shape, float(layer["scale_um"]))
        layers.append(ProjectLayer(
            name=layer["name"], material=layer["material"], thickness=thickness, visible=layer["visible"],
            opacity=float(layer["opacity"]), max_thickness_um=float(layer["max_thickness_um"]),
            encoding=layer["encoding"]))

    ref = _read_head(zf, label, head, project_dir, head_path, accept_head_change, verify_head)
    return Project(
        name=data["name"], head=ref, resolution=int(data["resolution"]), layers=layers, materials=data["materials"],
        lights=data["lights"], camera=data["camera"], look=data["look"], created_by=data["created_by"],
        source_schema_version=source_version, recovery=data.get("recovery"), layout=data["layout"],
    )


def _read_head(zf: SafeZipReader, label: str, head: dict[str, Any], project_dir: Path | None,
               head_path: str | Path | None, accept_head_change: bool, verify_head: bool) -> HeadRef:
    files = dict(head["files"])
    if head["embedded"]:
        data: dict[str, bytes] = {}
        for key, digest in files.items():
            entry = _HEAD_PREFIX + key
            blob = zf.read(entry, MAX_HEAD_FILE_BYTES)
            actual = hashlib.sha256(blob).hexdigest()
            if actual != digest:
                raise ProjectError(f"{label}: entry {entry!r}: SHA-256 {actual[:12]}… does not match "
                                   f"head.files ({digest[:12]}…): the embedded head is damaged")
            data[key] = blob
        return HeadRef(head["name"], None, head["asset"], head["mesh"], files, data)
    relinked = head_path is not None
    mesh_path = Path(head_path).absolute() if relinked else _resolve_head_path(head, project_dir)
    ref = HeadRef(head["name"], mesh_path, head["asset"], head["mesh"], files, None)
    if not verify_head:
        return ref
    if mesh_path is None or not mesh_path.is_file():
        raise HeadMissingError(f"{label}: head mesh {head['path'] or head['asset']!r} not found "
                               f"(looked at {mesh_path}): relink the head", mesh_path)
    if relinked and mesh_path.name != head["mesh"]:
        # a relinked head may have another file name: re-key the mesh
        files = {(mesh_path.name if k == head["mesh"] else k): v for k, v in files.items()}
        sidecar_old = head["mesh"] + ".sheer-head.json"
        if sidecar_old in files:
            files[mesh_path.name + ".sheer-head.json"] = files.pop(sidecar_old)
        ref = HeadRef(head["name"], mesh_path, head["asset"], mesh_path.name, files, None)
    if accept_head_change:
        fresh = make_head_ref(mesh_path)
        return HeadRef(fresh.name, mesh_path, fresh.asset, fresh.mesh, fresh.files, None)
    _verify_head(ref, label)
    return ref


def open_project(path: str | Path, *, head_path: str | Path | None = None, accept_head_change: bool = False,
                 verify_head: bool = True) -> Project:
    """Open a ``.sheer`` file, checking everything (``docs/FORMAT.md``); never writes anything.

    Args:
        path: the project file.
        head_path: relink: use this mesh instead of the recorded one (its files are still checked
            against the recorded SHA-256 unless ``accept_head_change``).
        accept_head_change: take the head on disk as it is now (record its new checksums).
        verify_head: False skips looking for the referenced head at all (``sheer project info``).

    Raises:
        ProjectError: any problem, naming the entry; :class:`HeadMissingError` and
        :class:`HeadChecksumError` when the head is gone or changed (offer to relink),
        :class:`ProjectVersionError` for a newer file, :class:`MigrationError` when an older one
        cannot be upgraded.
    """
    p = Path(path)
    if not p.is_file():
        raise ProjectError(f"{p}: {'not a regular file' if p.exists() else 'no such project file'}")
    project = read_project(p, name=str(p), project_dir=p.absolute().parent, head_path=head_path,
                           accept_head_change=accept_head_change, verify_head=verify_head)
    project.source_path = p.absolute()
    return project


def project_version(path: str | Path) -> int:
    """The ``schema_version`` recorded in a project file (checked for safety, not migrated)."""
    with SafeZipReader(path, name=str(path)) as zf:
        if PROJECT_JSON not in zf:
            raise ProjectContainerError(f"{path}: missing entry '{PROJECT_JSON}'")
        raw = _strict_json(zf.read(PROJECT_JSON, MAX_PROJECT_JSON_BYTES), f"{path}: {PROJECT_JSON}")
    if not isinstance(raw, dict):
        raise ProjectError(f"{path}: {PROJECT_JSON}: must be a JSON object")
    return check_version(raw.get("schema_version"), f"{path}: {PROJECT_JSON}")


# ---------------------------------------------------------------------------------------------- writing


def _number(x: float) -> float | int:
    return float(x)


def encode_maps(project: Project) -> list[bytes]:
    """Each layer's map entry (EXR or PNG bytes), after checking the map (dtype, square shape, values)."""
    out = []
    for i, layer in enumerate(project.layers):
        where = f"project '{project.name}': layer {i} {layer.name!r}"
        if layer.encoding not in ("exr-float32", "png16"):
            raise ProjectError(f"{where}: unknown encoding {layer.encoding!r}")
        shape = np.shape(layer.thickness)
        side = int(shape[0]) if len(shape) == 2 else 0
        thickness = check_thickness(layer.thickness, where, (side, side))
        if layer.encoding == "exr-float32":
            out.append(encode_exr(thickness))
        else:
            out.append(encode_png16(thickness, png16_scale(thickness)))
    return out


def project_json(project: Project, target_dir: Path | None, self_contained: bool,
                 maps: list[bytes] | None = None) -> dict[str, Any]:
    """The project.json dict for ``project`` saved into ``target_dir`` (head path made relative);
    ``maps`` are the encoded map entries (:func:`encode_maps`, computed when not given).
    """
    head = project.head
    if maps is None:
        maps = encode_maps(project)
    path_text: str | None = None
    if not self_contained:
        if head.mesh_path is None:
            raise ProjectError(f"project '{project.name}': the head is only embedded; save it self-contained")
        path_text = str(head.mesh_path)
        if target_dir is not None:
            with contextlib.suppress(ValueError):
                path_text = Path(os.path.relpath(head.mesh_path, target_dir.absolute())).as_posix()
    layers = []
    for i, layer in enumerate(project.layers):
        if layer.encoding not in ("exr-float32", "png16"):
            raise ProjectError(f"layer {layer.name!r}: unknown encoding {layer.encoding!r}")
        ext = "exr" if layer.encoding == "exr-float32" else "png"
        layers.append({
            "name": layer.name, "material": layer.material, "visible": bool(layer.visible),
            "opacity": _number(layer.opacity), "max_thickness_um": _number(layer.max_thickness_um),
            "resolution": int(layer.thickness.shape[0]) if np.ndim(layer.thickness) == 2 else 0,
            "map": f"layers/{i:03d}.{ext}", "encoding": layer.encoding,
            "scale_um": png16_scale(layer.thickness) if layer.encoding == "png16" else None,
            "sha256": hashlib.sha256(maps[i]).hexdigest(),
        })
    out: dict[str, Any] = {
        "schema_version": SCHEMA_VERSION,
        "format": "sheer-project",
        "name": project.name,
        "created_by": _created_by(),
        "resolution": int(project.resolution),
        "head": {"name": head.name, "path": path_text, "asset": head.asset, "mesh": head.mesh,
                 "files": dict(sorted(head.files.items())), "embedded": bool(self_contained)},
        "layers": layers,
        "materials": copy.deepcopy(project.materials),
        "lights": copy.deepcopy(project.lights),
        "camera": copy.deepcopy(project.camera),
        "look": copy.deepcopy(project.look),
        "layout": None if project.layout is None else dict(project.layout),
    }
    if project.recovery is not None:
        out["recovery"] = dict(project.recovery)
    return out


def _created_by() -> str:
    try:
        from importlib.metadata import version

        return f"Sheer {version('sheer')}"
    except Exception:
        return "Sheer"


def _entries(project: Project, target_dir: Path | None, self_contained: bool) -> list[tuple[str, bytes, bool]]:
    """Validate ``project`` as it would be read back, then produce the zip entries."""
    head = embed_head(project.head) if self_contained else project.head
    maps = encode_maps(project)
    doc = project_json(project, target_dir, self_contained, maps)
    where = f"project '{project.name}'"
    validate_json(doc, where)  # never write a file this Sheer would refuse to open
    _check_semantics(doc, where)
    entries: list[tuple[str, bytes, bool]] = [
        ("mimetype", MIMETYPE.encode(), False),
        (PROJECT_JSON, json.dumps(doc, indent=1, ensure_ascii=False, allow_nan=False).encode("utf-8"), True),
    ]
    for blob, meta in zip(maps, doc["layers"]):
        entries.append((meta["map"], blob, False))
    if self_contained:
        assert head.data is not None
        for key in sorted(head.data):
            entries.append((_HEAD_PREFIX + key, head.data[key], True))
    return entries


def project_bytes(project: Project, *, self_contained: bool = False, target_dir: Path | None = None) -> bytes:
    """The ``.sheer`` file content in memory (used by tests, the fuzzer and autosave)."""
    import io

    buf = io.BytesIO()
    write_container(buf, _entries(project, target_dir, self_contained))
    return buf.getvalue()


def save_project(project: Project, path: str | Path, *, self_contained: bool | None = None,
                 keep_backup: bool = True, clear_recovery: bool = True) -> Path:
    """Save atomically: temporary file in the same folder, flush + fsync, rename over ``path``.

    The previous file is kept as ``<path>.bak`` (``keep_backup``). When the file being replaced has an
    older ``schema_version`` (the project was migrated on open), it is also copied once to
    ``<path>.v<N>.bak`` first, so the original is never lost. A crash at any moment leaves either the
    old or the new file, both loadable. After a normal save the autosave recovery file of ``path`` is
    removed (``clear_recovery``). ``self_contained=None`` keeps the head embedded if it was.

    Returns the absolute path written.
    """
    target = Path(path).absolute()
    embed = project.head.embedded if self_contained is None else bool(self_contained)
    entries = _entries(project, target.parent, embed)  # everything validated before the file is touched
    if target.exists():
        with contextlib.suppress(ProjectError, OSError):
            old = project_version(target)
            if old < SCHEMA_VERSION:
                original = target.with_name(f"{target.name}.v{old}.bak")
                if not original.exists():
                    shutil.copy2(target, original)
    with atomic_writer(target, "wb", keep_backup=keep_backup) as fh:
        write_container(fh, entries)
    if embed and project.head.data is None:
        project.head = embed_head(project.head)
    project.source_path = target
    project.source_schema_version = SCHEMA_VERSION
    if clear_recovery:
        from project.recovery import discard_recovery

        discard_recovery(target)
    return target


def new_project(name: str = "Untitled", head_path: str | Path | None = None, look: str | None = None,
                resolution: int | None = None) -> Project:
    """An empty project on the head at ``head_path`` (default: the sample head).

    ``resolution`` (texels per side) defaults to :data:`DEFAULT_RESOLUTION`, the document's default.
    """
    ref = make_head_ref(head_path)
    return Project(name=name, head=ref, resolution=int(resolution or DEFAULT_RESOLUTION),
                   look=None if look is None else {"name": look}, created_by=_created_by())
