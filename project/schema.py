"""``project.json``: strict parsing, the JSON Schema and the rules the schema cannot state.

Reading a project runs :func:`parse_json` (refuses NaN, Infinity, overflowing numbers, duplicate keys
and deep nesting), then, after migration, :func:`validate_json` (``resources/project.schema.json``,
JSON Schema 2020-12) and :func:`check_semantics` (maps named by index, materials, lights, camera, head
files). Writing runs the last two on what it is about to write, so Sheer never writes a file it would
refuse to open. Every failure is a :class:`ProjectError` naming the file and the JSON path.
"""

from __future__ import annotations

import functools
import json
import math
from typing import TYPE_CHECKING, Any

from core.errors import SheerError
from project.container import check_entry_name
from project.errors import ProjectError
from project.model import MAX_JSON_DEPTH

if TYPE_CHECKING:
    from collections.abc import Iterable


def parse_json(blob: bytes, where: str) -> Any:
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


def schema() -> dict[str, Any]:
    """The JSON Schema of project.json (``resources/project.schema.json``)."""
    from core.assets import resource_path

    return json.loads(resource_path("project.schema.json").read_text(encoding="utf-8"))


@functools.cache
def _validator() -> Any:
    """The schema validator, built once per process."""
    import jsonschema

    return jsonschema.Draft202012Validator(schema())


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


def check_semantics(data: dict[str, Any], where: str) -> None:
    """What the schema cannot say: cross-field rules (maps by index, materials, camera, lights)."""
    for i, layer in enumerate(data["layers"]):
        ext = "exr" if layer["encoding"] == "exr-float32" else "png"
        expected = f"layers/{i:03d}.{ext}"
        if layer["map"] != expected:
            raise ProjectError(f"{where}: layers[{i}].map: {layer['map']!r}, expected {expected!r}")
        if (layer["encoding"] == "png16") != (layer["scale_um"] is not None):
            raise ProjectError(f"{where}: layers[{i}].scale_um: a number for png16 maps, null for exr-float32")
        channel = (layer["mask"] or {}).get("channel")
        if channel is not None and channel["map"] != f"masks/{i:03d}.exr":
            raise ProjectError(f"{where}: layers[{i}].mask.channel.map: {channel['map']!r}, expected "
                               f"'masks/{i:03d}.exr'")
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
