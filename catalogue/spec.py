"""A catalogue spec: a TOML file checked against ``resources/catalogue.schema.json``, then against the world.

Reading is all-or-nothing and happens before any rendering: the TOML syntax (with its line and column),
the JSON Schema (the key path, e.g. ``size[0]``), then what a schema cannot say — the looks, projects,
heads, faces, environments and materials named must exist, a product category must hold products and
each look must have a layer of that category to swap — each refusal a :class:`CatalogueError` naming the
spec file and the key (``spring.toml: looks[1].look: unknown look 'nope' …``). See ``docs/CATALOGUE.md``.

Paths in the spec are relative to the spec's folder. Sizes are pixels, angles degrees, the thickness-map
resolution texels per side.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from catalogue.errors import CatalogueError
from catalogue.labels import LabelCollision, normal, unique_labels
from core.errors import SheerError

if TYPE_CHECKING:
    from km.library import Library

#: Largest spec file read, in bytes.
MAX_SPEC_BYTES = 1024 * 1024
DEFAULT_NAMING = "{product}/{head}-{look}-{light}-{view}-{hash}.png"
NAMING_FIELDS = ("product", "head", "look", "light", "view", "hash", "mode", "size")

#: Light presets: (azimuth °, elevation °, intensity, (r, g, b), casts shadows). "portrait" is
#: ``render.lights.default_lights`` (resolved there, not repeated here).
LIGHT_PRESETS: dict[str, tuple[tuple[float, float, float, tuple[float, float, float], bool], ...] | None] = {
    "portrait": None,
    "key": ((30.0, 25.0, 1.5, (1.0, 0.97, 0.92), True),),
    "flat": ((0.0, 10.0, 1.0, (1.0, 1.0, 1.0), False), (0.0, -30.0, 0.3, (1.0, 1.0, 1.0), False)),
    "none": (),
}


@dataclass(frozen=True)
class HeadSource:
    """One face of the catalogue: the sample head, a head mesh file or a captured face folder.

    Attributes:
        name: the label used in file names and the manifest.
        path: an absolute mesh path, or None for the sample head.
        face: an absolute ``sheer capture`` folder (its albedo; the lightweight engine in that mode), or None.
    """

    name: str
    path: str | None = None
    face: str | None = None


@dataclass(frozen=True)
class LookSource:
    """A look (built-in name or JSON file) painted on every head, or a project rendered on its own head.

    Attributes:
        name: the label.
        look: a built-in look name or an absolute look JSON path, or None.
        project: an absolute ``.sheer`` path, or None.
    """

    name: str
    look: str | None = None
    project: str | None = None


@dataclass(frozen=True)
class LightRig:
    """One lighting of the catalogue.

    Attributes:
        name: the label.
        preset: a key of :data:`LIGHT_PRESETS`, or None when ``directional`` is given.
        directional: (azimuth °, elevation °, intensity) per light, at most 8.
        environment: an HDR environment name or absolute EXR path, or None.
        environment_intensity: mean irradiance of the environment (≥ 0).
    """

    name: str
    preset: str | None = "portrait"
    directional: tuple[tuple[float, float, float], ...] = ()
    environment: str | None = None
    environment_intensity: float = 0.3


@dataclass(frozen=True)
class View:
    """A camera angle: yaw (positive: the subject's left) and pitch, degrees."""

    name: str
    yaw: float = 0.0
    pitch: float = 0.0


@dataclass
class Spec:
    """A checked catalogue spec (see the module docstring and ``docs/CATALOGUE.md``).

    Attributes:
        path: the spec file.
        name: the catalogue's name.
        size: (width, height) pixels, 16..8192 each.
        mode: "fast", "reference" or "lightweight" (captured faces only).
        exposure: exposure multiplier (> 0).
        resolution: thickness-map resolution of looks, texels per side.
        naming: the output path pattern (fields :data:`NAMING_FIELDS`; ``{hash}`` required).
        library: the material library (products and look materials are looked up here).
        library_path: its file, or None for Sheer's default library.
        glb: also write one GLB per head × look × product.
        contact_sheets: write a contact sheet per product and view.
        heads, looks, lights, views: the axes of the catalogue.
        category: the product category swapped, or None (looks as they are).
        products: the product material names (library order), empty without a category.
        product_labels: each product's label in file names (:func:`catalogue.labels.unique_labels`).
        swaps: per look index, the layer indices whose material is replaced by each product.
    """

    path: Path
    name: str
    size: tuple[int, int]
    mode: str
    exposure: float
    resolution: int
    naming: str
    library: Library
    library_path: Path | None
    glb: bool
    contact_sheets: bool
    heads: list[HeadSource]
    looks: list[LookSource]
    lights: list[LightRig]
    views: list[View]
    category: str | None = None
    products: list[str] = field(default_factory=list)
    product_labels: dict[str, str] = field(default_factory=dict)
    swaps: dict[int, tuple[int, ...]] = field(default_factory=dict)


_Named = TypeVar("_Named", HeadSource, LookSource, LightRig, View)


@functools.cache
def schema() -> dict[str, Any]:
    """The JSON Schema of a catalogue spec (``resources/catalogue.schema.json``)."""
    from core.assets import resource_path

    return json.loads(resource_path("catalogue.schema.json").read_text(encoding="utf-8"))


def _key(parts: Any) -> str:
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "(top level)"


def key_line(text: str, key: str) -> int | None:
    """The 1-based line of ``text`` (a spec's TOML) where ``key`` (``looks[1].look``, ``size[0]``) is set.

    Follows ``[table]`` and ``[[array-of-tables]]`` headers; falls back to the entry's header line when the
    key itself is not written (a default), None when neither is found.
    """
    parts = [p for p in re.split(r"\.|\[(\d+)\]|\[|\]", key) if p]
    if not parts:
        return None
    head, rest = parts[0], parts[1:]
    index = int(rest.pop(0)) if rest and rest[0].isdigit() else None
    sub = next((r for r in rest if not r.isdigit()), None)
    section, seen, found = "", -1, None
    for no, line in enumerate(text.splitlines(), 1):
        stripped = line.strip()
        header = re.fullmatch(r"\[\[?\s*([A-Za-z0-9_-]+)\s*\]\]?(\s*#.*)?", stripped)
        if header:
            section = header.group(1)
            if section == head:
                seen += 1
                if found is None and (index is None or seen == index):
                    found = no
            continue
        name = re.match(r"([A-Za-z0-9_-]+)\s*=", stripped)
        if name is None:
            continue
        if section == "" and name.group(1) == head:
            return no
        if section == head and (index is None or seen == index) and name.group(1) == sub:
            return no
    return found


def parse_spec(path: str | Path) -> dict[str, Any]:
    """The spec's TOML as a dict, checked against the JSON Schema.

    Raises:
        CatalogueError: unreadable file, a TOML syntax error (with its line and column), or the first
            schema violation (with its key).
    """
    import jsonschema

    from core.files import read_bounded

    p = Path(path)
    blob = read_bounded(p, MAX_SPEC_BYTES, "catalogue spec", CatalogueError)
    try:
        text = blob.decode("utf-8")
        data = tomllib.loads(text)
    except UnicodeDecodeError as exc:
        raise CatalogueError(f"{p}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except tomllib.TOMLDecodeError as exc:
        raise CatalogueError(f"{p}: invalid TOML: {exc}") from None
    error = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(schema()).iter_errors(data))
    if error is not None:
        message = error.message if len(error.message) <= 200 else error.message[:200] + "…"
        if error.validator == "pattern" and list(error.absolute_path) == ["naming"]:
            message = "must contain {hash} (outputs are named by their content hash)"
        key = _key(error.absolute_path)
        line = key_line(text, key)
        raise CatalogueError(f"{p}{'' if line is None else f':{line}'}: {key}: {message}")
    return data


def load_spec(path: str | Path) -> Spec:
    """Read and check a catalogue spec (see the module docstring); nothing is rendered.

    Raises:
        CatalogueError: the first problem found, naming the spec file and the key.
    """
    p = Path(path)
    data = parse_spec(p)
    base = p.absolute().parent
    where = str(p)

    text = p.read_text(encoding="utf-8", errors="replace")

    def fail(key: str, message: str) -> CatalogueError:
        line = key_line(text, key)
        return CatalogueError(f"{where}{'' if line is None else f':{line}'}: {key}: {message}")

    def rel(text: str) -> str:
        q = Path(text).expanduser()
        return str(q if q.is_absolute() else base / q)

    naming = str(data.get("naming", DEFAULT_NAMING))
    for fld in re.findall(r"\{([^{}]*)\}", naming):
        if fld not in NAMING_FIELDS:
            raise fail("naming", f"unknown field {{{fld}}} (known: {', '.join(NAMING_FIELDS)})")
    if naming.startswith("/") or ".." in Path(naming).parts:
        raise fail("naming", "must be a relative path inside the output folder")
    mode = str(data.get("mode", "fast"))

    library, library_path = _library(data, rel, fail)
    heads = _heads(data, rel, fail, mode)
    looks = _looks(data, rel, fail, library)
    if mode == "lightweight":
        for i, src in enumerate(looks):
            if src.project is not None:
                raise fail(f"looks[{i}].project", "mode 'lightweight' renders captured faces only; a project "
                                                  "is rendered on its own head")
    lights = _lights(data, rel, fail)
    views = [View(str(v.get("name") or f"yaw{v.get('yaw', 0):g}_pitch{v.get('pitch', 0):g}"),
                  float(v.get("yaw", 0.0)), float(v.get("pitch", 0.0))) for v in data.get("views", [{}])]
    heads, looks = _labelled("heads", heads, fail), _labelled("looks", looks, fail)
    lights, views = _labelled("lights", lights, fail), _labelled("views", views, fail)
    spec = Spec(path=p, name=str(data.get("name", p.stem)), size=tuple(data.get("size", [1280, 720])),
                mode=mode, exposure=float(data.get("exposure", 0.85)), resolution=int(data.get("resolution", 1024)),
                naming=naming, library=library, library_path=library_path, glb=bool(data.get("glb", False)),
                contact_sheets=bool(data.get("contact_sheets", True)), heads=heads, looks=looks, lights=lights,
                views=views)
    if "products" in data:
        _products(spec, data["products"], fail)
    return spec


def _labelled(axis: str, items: list[_Named], fail: Any) -> list[_Named]:
    """``items`` (one axis: heads, looks, lights or views) with their names turned into unique labels.

    Raises:
        CatalogueError: two entries with one name, or two names that would share a label.
    """
    names = [normal(it.name) for it in items]
    dup = next((n for n in names if names.count(n) > 1), None)
    if dup is not None:
        raise fail(axis, f"two entries are named {dup!r} (give each a distinct 'name')")
    try:
        labels = unique_labels(names)
    except LabelCollision as exc:
        raise fail(axis, f"{exc} in file names (rename one)") from None
    return [dataclasses.replace(it, name=lab) for it, lab in zip(items, labels, strict=True)]


def _library(data: dict[str, Any], rel: Any, fail: Any) -> tuple[Library, Path | None]:
    import km
    from km.library import Library

    if "library" not in data:
        return km.default_library(), None
    lib_path = Path(rel(data["library"]))
    try:
        return Library.load(lib_path), lib_path
    except SheerError as exc:
        raise fail("library", str(exc)) from None


def _heads(data: dict[str, Any], rel: Any, fail: Any, mode: str) -> list[HeadSource]:
    heads = []
    for i, h in enumerate(data.get("heads", [{}])):
        if "path" in h and "face" in h:
            raise fail(f"heads[{i}]", "give 'path' or 'face', not both")
        if "face" in h:
            folder = Path(rel(h["face"]))
            if not (folder / "face.json").is_file():
                raise fail(f"heads[{i}].face", f"{folder}: not a face folder (no face.json; see 'sheer capture')")
            heads.append(HeadSource(str(h.get("name") or folder.name), None, str(folder)))
        elif "path" in h:
            mesh = Path(rel(h["path"]))
            if not mesh.is_file():
                raise fail(f"heads[{i}].path", f"{mesh}: head mesh not found")
            heads.append(HeadSource(str(h.get("name") or mesh.stem), str(mesh)))
        else:
            heads.append(HeadSource(str(h.get("name") or "sample")))
        if mode == "lightweight" and heads[-1].face is None:
            raise fail(f"heads[{i}]", "mode 'lightweight' renders captured faces only: give 'face'")
    return heads


def _looks(data: dict[str, Any], rel: Any, fail: Any, library: Library) -> list[LookSource]:
    from painting.looks import load_look

    looks = []
    for i, entry in enumerate(data.get("looks", [{"look": "bare"}])):
        if "project" in entry:
            proj = Path(rel(entry["project"]))
            if not proj.is_file():
                raise fail(f"looks[{i}].project", f"{proj}: project not found")
            looks.append(LookSource(str(entry.get("name") or proj.stem), project=str(proj)))
            continue
        text = entry["look"]
        ref = rel(text) if text.lower().endswith(".json") else text
        try:
            look = load_look(ref)
        except SheerError as exc:
            raise fail(f"looks[{i}].look", str(exc)) from None
        for j, lay in enumerate(look.layers):
            if lay.material not in library:
                raise fail(f"looks[{i}].look", f"layers[{j}]: unknown material {lay.material!r} "
                                               f"(not in the library {library.name!r})")
        looks.append(LookSource(str(entry.get("name") or look.name), look=ref))
    return looks


def _lights(data: dict[str, Any], rel: Any, fail: Any) -> list[LightRig]:
    from render.errors import RenderError
    from render.lights import find_environment

    rigs = []
    for i, lt in enumerate(data.get("lights", [{"preset": "portrait"}])):
        env = lt.get("environment")
        if env is not None:
            ref = rel(env) if env.lower().endswith(".exr") else env
            try:
                env = str(find_environment(ref))
            except RenderError as exc:
                raise fail(f"lights[{i}].environment", str(exc)) from None
        if "preset" in lt and "directional" in lt:
            raise fail(f"lights[{i}]", "give 'preset' or 'directional', not both")
        directional = tuple(tuple(float(v) for v in d) for d in lt.get("directional", []))
        preset = None if directional else str(lt.get("preset", "portrait"))
        name = lt.get("name") or (preset if preset is not None else f"light{i}")
        rigs.append(LightRig(str(name), preset, directional, env,  # type: ignore[arg-type]
                             float(lt.get("environment_intensity", 0.3))))
    return rigs


def _products(spec: Spec, products: dict[str, Any], fail: Any) -> None:
    """Fill ``spec.category``, ``products`` and ``swaps`` (which layer of each look takes the product)."""
    category = products["category"]
    lib = spec.library
    in_category = [m.name for m in lib.by_category(category)]
    if "materials" in products:
        names = []
        for j, name in enumerate(products["materials"]):
            if name not in lib:
                raise fail(f"products.materials[{j}]", f"unknown material {name!r} (not in the library {lib.name!r})")
            mat = lib.get(name)
            if mat.category != category:
                raise fail(f"products.materials[{j}]", f"{mat.name!r} is a {mat.category}, not a {category}")
            names.append(mat.name)
    else:
        if not in_category:
            known = ", ".join(sorted(lib.categories())) or "none"
            raise fail("products.category", f"no product of category {category!r} in the library {lib.name!r} "
                                            f"(its categories: {known})")
        names = in_category
    spec.category, spec.products = category, names
    try:
        spec.product_labels = dict(zip(names, unique_labels(names), strict=True))
    except LabelCollision as exc:
        raise fail("products", f"{exc} in file names (rename one)") from None
    for i, src in enumerate(spec.looks):
        cats = _layer_categories(src, lib)
        swap = tuple(k for k, c in enumerate(cats) if c == category)
        if not swap:
            raise fail(f"looks[{i}]", f"'{src.name}' has no {category} layer to swap the products into")
        spec.swaps[i] = swap


def _layer_categories(src: LookSource, lib: Library) -> list[str]:
    """The category of each layer's material of a look or project, bottom first."""
    if src.look is not None:
        from painting.looks import load_look

        return [lib.get(lay.material).category for lay in load_look(src.look).layers]
    from project.io import open_project

    project = open_project(src.project)  # type: ignore[arg-type]
    cats = []
    for lay in project.layers:
        mat = project.materials.get(lay.material)
        cats.append(str(mat.get("category", "")) if mat is not None else "")
    return cats
