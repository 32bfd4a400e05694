"""Migrations of ``project.json`` from older ``schema_version``s, registered one step at a time.

A migration is a function ``(data: dict) -> dict`` registered with ``@migration(n)``; it turns a
version-``n`` document into a version-``n + 1`` one. :func:`migrate` applies the steps in order on a
deep copy (so a failure leaves the caller's data untouched: the roll-back), checks that each step
produced the next version, and raises :class:`MigrationError` naming the failing step. A version newer
than :data:`SCHEMA_VERSION` raises :class:`ProjectVersionError` saying so.

The original *file* is backed up when a migrated project is first saved over it (``<file>.v<n>.bak``,
see :func:`project.io.save_project`); opening never writes.

Version history (see ``docs/FORMAT.md``):

1. The draft layout: ``head`` a path string with ``head_sha256`` of the mesh alone, one
   ``resolution`` for every layer, layers without opacity, EXR maps only.
2. Current: a head object (path, asset, SHA-256 of every head file, embedded flag), per-layer
   ``resolution``/``opacity``/``encoding``/``scale_um``, ``format``, ``created_by``, ``look``.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from pathlib import PurePosixPath
from typing import Any

from project.errors import MigrationError, ProjectVersionError

#: The version this Sheer writes.
SCHEMA_VERSION = 2
#: The oldest version it can migrate from.
OLDEST_SCHEMA_VERSION = 1

Migration = Callable[[dict[str, Any]], dict[str, Any]]
MIGRATIONS: dict[int, Migration] = {}


def migration(from_version: int) -> Callable[[Migration], Migration]:
    """Register ``func`` as the step ``from_version`` → ``from_version + 1``."""

    def register(func: Migration) -> Migration:
        if from_version in MIGRATIONS:
            raise RuntimeError(f"two migrations from schema_version {from_version}")
        MIGRATIONS[from_version] = func
        return func

    return register


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
            registry: dict[int, Migration] | None = None,
            target: int = SCHEMA_VERSION) -> tuple[dict[str, Any], list[int]]:
    """Bring ``data`` to ``target`` version; returns (new data, versions migrated from).

    ``data`` itself is never modified. ``registry`` defaults to :data:`MIGRATIONS` (tests pass their
    own).
    """
    steps = MIGRATIONS if registry is None else registry
    if not isinstance(data, dict):
        raise MigrationError(f"{source}: project.json must be a JSON object")
    version = check_version(data.get("schema_version"), source)
    current = data
    applied: list[int] = []
    while version < target:
        step = steps.get(version)
        if step is None:
            raise MigrationError(f"{source}: no migration from schema_version {version} to {version + 1}")
        try:
            result = step(copy.deepcopy(current))
        except MigrationError:
            raise
        except Exception as exc:  # a step that fails on odd data: roll back (the input is untouched)
            raise MigrationError(f"{source}: migration from schema_version {version} to {version + 1} "
                                 f"failed ({type(exc).__name__}: {exc}); the file is unchanged") from None
        if not isinstance(result, dict) or result.get("schema_version") != version + 1:
            raise MigrationError(f"{source}: migration from schema_version {version} did not produce "
                                 f"version {version + 1}")
        applied.append(version)
        current = result
        version += 1
    return (current if applied else copy.deepcopy(data)), applied


def _require(data: dict[str, Any], key: str, kind: type | tuple[type, ...]) -> Any:
    if key not in data:
        raise ValueError(f"missing field {key!r}")
    value = data[key]
    if not isinstance(value, kind) or isinstance(value, bool) and kind is not bool:
        raise ValueError(f"field {key!r} has the wrong type")
    return value


@migration(1)
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
