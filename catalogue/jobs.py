"""A spec expanded into jobs, each named by the hash of everything that determines its pixels.

A job's ``key`` is the SHA-256 of a canonical JSON of: the renderer's version (:func:`renderer_version`,
a hash of the source of every package that draws the pixels and of the shaders), the head's content
(mesh arrays, textures, metadata — not its path), the look file's or project file's bytes, every material
the image uses (``Material.to_json``), the lights and the environment file's bytes, the view, the size,
the mode, the exposure and the thickness-map resolution. The output file name carries the key's first 16
hex digits (``{hash}``), so a rerun finds what is already rendered and a changed material, head or light
gives new names only to the images it is in.

Jobs are self-contained (the materials travel as JSON, so a remote worker needs no library file; heads,
looks and projects are read from their paths, so a cluster's workers need the same files at the same
paths) and ordered so that a worker keeps its head, look and lights across consecutive jobs
(:func:`chunks`).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from catalogue.errors import CatalogueError
from catalogue.labels import label

if TYPE_CHECKING:
    from catalogue.spec import HeadSource, LightRig, LookSource, Spec, View

#: Hex digits of the key in file names.
NAME_HASH_DIGITS = 16
#: Packages and resource folders whose source determines a catalogue image's pixels.
_VERSION_PACKAGES = ("km", "painting", "project", "render", "catalogue")
_VERSION_RESOURCES = ("shaders", "looks", "heads", "materials")
#: Dry-run estimate (measured by ``sheer bench catalogue`` on a 2-core llvmpipe machine): seconds to start
#: a worker and set up a head, per lighting change, and per megapixel of a fast-mode image.
EST_WORKER_S, EST_LIGHT_S, EST_FAST_S_PER_MPIX = 4.0, 0.35, 0.35
EST_MODE_FACTOR = {"fast": 1.0, "reference": 3.0, "lightweight": 0.5}


@dataclass(frozen=True)
class Job:
    """One output: an image (``kind="image"``) or the made-up head as GLB (``kind="glb"``).

    Attributes:
        kind: "image" or "glb".
        key: the SHA-256 hex digest naming the output (see the module docstring).
        out: the output path relative to the output folder.
        head: the face; head_hash its content hash.
        look: the look or project; look_hash its file's hash.
        product: the product material swapped in, or None.
        swap: the look's layer indices whose material is the product.
        materials: (name, JSON text) of every material the look's layers use, and the product.
        light: the lighting (None for GLB). view: the angle (None for GLB).
        size: (width, height) pixels. mode: "fast" | "reference" | "lightweight". exposure: multiplier.
        resolution: thickness-map texels per side for looks.
        version: :func:`renderer_version` of the driver (a worker refuses a job from another Sheer).
        group: the chunking key (head, look, light): jobs sharing it reuse a worker's caches.
        product_label: the product's label in file names (``look`` without a product).
    """

    kind: str
    key: str
    out: str
    head: HeadSource
    head_hash: str
    look: LookSource
    look_hash: str
    product: str | None
    swap: tuple[int, ...]
    materials: tuple[tuple[str, str], ...]
    light: LightRig | None
    view: View | None
    size: tuple[int, int]
    mode: str
    exposure: float
    resolution: int
    version: str
    group: tuple[str, ...] = field(default=())
    product_label: str = "look"

    def params(self) -> dict[str, Any]:
        """The job's parameters for the manifest (JSON types)."""
        return {"kind": self.kind, "head": self.head.name, "look": self.look.name, "product": self.product or "",
                "light": self.light.name if self.light else "", "view": self.view.name if self.view else "",
                "yaw": self.view.yaw if self.view else None, "pitch": self.view.pitch if self.view else None,
                "width": self.size[0], "height": self.size[1], "mode": self.mode}


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


@functools.cache
def file_hash(path: str) -> str:
    """SHA-256 of a file's bytes (cached per process: catalogue inputs do not change during a run)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def renderer_version() -> str:
    """A hash of the source files and shaders that draw a catalogue image (the "renderer's version").

    Read from disk on every call (≈ 20 ms): a driver computes it per expansion; a worker keeps the one
    of the code it loaded (:func:`catalogue.worker.worker_version`).
    """
    import importlib

    from core.assets import resource_path

    h = hashlib.sha256()
    files: list[Path] = []
    for pkg in _VERSION_PACKAGES:
        folder = Path(importlib.import_module(pkg).__file__ or "").parent
        files += sorted(folder.rglob("*.py"))
    for res in _VERSION_RESOURCES:
        files += sorted(q for q in resource_path(res).rglob("*") if q.is_file())
    for f in files:
        h.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()[:32]


def head_hash(src: HeadSource) -> str:
    """The content hash of a head as the renderer sees it (arrays, textures, metadata; face albedo)."""
    h = _hash_head(load_source_head(src))
    if src.face is not None:
        h.update(file_hash(str(Path(src.face) / "face.json")).encode())
    return h.hexdigest()


def _hash_head(head: Any) -> Any:
    import numpy as np

    h = hashlib.sha256()
    for name in ("vertices", "faces", "uv", "normals", "albedo", "normal_map", "specular_map", "roughness_map",
                 "skin_mask"):
        a = getattr(head, name)
        h.update(name.encode() + (b"-" if a is None else str(a.shape).encode() + np.ascontiguousarray(a).tobytes()))
    h.update(json.dumps(head.metadata.to_json(), sort_keys=True).encode())
    return h


def load_source_head(src: HeadSource) -> Any:
    """The ``painting.head.Head`` of a head source; a captured face's albedo replaces the skin's."""
    import dataclasses

    from painting.head import load_head

    if src.face is None:
        return load_head(src.path)
    from capture.face import face_albedo, load_face

    face = load_face(src.face)
    head_path = face.head_path if src.path is None else src.path  # face.json's head, relative to its folder
    head = load_head(head_path)
    return dataclasses.replace(head, albedo=face_albedo(face))


def look_hash(src: LookSource) -> str:
    """The hash of a look's JSON file or a project file."""
    if src.project is not None:
        return file_hash(src.project)
    from painting.looks import look_path

    path = src.look if str(src.look).lower().endswith(".json") else str(look_path(str(src.look)))
    return file_hash(path)


def _light_key(rig: LightRig) -> dict[str, Any]:
    return {"preset": rig.preset, "directional": [list(d) for d in rig.directional],
            "environment": None if rig.environment is None else file_hash(rig.environment),
            "environment_intensity": rig.environment_intensity}


def _look_materials(src: LookSource, spec: Spec) -> list[Any]:
    """The ``km.Material`` of each layer of a look (from the spec's library) or project (embedded)."""
    if src.look is not None:
        from painting.looks import load_look

        return [spec.library.get(lay.material) for lay in load_look(src.look).layers]
    from project.document import project_library
    from project.io import open_project

    project = open_project(src.project)  # type: ignore[arg-type]
    lib = project_library(project)
    return [lib.get(lay.material) for lay in project.layers]


def _fill(pattern: str, values: dict[str, str]) -> str:
    out = pattern
    for k, v in values.items():
        out = out.replace("{" + k + "}", v)
    return out


def expand(spec: Spec) -> list[Job]:
    """Every job of ``spec``: images (light × head × look × product × view) then GLBs, in chunk order.

    Raises:
        CatalogueError: a head, face or project that cannot be loaded (named), or two jobs with one
            output path (the naming pattern leaves out an axis that varies).
    """
    from core.errors import SheerError

    version = renderer_version()
    heads: list[tuple[HeadSource, str]] = []
    for i, src in enumerate(spec.heads):
        try:
            heads.append((src, head_hash(src)))
        except SheerError as exc:
            raise CatalogueError(f"{spec.path}: heads[{i}]: {exc}") from None
    pairs: list[tuple[HeadSource, str, int, LookSource, str, list[Any]]] = []
    for i, look in enumerate(spec.looks):
        try:
            mats = _look_materials(look, spec)
            lhash = look_hash(look)
            if look.project is not None:
                from catalogue.spec import HeadSource

                # the project's own head (the worker loads it from the project), labelled by the look
                pairs.append((HeadSource(name=look.name), _project_head_hash(look), i, look, lhash, mats))
                continue
        except SheerError as exc:
            raise CatalogueError(f"{spec.path}: looks[{i}]: {exc}") from None
        pairs += [(h, hh, i, look, lhash, mats) for h, hh in heads]
    products: list[str | None] = list(spec.products) or [None]
    jobs: list[Job] = []
    common = {"size": spec.size, "mode": spec.mode, "exposure": spec.exposure, "resolution": spec.resolution,
              "version": version}
    kinds = [("image", rig) for rig in spec.lights] + ([("glb", None)] if spec.glb else [])
    for kind, rig in kinds:
        for head, hhash, li, look, lhash, mats in pairs:
            for product in products:
                swap = spec.swaps.get(li, ()) if product is not None else ()
                used = list(mats)
                for k in swap:
                    used[k] = spec.library.get(product)  # type: ignore[arg-type]
                # the look's own materials too: painting a look builds each layer up to its material's maximum
                mat_json = tuple(sorted({m.name: json.dumps(m.to_json(), sort_keys=True)
                                         for m in [*mats, *used]}.items()))
                for view in (spec.views if kind == "image" else [None]):
                    ident = {"kind": kind, "version": version, "head": hhash, "look": lhash, "swap": list(swap),
                             "materials": [json.loads(t) for _, t in mat_json],
                             "layer_materials": [m.name for m in used],
                             "light": _light_key(rig) if rig else None,
                             "view": [view.yaw, view.pitch] if view else None,
                             **({k: v for k, v in common.items() if k != "version"} if kind == "image"
                                else {"resolution": spec.resolution})}
                    key = _sha(json.dumps(ident, sort_keys=True, separators=(",", ":")).encode())
                    plabel = spec.product_labels.get(product, label(product)) if product else "look"
                    names = {"product": plabel, "head": head.name, "look": look.name,
                             "light": rig.name if rig else "glb", "view": view.name if view else "glb",
                             "hash": key[:NAME_HASH_DIGITS], "mode": spec.mode,
                             "size": f"{spec.size[0]}x{spec.size[1]}"}
                    if kind == "image":
                        out = _fill(spec.naming, names)
                        out = out if out.lower().endswith(".png") else out + ".png"
                    else:
                        out = f"glb/{names['product']}/{head.name}-{look.name}-{names['hash']}.glb"
                    jobs.append(Job(kind, key, out, head, hhash, look, lhash, product, swap, mat_json, rig, view,
                                    **common, group=(kind, hhash, lhash, rig.name if rig else ""),  # type: ignore[arg-type]
                                    product_label=plabel))
    seen: dict[str, Job] = {}
    for job in jobs:
        if job.out in seen and seen[job.out].key != job.key:
            raise CatalogueError(f"{spec.path}: naming: two different images would be written to {job.out!r} "
                                 "(add the axis that differs, e.g. {view} or {light}, to the pattern)")
        seen[job.out] = job
    if spec.contact_sheets:
        _check_sheet_names(spec, jobs)
    return list(seen.values())  # one job per output (two labels for the same pixels stay two files)


def sheet_name(job: Job) -> str:
    """The file name of the contact sheet an image job is on: ``<product label>-<view label>.png``."""
    assert job.view is not None
    return f"{job.product_label}-{job.view.name}.png"


def _check_sheet_names(spec: Spec, jobs: list[Job]) -> None:
    """Refuse two (product, view) pairs whose contact sheets would be one file (``A-b`` + ``c``, ``A`` + ``b-c``).

    Raises:
        CatalogueError: naming the spec, both products and views and the shared sheet.
    """
    owners: dict[str, tuple[str, str]] = {}
    for job in jobs:
        if job.kind != "image" or job.view is None:
            continue
        name, pair = sheet_name(job), (job.product or "look", job.view.name)
        other = owners.setdefault(name.casefold(), pair)
        if other != pair:
            raise CatalogueError(f"{spec.path}: contact_sheets: product {other[0]!r} in view {other[1]!r} and "
                                 f"product {pair[0]!r} in view {pair[1]!r} would share sheets/{name} "
                                 "(rename a view, or set contact_sheets = false)")


def _project_head_hash(look: LookSource) -> str:
    from project.document import project_head
    from project.io import open_project

    return _hash_head(project_head(open_project(str(look.project)))).hexdigest()


def chunks(jobs: list[Job], workers: int) -> list[list[Job]]:
    """Jobs in runs that share a head, look and lighting, cut so every worker has several to take.

    Args:
        jobs: in :func:`expand` order.
        workers: how many workers will share them (≥ 1).

    Returns:
        Consecutive runs of ``jobs``, each at most ``ceil(len(jobs) / (3 × workers))`` long, never
        spanning two groups.
    """
    limit = max(1, math.ceil(len(jobs) / (3 * max(workers, 1))))
    out: list[list[Job]] = []
    for job in jobs:
        if out and out[-1][-1].group == job.group and len(out[-1]) < limit:
            out[-1].append(job)
        else:
            out.append([job])
    return out


def estimate_seconds(jobs: list[Job], workers: int) -> float:
    """A rough wall-clock estimate of rendering ``jobs`` on ``workers`` workers (see the ``EST_*`` constants)."""
    if not jobs:
        return 0.0
    groups = len({j.group for j in jobs})
    per = sum(EST_FAST_S_PER_MPIX * EST_MODE_FACTOR.get(j.mode, 1.0) * j.size[0] * j.size[1] / 1e6 + 0.05
              for j in jobs)
    return EST_WORKER_S + (per + groups * EST_LIGHT_S) / max(workers, 1)
