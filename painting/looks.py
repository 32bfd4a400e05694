"""Built-in looks: cosmetic layers painted with brush strokes at the head's landmarks (reproducible).

A look is a JSON file in ``resources/looks/<name>.json``::

    {"schema_version": 2, "name": "natural", "description": "…",
     "layers": [{"material": "Foundation Ivory", "name": "Foundation",
                 "strokes": [{"points": ["forehead", {"landmark": "left_cheek", "offset_mm": [5, 0, 0]}],
                              "radius_mm": 30, "hardness": 0.3, "strength": 0.8, "amount_um": 12,
                              "mode": "add", "mirror": false}]}]}

Layers are listed bottom first. A point is a landmark name, ``{"landmark": name, "offset_mm": [dx, dy,
dz]}`` (offset in mm in head space, then projected back onto the surface along −Z from the front), or
``[x, y, z]`` in mesh units (projected likewise). Each stroke becomes one brush stroke (one undo step)
through :class:`painting.Document`'s brush API; ``mirror`` paints the mirror image too. ``bare`` has no
layers.

Regions (:mod:`painting.regions`): a stroke may name ``"region"`` (with ``"region_mode"`` ``"inside"``,
the default, or ``"avoid"``) to stay inside or out of it; a stroke ``{"fill_region": "lips",
"amount_um": 20}`` (no points) fills a region to its line with its soft edge
(:meth:`painting.Document.fill_region`); a layer may carry a ``"mask"`` (``{"regions": [["union",
"lips"]], "invert": false, "feather_mm": 0}``, :class:`painting.mask.LayerMask`). Regions and masks
need ``"schema_version": 2``; files of version 1 (without them) are read as they were.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from core.errors import SheerError

if TYPE_CHECKING:
    from painting.document import Document
    from painting.layer import Layer

LOOK_SCHEMA_VERSION = 2
#: what version 2 added (regions): a version-1 file naming any of these is refused, so a file written for
#: this Sheer is never read by an older one as if the regions were not there (the older one refuses 2)
_V2_STROKE_KEYS = ("region", "region_mode", "fill_region")
BUILTIN_LOOKS = ("bare", "natural", "evening", "red-lip", "soft-glam", "no-makeup")
_STROKE_KEYS = {"points", "radius_mm", "hardness", "strength", "amount_um", "mode", "mirror", "flow", "spacing",
                "region", "region_mode", "fill_region"}


class LookError(SheerError, ValueError):
    """An unknown or malformed look; the message names the look (file) and the offending field."""


@dataclass
class LookStroke:
    """One stroke: points (see the module docstring) and brush settings (radius in mm, amount in µm)."""

    points: list[Any]
    radius_mm: float = 10.0
    hardness: float = 0.5
    strength: float = 1.0
    amount_um: float | None = None
    mode: str = "add"
    mirror: bool = False
    flow: float = 1.0
    spacing: float = 0.15
    region: str | None = None
    region_mode: str = "inside"
    fill_region: str | None = None


@dataclass
class LookLayer:
    """One layer of a look: a material (library name), the layer's name and its strokes, in order."""

    material: str
    name: str = ""
    strokes: list[LookStroke] = field(default_factory=list)
    mask: dict[str, Any] | None = None


@dataclass
class Look:
    """A look: its name, a description and its layers, bottom first (see the module docstring)."""

    name: str
    description: str = ""
    layers: list[LookLayer] = field(default_factory=list)

    @classmethod
    def from_json(cls, data: Any, source: str) -> Look:
        """Validate and build a look from its parsed JSON; ``source`` names it in messages.

        Raises:
            LookError: a missing or malformed field (the message names it).
        """
        if not isinstance(data, dict):
            raise LookError(f"{source}: a look must be a JSON object")
        version = data.get("schema_version")
        if isinstance(version, bool) or version not in (1, LOOK_SCHEMA_VERSION):
            raise LookError(f"{source}: schema_version {version!r} is not supported "
                            f"(this Sheer reads 1 to {LOOK_SCHEMA_VERSION})")
        if version == 1:
            _check_version_1(data, source)
        layers_raw = data.get("layers", [])
        if not isinstance(layers_raw, list):
            raise LookError(f"{source}: 'layers' must be a list")
        layers = []
        for i, lay in enumerate(layers_raw):
            where = f"{source}: layers[{i}]"
            if not isinstance(lay, dict) or not isinstance(lay.get("material"), str):
                raise LookError(f"{where}: needs a 'material' name")
            strokes = []
            strokes_raw = lay.get("strokes", [])
            if not isinstance(strokes_raw, list):
                raise LookError(f"{where}: 'strokes' must be a list")
            for j, st in enumerate(strokes_raw):
                w = f"{where}.strokes[{j}]"
                if not isinstance(st, dict):
                    raise LookError(f"{w}: must be an object")
                unknown = set(st) - _STROKE_KEYS
                if unknown:
                    raise LookError(f"{w}: unknown field(s) {sorted(unknown)}")
                pts = st.get("points")
                if "fill_region" in st:
                    if "points" in st or not isinstance(st["fill_region"], str):
                        raise LookError(f"{w}: a 'fill_region' stroke names a region and has no 'points'")
                    st = {**st, "points": []}
                elif not isinstance(pts, list) or not pts:
                    raise LookError(f"{w}: 'points' must be a non-empty list")
                for key in ("region", "fill_region"):
                    if st.get(key) is not None:
                        from painting.regions import REGION_NAMES

                        if st[key] not in REGION_NAMES:
                            raise LookError(f"{w}.{key}: unknown region {st[key]!r} (known: {', '.join(REGION_NAMES)})")
                for key in ("radius_mm", "hardness", "strength", "amount_um", "flow", "spacing"):
                    value = st.get(key)
                    if value is None and (key == "amount_um" or key not in st):
                        continue
                    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                        raise LookError(f"{w}.{key}: must be a finite number, got {value!r}")
                if not isinstance(st.get("mode", "add"), str) or not isinstance(st.get("mirror", False), bool):
                    raise LookError(f"{w}: 'mode' must be a string and 'mirror' true or false")
                try:
                    strokes.append(LookStroke(**st))
                except TypeError as exc:
                    raise LookError(f"{w}: {exc}") from None
            mask = lay.get("mask")
            if mask is not None:
                from painting.mask import LayerMask

                try:
                    LayerMask.from_json(mask, f"{where}.mask")
                except SheerError as exc:
                    raise LookError(str(exc)) from None
            layers.append(LookLayer(lay["material"], str(lay.get("name", lay["material"])), strokes, mask))
        return cls(str(data.get("name", source)), str(data.get("description", "")), layers)


def look_path(name: str) -> Path:
    """The file of the built-in look ``name`` (in ``resources/looks``; it may not exist)."""
    from core.assets import resource_path

    return resource_path("looks", f"{name}.json")


def available_looks() -> list[str]:
    """Names of the looks in ``resources/looks``."""
    from core.assets import resource_path

    return sorted(p.stem for p in resource_path("looks").glob("*.json"))


def load_look(name_or_path: str | Path) -> Look:
    """A look by built-in name (``natural``…) or from a JSON file path."""
    p = Path(name_or_path)
    if p.suffix.lower() != ".json":
        p = look_path(str(name_or_path))
        if not p.is_file():
            raise LookError(f"unknown look '{name_or_path}' (known: {', '.join(available_looks())})")
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise LookError(f"{p}: look file not found") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise LookError(f"{p}: cannot read look: {exc}") from None
    return Look.from_json(data, str(p))


def _front_z(doc: Document) -> float:
    return float(np.asarray(doc.head.vertices)[:, 2].max()) + 1.0


def resolve_point(doc: Document, point: object, where: str) -> np.ndarray:
    """A look point → a surface point (mesh units)."""
    head = doc.head
    offset = np.zeros(3)
    if isinstance(point, str):
        return np.asarray(head.landmark(point), dtype=float)
    if isinstance(point, dict):
        if "landmark" not in point:
            raise LookError(f"{where}: a point object needs 'landmark'")
        base = np.asarray(head.landmark(str(point["landmark"])), dtype=float)
        off = np.asarray(point.get("offset_mm", [0, 0, 0]), dtype=float)
        if off.shape != (3,) or not np.all(np.isfinite(off)):
            raise LookError(f"{where}: 'offset_mm' must be 3 finite numbers")
        offset = off / float(head.mm_per_unit)
        p = base + offset
    else:
        p = np.asarray(point, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise LookError(f"{where}: a point must be a landmark name, an object or [x, y, z]")
    origin = np.array([p[0], p[1], _front_z(doc)], dtype=np.float64)
    cache = _ray_cache(doc)
    if cache is not None and origin.tobytes() in cache[1]:
        return cache[1][origin.tobytes()].copy()
    hit = doc.hit((origin[0], origin[1], origin[2]), (0.0, 0.0, -1.0))
    if hit is None:
        raise LookError(f"{where}: the point {p.tolist()} does not project onto the surface")
    point = np.asarray(getattr(hit, "point", hit), dtype=float)
    if cache is not None and point.shape == (3,):
        cache[1][origin.tobytes()] = point.copy()
        _save_ray_cache(cache[0], cache[1])
    return point


#: Bump when :func:`painting.hit.ray_hit` gives different points for the same layout and ray.
_RAY_CACHE_VERSION = 1
#: layout key → (cache file, {origin float64 bytes: surface point}); the cache holds the results of the
#: straight-down rays of :func:`resolve_point` only (the studio applies its opening look without
#: importing trimesh for the ray queries, ~1.7 s on a slow machine).
_RAY_CACHES: dict[str, tuple[Path, dict[bytes, np.ndarray]]] = {}


def _ray_cache(doc: Document) -> tuple[Path, dict[bytes, np.ndarray]] | None:
    """The look-point cache of ``doc``'s paint layout (a real :class:`painting.Document` only)."""
    from painting.document import Document

    if not isinstance(doc, Document) or type(doc).hit is not Document.hit:
        return None
    key = doc.layout.key
    if key not in _RAY_CACHES:
        from core.cache import cache_dir, load_arrays

        path = cache_dir("looks") / f"{key}-v{_RAY_CACHE_VERSION}.cache"
        entries: dict[bytes, np.ndarray] = {}
        data = load_arrays(path, _RAY_CACHE_VERSION) or {}  # absent or damaged (then deleted): start empty
        origins, points = data.get("origins"), data.get("points")
        if (origins is not None and points is not None and origins.dtype == np.float64
                and points.dtype == np.float64 and origins.ndim == 2 and origins.shape[1:] == (3,)
                and points.shape == origins.shape):
            entries = {o.tobytes(): pt for o, pt in zip(origins, points)}
        _RAY_CACHES[key] = (path, entries)
    return _RAY_CACHES[key]


def _save_ray_cache(path: Path, entries: dict[bytes, np.ndarray]) -> None:
    from core.cache import save_arrays

    origins = np.array([np.frombuffer(k, dtype=np.float64) for k in entries], dtype=np.float64).reshape(-1, 3)
    points = np.array(list(entries.values()), dtype=np.float64).reshape(-1, 3)
    save_arrays(path, {"origins": origins, "points": points}, _RAY_CACHE_VERSION)


#: Bump when a look's painted maps change for the same strokes (the painting code's own source is part
#: of the key too, see :data:`_MAPS_SOURCES`).
_MAPS_CACHE_VERSION = 1
#: The painting modules whose code decides what a stroke paints: a cached look is never reused after
#: any of them changed (:func:`core.cache.source_digest`).
_MAPS_SOURCES: tuple[Path, ...] = tuple(Path(__file__).with_name(name) for name in (
    "brush.py", "document.py", "layer.py", "stroke.py", "spatial.py", "kernels.py", "layout.py", "atlas.py",
    "history.py", "raster.py", "looks.py", "regions.py", "region_shapes.py", "mask.py", "document_masks.py"))


def _maps_cache_path(doc: Document, look: Look, points: list[list[list[np.ndarray]]]) -> Path | None:
    """Where the painted maps of ``look`` on ``doc`` are cached (a real :class:`painting.Document` only).

    Keyed by the paint layout, the layers' resolution, the materials' maximum and default thickness,
    every stroke's brush and resolved surface points, the mirror plane and the painting code.
    """
    from core.cache import source_digest
    from painting.document import Document

    if not isinstance(doc, Document) or type(doc).add_layer is not Document.add_layer:
        return None
    h = hashlib.sha256()
    md = doc.head.metadata
    h.update(f"{doc.layout.key}|{doc.resolution}|{source_digest(_MAPS_SOURCES)}|{md.midplane_point}|{md.midplane_normal}".encode())
    for lay, lay_points in zip(look.layers, points):
        mat = doc.library.get(lay.material)  # a stroke without amount_um adds the material's default
        h.update(f"|{lay.material}|{float(mat.max_thickness_um)!r}|{getattr(mat, 'default_thickness_um', None)!r}"
                 f"|{getattr(mat, 'thickness_um', None)!r}|{json.dumps(lay.mask, sort_keys=True)}"
                 .encode())
        for st, pts in zip(lay.strokes, lay_points):
            h.update(repr((st.radius_mm, st.hardness, st.strength, st.mode, st.flow, st.amount_um, st.spacing,
                           st.mirror, st.region, st.region_mode, st.fill_region)).encode())
            for name in (st.region, st.fill_region):
                if name is not None:  # the region's mask itself (a rebuilt region file paints differently)
                    h.update(doc.regions.get(name).mask.tobytes())
            for p in pts:
                h.update(np.ascontiguousarray(p, dtype="<f8").tobytes())
    from core.cache import cache_dir

    return cache_dir("looks") / f"maps-{h.hexdigest()[:32]}-v{_MAPS_CACHE_VERSION}.cache"


def _load_maps(path: Path | None, count: int, shape: tuple[int, int]) -> list[np.ndarray] | None:
    if path is None:
        return None
    from core.cache import load_arrays

    data = load_arrays(path, _MAPS_CACHE_VERSION)  # None when absent or damaged (then deleted)
    if data is None or any(f"layer{i}" not in data for i in range(count)):
        return None
    maps = [data[f"layer{i}"] for i in range(count)]
    for m in maps:
        if m.shape != shape or m.dtype != np.float32 or not np.all(np.isfinite(m)) or m.min(initial=0.0) < 0:
            return None
    return maps


def _save_maps(path: Path, maps: list[np.ndarray]) -> None:
    from core.cache import save_arrays

    save_arrays(path, {f"layer{i}": m for i, m in enumerate(maps)}, _MAPS_CACHE_VERSION, compress=True)


def apply_look(doc: Document, look: Look | str, clear: bool = True) -> list[Layer]:
    """Paint ``look`` on a :class:`painting.Document` through its brush API; returns the added layers.

    One undo step per stroke and per added layer; ``clear`` removes the document's layers first.

    Every point is resolved on the surface before the document changes (a bad point leaves it as it
    was). The painted maps are cached on disk (:func:`_maps_cache_path`): applying the same look to the
    same layout again sets each layer's map in one undo step instead of replaying the strokes (the
    studio opens on a look; replaying it took 1.5–2.5 s of the start-up at 2048²). The maps are the
    same to the bit either way (tested).
    """
    from painting import Brush

    if isinstance(look, str):
        look = load_look(look)
    points = [[[resolve_point(doc, p, f"look '{look.name}' layers[{i}].strokes[{j}]") for p in st.points]
               for j, st in enumerate(lay.strokes)] for i, lay in enumerate(look.layers)]
    path = _maps_cache_path(doc, look, points)  # also checks every material before anything changes
    if clear:
        for i in reversed(range(len(doc.layers))):
            doc.remove_layer(i)
    added = []
    cached: list[np.ndarray] | None = None
    for i, lay in enumerate(look.layers):
        layer = doc.add_layer(lay.material, name=lay.name or None)
        added.append(layer)
        if lay.mask is not None:
            from painting.mask import LayerMask

            doc.set_layer_mask(layer, LayerMask.from_json(lay.mask, f"look '{look.name}' layers[{i}].mask"))
        if i == 0:
            cached = _load_maps(path, len(look.layers), tuple(layer.thickness.shape))
        if cached is not None:
            doc.set_thickness(layer, cached[i], detail=f"look {look.name}")
            continue
        for st, pts in zip(lay.strokes, points[i]):
            if st.fill_region is not None:
                doc.fill_region(layer, st.fill_region, st.amount_um)
                continue
            brush = Brush(radius_mm=float(st.radius_mm), hardness=float(st.hardness), strength=float(st.strength),
                          mode=st.mode, flow=float(st.flow), amount_um=st.amount_um, spacing=float(st.spacing),
                          mirror=bool(st.mirror), region=st.region, region_mode=st.region_mode)
            with doc.stroke(layer, brush) as s:
                for p in pts:
                    s.dab(p)
    if cached is None and path is not None and added:
        _save_maps(path, [np.asarray(lay.thickness, dtype=np.float32) for lay in added])
    return added


def _check_version_1(data: dict[str, Any], source: str) -> None:
    """Refuse the keys of version 2 in a version-1 look (named, with the version they need)."""
    for i, lay in enumerate(data.get("layers", []) if isinstance(data.get("layers"), list) else []):
        if not isinstance(lay, dict):
            continue
        if "mask" in lay:
            raise LookError(f"{source}: layers[{i}].mask needs \"schema_version\": 2")
        for j, st in enumerate(lay.get("strokes", []) if isinstance(lay.get("strokes"), list) else []):
            used = [k for k in _V2_STROKE_KEYS if isinstance(st, dict) and k in st]
            if used:
                raise LookError(f"{source}: layers[{i}].strokes[{j}].{used[0]} needs \"schema_version\": 2")
