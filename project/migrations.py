"""Migrations of ``project.json`` from older ``schema_version``s, registered one step at a time.

A migration is a function ``(data: dict) -> dict`` registered with ``@MIGRATIONS.register(n)`` (a
:class:`core.migrations.Migrations`); it turns a version-``n`` document into a version-``n + 1`` one.
:func:`migrate` applies the steps in order on a deep copy (so a failure leaves the caller's data
untouched: the roll-back), checks that each step produced the next version, and raises
:class:`MigrationError` naming the failing step. A version newer than :data:`SCHEMA_VERSION` raises
:class:`ProjectVersionError` saying so.

The original *file* is backed up when a migrated project is first saved over it (``<file>.v<n>.bak``,
see :func:`project.io.save_project`); opening never writes.

Version history (see ``docs/FORMAT.md``):

1. The draft layout: ``head`` a path string with ``head_sha256`` of the mesh alone, one
   ``resolution`` for every layer, layers without opacity, EXR maps only.
2. A head object (path, asset, SHA-256 of every head file, embedded flag), per-layer
   ``resolution``/``opacity``/``encoding``/``scale_um``, ``format``, ``created_by``, ``look``.
3. Per-layer ``mask`` (facial regions combined, inverted, feathered, and a paint channel map
   ``masks/NNN.exr``), or null.
4. Current: every embedded material states its ``coverage`` (:mod:`km.coverage`), or null (none stated:
   the one its S and K give).
"""

from __future__ import annotations

from pathlib import PurePosixPath
from typing import TYPE_CHECKING, Any

from core.migrations import Migrations
from project.errors import MigrationError, ProjectVersionError

if TYPE_CHECKING:
    from collections.abc import Mapping

    from core.migrations import Step

#: The version this Sheer writes.
SCHEMA_VERSION = 4
#: The oldest version it can migrate from.
OLDEST_SCHEMA_VERSION = 1

#: ``from_version -> step(data) -> data at from_version + 1``.
MIGRATIONS = Migrations(MigrationError)


def check_version(version: Any, source: str) -> int:
    """The integer version, or :class:`ProjectVersionError` (newer, older than supported, not an int)."""
    if isinstance(version, bool) or not isinstance(version, int):
        raise ProjectVersionError(f"{source}: schema_version {version!r} is not a version number")
    if version > SCHEMA_VERSION:
        raise ProjectVersionError(
            f"{source}: written by a newer Sheer (schema_version {version}; this Sheer reads up to "
            f"{SCHEMA_VERSION}): update Sheer to open it")
    if version < OLDEST_SCHEMA_VERSION:
        raise ProjectVersionError(f"{source}: schema_version {version} is older than any Sheer project format")
    return version


def migrate(data: dict[str, Any], source: str,
            registry: Mapping[int, Step] | None = None,
            target: int = SCHEMA_VERSION) -> tuple[dict[str, Any], list[int]]:
    """Bring ``data`` to ``target`` version; returns (new data, versions migrated from).

    ``data`` itself is never modified. ``registry`` defaults to :data:`MIGRATIONS` (tests pass their
    own).

    Raises:
        ProjectVersionError: the version is not a number, newer than this Sheer or older than any.
        MigrationError: ``data`` is not an object; a missing or failing step (named in the message).
    """
    steps = MIGRATIONS if registry is None else Migrations(MigrationError, registry)
    if not isinstance(data, dict):
        raise MigrationError(f"{source}: project.json must be a JSON object")
    version = check_version(data.get("schema_version"), source)
    out = steps.upgrade(data, version=version, target=target, source=source)
    return out, list(range(version, target))


def _require(data: dict[str, Any], key: str, kind: type | tuple[type, ...]) -> Any:
    if key not in data:
        raise ValueError(f"missing field {key!r}")
    value = data[key]
    if not isinstance(value, kind) or isinstance(value, bool) and kind is not bool:
        raise ValueError(f"field {key!r} has the wrong type")
    return value


@MIGRATIONS.register(1)
def _v1_to_v2(data: dict[str, Any]) -> dict[str, Any]:
    """Draft → 2: head object, per-layer resolution/opacity/encoding/scale, format fields."""
    head = _require(data, "head", str)
    digest = _require(data, "head_sha256", str)
    resolution = _require(data, "resolution", int)
    layers = _require(data, "layers", list)
    mesh = PurePosixPath(head.replace("\\", "/")).name or "head"
    new_layers = []
    for layer in layers:
        if not isinstance(layer, dict):
            raise ValueError("a layer is not an object")
        new = dict(layer)
        new.setdefault("opacity", 1.0)
        new.setdefault("encoding", "exr-float32")
        new.setdefault("scale_um", None)
        new.setdefault("resolution", resolution)
        new.setdefault("sha256", None)  # the draft had no map digests: unchecked until saved again
        new_layers.append(new)
    out = {
        "schema_version": 2,
        "format": "sheer-project",
        "name": data.get("name", "Untitled"),
        "created_by": "migrated from schema_version 1",
        "resolution": resolution,
        "head": {"name": PurePosixPath(mesh).stem, "path": head, "asset": None, "mesh": mesh,
                 "files": {mesh: digest.lower()}, "embedded": False},
        "layers": new_layers,
        "materials": data.get("materials", {}),
        "lights": data.get("lights", []),
        "camera": data.get("camera"),
        "look": None,
        "layout": None,
    }
    extra = set(data) - {"schema_version", "name", "head", "head_sha256", "resolution", "layers",
                         "materials", "lights", "camera"}
    if extra:
        raise ValueError(f"unknown field(s) {sorted(extra)} in a schema_version 1 project")
    return out


@MIGRATIONS.register(2)
def _v2_to_v3(data: dict[str, Any]) -> dict[str, Any]:
    """2 → 3: every layer gets ``mask: null`` (no mask: the layer shows everywhere, as before)."""
    layers = _require(data, "layers", list)
    out = dict(data)
    out["layers"] = []
    for layer in layers:
        if not isinstance(layer, dict):
            raise ValueError("a layer is not an object")
        if "mask" in layer:
            raise ValueError("a schema_version 2 layer has a 'mask' field")
        out["layers"].append({**layer, "mask": None})
    out["schema_version"] = 3
    return out


@MIGRATIONS.register(3)
def _v3_to_v4(data: dict[str, Any]) -> dict[str, Any]:
    """3 → 4: every embedded material gets ``coverage: null`` (it states none: its S and K give it on loading)."""
    materials = _require(data, "materials", dict)
    out = dict(data)
    out["materials"] = {}
    for name, material in materials.items():
        if not isinstance(material, dict):
            raise ValueError(f"material {name!r} is not an object")
        out["materials"][name] = {"coverage": None, **material}  # one that has it keeps it (then validated)
    out["schema_version"] = 4
    return out
