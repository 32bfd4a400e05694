"""Reading and writing ``.sheer`` files (see ``docs/FORMAT.md``): opened strictly, saved atomically.

Public API (what the studio, the kiosk and the command line call; also exported by :mod:`project`)::

    project = open_project(path)                  # every check of docs/FORMAT.md; writes nothing
    project = open_project(path, head_path=NEW)   # relink a moved head (after HeadMissingError /
                                                  # HeadChecksumError); or accept_head_change=True
    save_project(project, path)                   # atomic, keeps path.bak, removes the autosave
    save_project(project, path, self_contained=True)   # the head's files go into the zip

The model is :mod:`project.model`, the zip policy :mod:`project.container`, project.json's checks
:mod:`project.schema`, head references :mod:`project.heads`, the maps' codec :mod:`painting.maps_io`
(its :class:`~painting.maps_io.MapError` becomes a :class:`ProjectError` naming the file and entry), and
a ``painting.Document`` is made from a project by :mod:`project.document`.

Every failure to open is a :class:`ProjectError` (a :class:`core.errors.SheerError` and a
``ValueError``) whose message names the file, the entry or JSON path, and the problem.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import io
import json
import os
import shutil
from pathlib import Path
from typing import IO, Any

import numpy as np

from core.atomicio import atomic_writer
from core.locks import writing
from painting.head import MAX_HEAD_FILE_BYTES
from painting.maps_io import (
    MapError,
    check_thickness,
    decode_exr,
    decode_png,
    encode_exr,
    encode_png16,
    from_counts,
    png16_um_per_count,
    quantise,
)
from project.container import SafeZipReader, write_container
from project.errors import ProjectContainerError, ProjectError, ProjectVersionError
from project.heads import embed_head, make_head_ref, referenced_head
from project.migrations import SCHEMA_VERSION, check_version, migrate
from project.model import (
    DEFAULT_RESOLUTION,
    ENCODINGS,
    HEAD_PREFIX,
    MAX_PROJECT_JSON_BYTES,
    MIMETYPE,
    PROJECT_JSON,
    HeadRef,
    Project,
    ProjectLayer,
)
from project.recovery_files import discard_recovery, remove_stale_temporaries
from project.schema import check_semantics, parse_json, validate_json

#: A temporary file beside a project older than this (s) was left by a killed save: the next save removes it.
STALE_TEMP_S = 3600.0

# ---------------------------------------------------------------------------------------------- reading


def read_project(source: str | Path | IO[bytes], *, name: str | None = None, project_dir: Path | None = None,
                 head_path: str | Path | None = None, accept_head_change: bool = False,
                 verify_head: bool = True) -> Project:
    """Read a project from a path or a binary file object (see :func:`open_project`).

    ``name`` names the source in messages (default ``str(source)``); ``project_dir`` is the folder a
    relative head path is resolved against (None: only absolute paths and asset paths).
    """
    label = name or str(source)
    with SafeZipReader(source, name=label) as zf:
        return _read(zf, label, project_dir, head_path, accept_head_change, verify_head)


def _read_json(zf: SafeZipReader, label: str) -> dict[str, Any]:
    """project.json parsed strictly (not migrated): a JSON object."""
    if PROJECT_JSON not in zf:
        raise ProjectContainerError(f"{label}: missing entry '{PROJECT_JSON}' (not a Sheer project)")
    where = f"{label}: {PROJECT_JSON}"
    raw = parse_json(zf.read(PROJECT_JSON, MAX_PROJECT_JSON_BYTES), where)
    if not isinstance(raw, dict):
        raise ProjectError(f"{where}: must be a JSON object")
    return raw


def _check_entries(zf: SafeZipReader, label: str, data: dict[str, Any]) -> None:
    """The entries must be exactly what project.json names (``mimetype`` optional, and then first)."""
    expected = {PROJECT_JSON} | {layer["map"] for layer in data["layers"]}
    expected |= {layer["mask"]["channel"]["map"] for layer in data["layers"]
                 if layer["mask"] is not None and layer["mask"]["channel"] is not None}
    if data["head"]["embedded"]:
        expected |= {HEAD_PREFIX + key for key in data["head"]["files"]}
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


def _read_layer(zf: SafeZipReader, label: str, i: int, record: dict[str, Any]) -> ProjectLayer:
    """Layer ``i`` of project.json with its map: digest checked, decoded, values checked."""
    entry = record["map"]
    blob = zf.read(entry)
    at = f"{label}: entry {entry!r} (layer {i} {record['name']!r})"
    if record["sha256"] is not None:
        actual = hashlib.sha256(blob).hexdigest()
        if actual != record["sha256"]:
            raise ProjectError(f"{at}: SHA-256 {actual[:12]}… does not match layers[{i}].sha256 "
                               f"({record['sha256'][:12]}…): the map is damaged or belongs to another layer")
    side = int(record["resolution"])
    try:
        if record["encoding"] == "exr-float32":
            values = decode_exr(blob, at, (side, side))
        else:
            values = from_counts(decode_png(blob, at, (side, side))[0], float(record["scale_um"]))
        thickness = check_thickness(values, at, (side, side))
    except MapError as exc:
        raise ProjectError(str(exc)) from None
    mask = record["mask"]
    channel = None if mask is None or mask["channel"] is None else _read_channel(zf, label, i, mask["channel"], side)
    return ProjectLayer(name=record["name"], material=record["material"], thickness=thickness,
                        visible=record["visible"], opacity=float(record["opacity"]),
                        max_thickness_um=float(record["max_thickness_um"]), encoding=record["encoding"],
                        mask=None if mask is None else {k: mask[k] for k in ("regions", "invert", "feather_mm")},
                        mask_channel=channel)


def _read_channel(zf: SafeZipReader, label: str, i: int, record: dict[str, Any], side: int) -> np.ndarray:
    """Layer ``i``'s mask channel: digest checked, decoded (EXR float32 of the layer's size), values in [0, 2]."""
    entry = record["map"]
    blob = zf.read(entry)
    at = f"{label}: entry {entry!r} (mask of layer {i})"
    actual = hashlib.sha256(blob).hexdigest()
    if actual != record["sha256"]:
        raise ProjectError(f"{at}: SHA-256 {actual[:12]}… does not match layers[{i}].mask.channel.sha256 "
                           f"({record['sha256'][:12]}…): the mask is damaged or belongs to another layer")
    try:
        values = decode_exr(blob, at, (side, side))
    except MapError as exc:
        raise ProjectError(str(exc)) from None
    if not np.all(np.isfinite(values)) or values.min(initial=0.0) < 0.0 or values.max(initial=0.0) > 2.0:
        raise ProjectError(f"{at}: mask channel values must be finite and in [0, 2]")
    return values


def _read_embedded_head(zf: SafeZipReader, label: str, record: dict[str, Any]) -> HeadRef:
    """The embedded head's files from their ``head/<key>`` entries, each checked against its SHA-256."""
    data: dict[str, bytes] = {}
    for key, digest in record["files"].items():
        entry = HEAD_PREFIX + key
        blob = zf.read(entry, MAX_HEAD_FILE_BYTES)
        actual = hashlib.sha256(blob).hexdigest()
        if actual != digest:
            raise ProjectError(f"{label}: entry {entry!r}: SHA-256 {actual[:12]}… does not match "
                               f"head.files ({digest[:12]}…): the embedded head is damaged")
        data[key] = blob
    return HeadRef(record["name"], None, record["asset"], record["mesh"], dict(record["files"]), data)


def _read(zf: SafeZipReader, label: str, project_dir: Path | None, head_path: str | Path | None,
          accept_head_change: bool, verify_head: bool) -> Project:
    """Every check of docs/FORMAT.md, in order: project.json, the entries, the maps, the head."""
    raw = _read_json(zf, label)
    where = f"{label}: {PROJECT_JSON}"
    if "schema_version" not in raw:
        raise ProjectVersionError(f"{where}: missing schema_version")
    source_version = check_version(raw["schema_version"], where)
    data, _steps = migrate(raw, where)
    validate_json(data, where)
    check_semantics(data, where)
    _check_entries(zf, label, data)
    layers = [_read_layer(zf, label, i, record) for i, record in enumerate(data["layers"])]
    if data["head"]["embedded"]:
        ref = _read_embedded_head(zf, label, data["head"])
    else:
        ref = referenced_head(data["head"], label, project_dir, head_path, accept_head_change, verify_head)
    return Project(
        name=data["name"], head=ref, resolution=int(data["resolution"]), layers=layers, materials=data["materials"],
        lights=data["lights"], camera=data["camera"], look=data["look"], created_by=data["created_by"],
        source_schema_version=source_version, recovery=data.get("recovery"), layout=data["layout"],
    )


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
        raw = _read_json(zf, str(path))
    return check_version(raw.get("schema_version"), f"{path}: {PROJECT_JSON}")


# ---------------------------------------------------------------------------------------------- writing


def encode_maps(project: Project) -> list[bytes]:
    """Each layer's map entry (EXR or PNG bytes), after checking the map (float32, square, values).

    A PNG map's counts are the thickness / :func:`painting.maps_io.png16_um_per_count` (µm per count).
    """
    out = []
    for i, layer in enumerate(project.layers):
        where = f"project '{project.name}': layer {i} {layer.name!r}"
        if layer.encoding not in ENCODINGS:
            raise ProjectError(f"{where}: unknown encoding {layer.encoding!r}")
        side = layer.resolution if np.ndim(layer.thickness) == 2 else 0
        try:
            thickness = check_thickness(layer.thickness, where, (side, side))
        except MapError as exc:
            raise ProjectError(str(exc)) from None
        if layer.encoding == "exr-float32":
            out.append(encode_exr(thickness))
        else:
            out.append(encode_png16(quantise(thickness, png16_um_per_count(thickness))))
    return out


def encode_channels(project: Project) -> list[bytes | None]:
    """Each layer's mask channel entry (EXR float32 bytes), or None for a layer without one."""
    out: list[bytes | None] = []
    for i, layer in enumerate(project.layers):
        ch = layer.mask_channel
        if ch is None:
            out.append(None)
            continue
        arr = np.asarray(ch)
        if arr.shape != (layer.resolution, layer.resolution) or arr.dtype != np.float32 \
                or not np.all(np.isfinite(arr)) or arr.min() < 0.0 or arr.max() > 2.0:
            raise ProjectError(f"project '{project.name}': layer {i} {layer.name!r}: the mask channel must be "
                               f"float32 {layer.resolution}×{layer.resolution} in [0, 2]")
        out.append(encode_exr(arr))
    return out


def _mask_json(layer: ProjectLayer, i: int, channel: bytes | None) -> dict[str, Any] | None:
    """Layer ``i``'s ``mask`` record (its recipe and its channel entry), or None."""
    if layer.mask is None and channel is None:
        return None
    recipe = layer.mask or {"regions": [], "invert": False, "feather_mm": 0.0}
    return {"regions": [list(r) for r in recipe["regions"]], "invert": bool(recipe["invert"]),
            "feather_mm": float(recipe["feather_mm"]),
            "channel": None if channel is None else {"map": f"masks/{i:03d}.exr",
                                                     "sha256": hashlib.sha256(channel).hexdigest()}}


def project_json(project: Project, target_dir: Path | None, self_contained: bool,
                 maps: list[bytes] | None = None, channels: list[bytes | None] | None = None) -> dict[str, Any]:
    """The project.json dict for ``project`` saved into ``target_dir``.

    The head's path is made relative to ``target_dir`` when it can be; ``self_contained`` records an
    embedded head; ``maps`` are the encoded map entries (:func:`encode_maps`, computed when not given),
    ``channels`` the mask channels' (:func:`encode_channels`, likewise).
    """
    head = project.head
    if maps is None:
        maps = encode_maps(project)
    if channels is None:
        channels = encode_channels(project)
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
        if layer.encoding not in ENCODINGS:
            raise ProjectError(f"layer {layer.name!r}: unknown encoding {layer.encoding!r}")
        ext = "exr" if layer.encoding == "exr-float32" else "png"
        layers.append({
            "name": layer.name, "material": layer.material, "visible": bool(layer.visible),
            "opacity": float(layer.opacity), "max_thickness_um": float(layer.max_thickness_um),
            "resolution": layer.resolution if np.ndim(layer.thickness) == 2 else 0,
            "map": f"layers/{i:03d}.{ext}", "encoding": layer.encoding,
            "scale_um": png16_um_per_count(layer.thickness) if layer.encoding == "png16" else None,
            "sha256": hashlib.sha256(maps[i]).hexdigest(),
            "mask": _mask_json(layer, i, channels[i]),
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
    """``Sheer <installed version>``, or ``Sheer`` when not installed as a package."""
    try:
        from importlib.metadata import version

        return f"Sheer {version('sheer')}"
    except Exception:
        return "Sheer"


def _entries(project: Project, target_dir: Path | None, self_contained: bool) -> list[tuple[str, bytes, bool]]:
    """Validate ``project`` as it would be read back, then produce the zip entries."""
    head = embed_head(project.head) if self_contained else project.head
    maps = encode_maps(project)
    channels = encode_channels(project)
    doc = project_json(project, target_dir, self_contained, maps, channels)
    where = f"project '{project.name}'"
    validate_json(doc, where)  # never write a file this Sheer would refuse to open
    check_semantics(doc, where)
    entries: list[tuple[str, bytes, bool]] = [
        ("mimetype", MIMETYPE.encode(), False),
        (PROJECT_JSON, json.dumps(doc, indent=1, ensure_ascii=False, allow_nan=False).encode("utf-8"), True),
    ]
    for blob, channel, meta in zip(maps, channels, doc["layers"]):
        entries.append((meta["map"], blob, False))
        if channel is not None:
            entries.append((meta["mask"]["channel"]["map"], channel, False))
    if self_contained:
        assert head.data is not None
        for key in sorted(head.data):
            entries.append((HEAD_PREFIX + key, head.data[key], True))
    return entries


def project_bytes(project: Project, *, self_contained: bool = False, target_dir: Path | None = None) -> bytes:
    """The ``.sheer`` file content in memory (see :func:`project_json` for the arguments)."""
    buf = io.BytesIO()
    write_container(buf, _entries(project, target_dir, self_contained))
    return buf.getvalue()


def save_project(project: Project, path: str | Path, *, self_contained: bool | None = None,
                 keep_backup: bool = True, clear_recovery: bool = True, lock: bool = True) -> Path:
    """Save atomically: temporary file in the same folder, flush + fsync, rename over ``path``.

    The previous file is kept as ``<path>.bak`` (``keep_backup``). When the file being replaced has an
    older ``schema_version`` (the project was migrated on open), it is also copied once to
    ``<path>.v<N>.bak`` first, so the original is never lost. A crash at any moment leaves either the
    old or the new file, both loadable. After a normal save this process's autosave recovery file of
    ``path`` is removed (``clear_recovery``). ``self_contained=None`` keeps the head embedded if it was.

    One writer at a time (``lock``, :func:`core.locks.writing`): the write waits for another process's
    save of the same file (up to :data:`core.locks.WRITE_WAIT_S` seconds) and is refused while another
    Sheer has the project open; under the lock, temporary files a killed save left beside it more than
    :data:`STALE_TEMP_S` seconds ago are removed.

    Raises:
        core.locks.LockedError: another Sheer has the project open (the message names it and its host, pid).

    Returns the absolute path written.
    """
    target = Path(path).absolute()
    embed = project.head.embedded if self_contained is None else bool(self_contained)
    entries = _entries(project, target.parent, embed)  # everything validated before the file is touched
    with writing(target) if lock else contextlib.nullcontext():
        if lock:
            remove_stale_temporaries(target, STALE_TEMP_S)
        _write(target, entries, keep_backup)
    if embed and project.head.data is None:
        project.head = embed_head(project.head)
    project.source_path = target
    project.source_schema_version = SCHEMA_VERSION
    if clear_recovery:
        discard_recovery(target)
    return target


def _write(target: Path, entries: list[tuple[str, bytes, bool]], keep_backup: bool) -> None:
    """Write the container of ``entries`` over ``target`` atomically (keeping ``.v<N>.bak`` of an old one)."""
    if target.exists():
        with contextlib.suppress(ProjectError, OSError):
            old = project_version(target)
            if old < SCHEMA_VERSION:
                original = target.with_name(f"{target.name}.v{old}.bak")
                if not original.exists():
                    shutil.copy2(target, original)
    with atomic_writer(target, "wb", keep_backup=keep_backup) as fh:
        write_container(fh, entries)


def new_project(name: str = "Untitled", head_path: str | Path | None = None, look: str | None = None,
                resolution: int | None = None) -> Project:
    """An empty project on the head at ``head_path`` (default: the sample head).

    ``resolution`` (texels per side) defaults to :data:`DEFAULT_RESOLUTION`, the document's default.
    """
    ref = make_head_ref(head_path)
    return Project(name=name, head=ref, resolution=int(resolution or DEFAULT_RESOLUTION),
                   look=None if look is None else {"name": look}, created_by=_created_by())
