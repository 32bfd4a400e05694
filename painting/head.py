"""A head: the mesh, its textures and its metadata (scale in mm per mesh unit, landmarks, skin mask).

Conventions shared by every package (painting, render, capture):

- **Mesh units** are the vertex coordinates exactly as trimesh loads them from the file, with the scene
  graph's transforms applied (identity for the sample head): no recentring, no scaling.
- **Texture space**: an image array is stored top row first, and texel row ``i`` covers
  ``v ∈ [i/H, (i+1)/H)``; column ``j`` covers ``u ∈ [j/W, (j+1)/W)``. The UVs are used exactly as
  loaded. Uploading an array to GL as it is (row 0 first) puts row 0 at texture coordinate ``t = 0``, so
  the shader samples ``texture(tex, uv)`` with no flip. (Measured for the sample head: with this
  convention the albedo's lips land on the mesh's lips.) Thickness maps, baked position maps and masks
  all follow it.
- **Metadata sidecar** (JSON): ``<mesh file>.sheer-head.json`` beside the mesh, or for the sample
  heads (which are read-only and never copied) ``resources/heads/<folder name>.json``. See
  :class:`HeadMetadata` for the fields.

A head loads from files (:func:`load_head`) or from its files' bytes (:func:`load_head_from_bytes`, for
a head embedded in a project): one code path, the same checks and caps, only where the bytes come
from differs.
"""

from __future__ import annotations

import io
import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from core.errors import SheerError
from core.files import read_bounded

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping

#: Refuse meshes larger than this many triangles (a 3D scan for real-time painting is far smaller).
MAX_FACES = 2_000_000
#: Refuse a vertex coordinate larger than this (mesh units), or a UV coordinate larger than ``MAX_UV``: the
#: layout's areas and the rasteriser's pixel indices overflow far beyond them.
MAX_COORDINATE = 1e9
MAX_UV = 1e6
#: Refuse textures larger than this on a side (texels).
MAX_TEXTURE_SIDE = 16384
#: Refuse a head file (mesh, sidecar, texture) larger than this (bytes), before reading it.
MAX_HEAD_FILE_BYTES = 256 * 1024**2
#: The mesh formats a head may be in: file suffix -> trimesh file type.
MESH_TYPES = {".glb": "glb", ".gltf": "gltf", ".obj": "obj", ".ply": "ply", ".stl": "stl", ".off": "off"}
#: The folder :func:`load_head_from_bytes` gives as the head's (no file exists there).
EMBEDDED_FOLDER = Path("<embedded>")
SIDECAR_SUFFIX = ".sheer-head.json"
HEAD_SCHEMA_VERSION = 1
SAMPLE_HEAD = "heads/lee-perry-smith/head.glb"


#: The skin colour (linear sRGB) of a head without an albedo (:meth:`Head.skin_rgb`).
DEFAULT_SKIN_RGB = (0.6, 0.45, 0.38)


class HeadError(SheerError, ValueError):
    """A head file (mesh, texture or metadata) that cannot be used; the message names the file."""


@dataclass
class HeadMetadata:
    """What a mesh file does not say about a head.

    Attributes:
        name: display name.
        mm_per_unit: scale, millimetres per mesh unit (> 0).
        scale_note: how ``mm_per_unit`` was calibrated (e.g. from which facial proportions).
        landmarks: named points in mesh units, e.g. ``left_eye``, ``right_eye``, ``lip_centre``,
            ``left_cheek``, ``right_cheek``, ``nose_tip``, ``chin``, ``forehead``. "Left" is the
            subject's left.
        midplane_point, midplane_normal: the mirror plane of the face (mesh units; unit normal).
        albedo, normal_map, specular_map, roughness_map: texture file paths relative to the mesh's
            folder, else to the sidecar's folder (or absolute), or None (see :func:`resolve_texture_path`).
        skin_mask: a greyscale image in UV space (white = skin), relative path as above, or None (then
            every covered texel counts as skin).
        credit: credit line to show wherever the head is shown or exported.
    """

    name: str
    mm_per_unit: float
    scale_note: str = ""
    landmarks: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    midplane_point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    midplane_normal: tuple[float, float, float] = (1.0, 0.0, 0.0)
    albedo: str | None = None
    normal_map: str | None = None
    specular_map: str | None = None
    roughness_map: str | None = None
    skin_mask: str | None = None
    credit: str = ""
    calibrated: bool = True

    @classmethod
    def from_json(cls, data: Any, source: str) -> HeadMetadata:
        """Validate and build from parsed JSON; ``source`` names the file in error messages."""
        if not isinstance(data, dict):
            raise HeadError(f"{source}: head metadata must be a JSON object")
        version = data.get("schema_version")
        if version != HEAD_SCHEMA_VERSION:
            raise HeadError(
                f"{source}: schema_version {version!r} is not supported (this Sheer reads {HEAD_SCHEMA_VERSION})"
            )
        known = {f for f in cls.__dataclass_fields__}
        unknown = set(data) - known - {"schema_version"}
        if unknown:
            raise HeadError(f"{source}: unknown field(s) {sorted(unknown)}")
        if not isinstance(data.get("name", ""), str):
            raise HeadError(f"{source}: field 'name' must be a string")
        if isinstance(data.get("mm_per_unit"), bool):
            raise HeadError(f"{source}: field 'mm_per_unit' must be a number")
        try:
            mm = float(data["mm_per_unit"])
            name = str(data["name"])
        except KeyError as exc:
            raise HeadError(f"{source}: missing field {exc.args[0]!r}") from None
        except (TypeError, ValueError):
            raise HeadError(f"{source}: field 'mm_per_unit' must be a number") from None
        if not np.isfinite(mm) or mm <= 0:
            raise HeadError(f"{source}: field 'mm_per_unit' must be a positive finite number, got {mm}")

        def vec3(key: str, value: Any) -> tuple[float, float, float]:
            arr = np.asarray(value, dtype=float) if isinstance(value, list) else None
            if arr is None or arr.shape != (3,) or not np.all(np.isfinite(arr)):
                raise HeadError(f"{source}: field '{key}' must be a list of 3 finite numbers")
            return (float(arr[0]), float(arr[1]), float(arr[2]))

        landmarks_raw = data.get("landmarks", {})
        if not isinstance(landmarks_raw, dict):
            raise HeadError(f"{source}: field 'landmarks' must be an object of name -> [x, y, z]")
        landmarks = {str(k): vec3(f"landmarks.{k}", v) for k, v in landmarks_raw.items()}
        normal = vec3("midplane_normal", data.get("midplane_normal", [1.0, 0.0, 0.0]))
        n = float(np.linalg.norm(normal))
        if n == 0:
            raise HeadError(f"{source}: field 'midplane_normal' must not be zero")
        strings = {}
        for key in ("albedo", "normal_map", "specular_map", "roughness_map", "skin_mask"):
            value = data.get(key)
            if value is not None and not isinstance(value, str):
                raise HeadError(f"{source}: field '{key}' must be a file path or null")
            strings[key] = value
        return cls(
            name=name,
            mm_per_unit=mm,
            scale_note=str(data.get("scale_note", "")),
            landmarks=landmarks,
            midplane_point=vec3("midplane_point", data.get("midplane_point", [0.0, 0.0, 0.0])),
            midplane_normal=(normal[0] / n, normal[1] / n, normal[2] / n),
            credit=str(data.get("credit", "")),
            calibrated=bool(data.get("calibrated", True)),
            **strings,
        )

    def to_json(self) -> dict[str, Any]:
        """The JSON form (with ``schema_version``)."""
        out: dict[str, Any] = {"schema_version": HEAD_SCHEMA_VERSION}
        for key in self.__dataclass_fields__:
            value = getattr(self, key)
            if isinstance(value, tuple):
                value = list(value)
            elif isinstance(value, dict):
                value = {k: list(v) for k, v in value.items()}
            out[key] = value
        return out


@dataclass
class Head:
    """A loaded head.

    Attributes:
        path: the mesh file.
        vertices: float64 (N, 3), mesh units. faces: int64 (F, 3). uv: float64 (N, 2) in [0, 1].
        normals: float64 (N, 3) unit vertex normals.
        albedo: uint8 (H, W, 3) sRGB, top row first (see the module docstring), or None.
        normal_map: uint8 (H, W, 3) tangent-space normal map, or None.
        specular_map, roughness_map: uint8 (H, W) or None.
        skin_mask: bool (H, W) in UV space, or None (every covered texel is skin).
        metadata: the sidecar's contents.
    """

    path: Path
    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray
    normals: np.ndarray
    metadata: HeadMetadata
    albedo: np.ndarray | None = None
    normal_map: np.ndarray | None = None
    specular_map: np.ndarray | None = None
    roughness_map: np.ndarray | None = None
    skin_mask: np.ndarray | None = None

    @property
    def mm_per_unit(self) -> float:
        """Millimetres per mesh unit."""
        return self.metadata.mm_per_unit

    @property
    def name(self) -> str:
        """Display name (from the metadata)."""
        return self.metadata.name

    @property
    def credit(self) -> str:
        """Credit line to show wherever the head is shown or exported (from the metadata)."""
        return self.metadata.credit

    def landmark(self, name: str) -> np.ndarray:
        """A landmark point (mesh units); :class:`HeadError` naming the known ones if absent."""
        try:
            return np.asarray(self.metadata.landmarks[name], dtype=float)
        except KeyError:
            known = ", ".join(sorted(self.metadata.landmarks)) or "none"
            raise HeadError(f"head '{self.name}' has no landmark '{name}' (it has: {known})") from None

    def skin_rgb(self) -> np.ndarray:
        """The head's skin colour, linear sRGB float64 (3,): the median of the albedo's middle third.

        The middle third of the texture in both directions (a face's cheeks, nose and mouth in its unwrap);
        :data:`DEFAULT_SKIN_RGB` when the head has no albedo. The studio (Shade Finder, the library's "over
        skin" swatch) and the kiosk (*Find my foundation*) read the head's skin so.
        """
        from km.srgb import srgb_decode

        if self.albedo is None:
            return np.array(DEFAULT_SKIN_RGB, dtype=np.float64)
        h, w = self.albedo.shape[:2]
        third = self.albedo[h // 3:2 * h // 3, w // 3:2 * w // 3, :3].reshape(-1, 3)
        return np.asarray(np.median(srgb_decode(third.astype(np.float64) / 255.0), axis=0), dtype=np.float64)

    def trimesh(self) -> Any:
        """A ``trimesh.Trimesh`` of this head (not processed: vertices and faces exactly as here)."""
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, vertex_normals=self.normals, process=False)


def sidecar_candidates(mesh_path: Path) -> list[Path]:
    """Where the metadata of the head at ``mesh_path`` is looked for, in order."""
    from core.assets import resource_path

    return [
        mesh_path.with_name(mesh_path.name + SIDECAR_SUFFIX),
        resource_path("heads", f"{mesh_path.parent.name}.json"),
    ]


def find_sidecar(mesh_path: Path) -> Path | None:
    """The sidecar file used for ``mesh_path`` (the first of :func:`sidecar_candidates` that exists)."""
    for candidate in sidecar_candidates(mesh_path):
        if candidate.is_file():
            return candidate
    return None


def resolve_texture_path(rel: str, mesh_path: Path, sidecar: Path | None = None) -> Path:
    """Where a texture path of the sidecar points.

    Absolute paths are kept as they are; a relative path is looked up beside the mesh first, then
    beside the sidecar file (so a read-only sample head can take a mask shipped in
    ``resources/heads/``). Returns the mesh-relative path when neither exists (the reader then names
    it in its error).
    """
    p = Path(rel)
    if p.is_absolute():
        return p
    beside_mesh = mesh_path.parent / p
    if not beside_mesh.exists() and sidecar is not None and (sidecar.parent / p).exists():
        return sidecar.parent / p
    return beside_mesh


def parse_metadata(blob: bytes, where: str) -> HeadMetadata:
    """The :class:`HeadMetadata` of a sidecar's bytes (UTF-8 JSON); ``where`` names it in messages."""
    try:
        data = json.loads(blob.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise HeadError(f"{where}: cannot read head metadata: {exc}") from None
    return HeadMetadata.from_json(data, where)


def default_metadata(name: str, mesh_vertices: np.ndarray | None = None) -> HeadMetadata:
    """The metadata of a head without a sidecar, named ``name``.

    Uncalibrated: the scale is guessed from the bounding box (the largest extent of ``mesh_vertices``,
    mesh units, taken as a head 230 mm tall; 1 unit when no vertices are given); no landmarks.
    """
    height = 1.0
    if mesh_vertices is not None and len(mesh_vertices):
        height = float(np.ptp(mesh_vertices, axis=0).max()) or 1.0
    return HeadMetadata(
        name=name,
        mm_per_unit=230.0 / height,
        scale_note="uncalibrated: guessed from the bounding box, assuming a head 230 mm tall",
        calibrated=False,
    )


def load_metadata(mesh_path: Path, mesh_vertices: np.ndarray | None = None) -> HeadMetadata:
    """The metadata of the head at ``mesh_path``.

    Read from its sidecar (the first of :func:`sidecar_candidates` that exists); without one,
    :func:`default_metadata` named after the mesh file, scaled from ``mesh_vertices`` (mesh units).
    """
    sidecar = find_sidecar(mesh_path)
    if sidecar is None:
        return default_metadata(mesh_path.stem, mesh_vertices)
    return parse_metadata(read_bounded(sidecar, MAX_HEAD_FILE_BYTES, "head metadata", HeadError), str(sidecar))


def decode_texture(blob: bytes, where: str, mode: str) -> np.ndarray:
    """Decode a texture image's bytes to a uint8 array in Pillow ``mode`` ("RGB": (H, W, 3), "L": (H, W)).

    Refused before decoding: a side over :data:`MAX_TEXTURE_SIDE` texels, or more pixels than Pillow's
    decompression-bomb threshold (``Image.MAX_IMAGE_PIXELS``).
    """
    from PIL import Image

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(io.BytesIO(blob)) as im:
                if max(im.size) > MAX_TEXTURE_SIDE:
                    raise HeadError(f"{where}: texture is {im.size[0]}×{im.size[1]}, over the "
                                    f"{MAX_TEXTURE_SIDE} limit")
                return np.asarray(im.convert(mode))
    except HeadError:
        raise
    except (Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
        raise HeadError(f"{where}: image too large to decode safely: {exc}") from None
    except Exception as exc:  # Pillow raises UnidentifiedImageError, OSError, SyntaxError... for bad files
        raise HeadError(f"{where}: cannot decode texture: {exc}") from None


def _read_image(path: Path, mode: str) -> np.ndarray:
    """A texture file decoded by :func:`decode_texture`."""
    return decode_texture(read_bounded(path, MAX_HEAD_FILE_BYTES, "texture file", HeadError), str(path), mode)


def _check_topology(vertices: np.ndarray, faces: np.ndarray, where: str) -> None:
    """Refuse vertices that are not (N, 3) and faces that are not triangles of vertex indices in range."""
    if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) == 0:
        raise HeadError(f"{where}: the mesh's vertices have shape {vertices.shape}, (N, 3) expected")
    if faces.shape[1] != 3:
        raise HeadError(f"{where}: the mesh's faces have {faces.shape[1]} corners, triangles expected")
    bad = faces[(faces < 0) | (faces >= len(vertices))]
    if len(bad):
        raise HeadError(f"{where}: a face refers to vertex {int(bad[0])}, outside the mesh's "
                        f"{len(vertices):,} vertices")


def _mesh_arrays_from_loaded(loaded: Any, where: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Validate what ``trimesh.load`` returned and give (vertices, faces, uv, vertex normals).

    ``where`` names the source in error messages. Scenes are flattened with their transforms.
    """
    import trimesh

    if isinstance(loaded, trimesh.Scene):
        meshes = [g for g in loaded.dump() if isinstance(g, trimesh.Trimesh)] if loaded.geometry else []
        if not meshes:
            raise HeadError(f"{where}: the file contains no triangle mesh")
        if len(meshes) > 1:
            uv_ok = all(getattr(m.visual, "uv", None) is not None for m in meshes)
            if not uv_ok:
                raise HeadError(f"{where}: a mesh in the file has no UV coordinates")
            mesh = cast("trimesh.Trimesh", trimesh.util.concatenate(meshes))
        else:
            mesh = meshes[0]
    elif isinstance(loaded, trimesh.Trimesh):
        mesh = loaded
    else:
        raise HeadError(f"{where}: the file contains no triangle mesh")
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if faces.ndim != 2 or len(faces) == 0:
        raise HeadError(f"{where}: the mesh has no triangles")
    if len(faces) > MAX_FACES:
        raise HeadError(f"{where}: the mesh has {len(faces):,} triangles, over the {MAX_FACES:,} limit")
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    _check_topology(vertices, faces, where)
    uv = getattr(mesh.visual, "uv", None)
    if uv is None or len(uv) != len(mesh.vertices):
        raise HeadError(f"{where}: the mesh has no UV coordinates (Sheer paints in UV space)")
    uv = np.asarray(uv, dtype=np.float64)
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise HeadError(f"{where}: the mesh's UV coordinates have shape {uv.shape}, (N, 2) expected")
    if not (np.all(np.isfinite(vertices)) and np.all(np.isfinite(uv))):
        raise HeadError(f"{where}: the mesh has NaN or infinite vertex positions or UVs")
    for values, what, limit in ((vertices, "vertex coordinate", MAX_COORDINATE), (uv, "UV coordinate", MAX_UV)):
        largest = float(np.abs(values).max())
        if largest > limit:
            raise HeadError(f"{where}: a {what} is {largest:.3g}, over the limit of {limit:g}")
    normals = np.asarray(mesh.vertex_normals, dtype=np.float64)
    return vertices, faces, uv, normals


def _check_obj_indices(blob: bytes, where: str) -> None:
    """Refuse an OBJ face index with more digits than the file has lines, before trimesh parses it.

    trimesh allocates an array as long as the largest index (a forged ``f 4294967295 …`` asks for
    32 GiB); any index longer than the line count is out of range, so the check never refuses a good file.
    """
    import re

    lines = blob.count(b"\n") + 1
    first_face = max(blob.find(b"\nf"), 0)  # faces usually follow the vertices: scan from the first
    for found in re.finditer(rb"(?<![\d.])[1-9]\d{%d,}" % len(str(lines)), blob[first_face:]):
        line = blob[blob.rfind(b"\n", 0, first_face + found.start()) + 1:first_face + found.start()].lstrip()
        if line[:2] in (b"f ", b"f\t"):
            raise HeadError(f"{where}: a face refers to vertex {found.group(0)[:20].decode()}, beyond the "
                            f"file's {lines:,} lines")


def parse_mesh(blob: bytes, name: str, where: str, folder: Path | None = None,
               cache: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(vertices, faces, uv, vertex normals) of a mesh file's bytes, parsed by trimesh.

    Args:
        blob: the mesh file's bytes.
        name: its file name; the suffix picks the format (:data:`MESH_TYPES`).
        where: names the mesh in messages.
        folder: where files the mesh refers to are looked up (a glTF's buffers, an OBJ's materials),
            or None (an embedded head: nothing is read from disk).
        cache: look up and store the validated arrays in the mesh cache, keyed by the bytes' SHA-256.

    Raises:
        HeadError: an unsupported format, an unreadable file, no triangles, no UVs, NaN or infinite
            positions or UVs, or more than :data:`MAX_FACES` triangles.
    """
    suffix = PurePosixPath(name).suffix.lower()
    file_type = MESH_TYPES.get(suffix)
    if file_type is None:
        raise HeadError(f"{where}: unsupported mesh type {suffix!r} (use {', '.join(MESH_TYPES)})")
    cached_at = _mesh_cache_path(blob) if cache else None
    if cached_at is not None:
        cached = _load_mesh_cache(cached_at)
        if cached is not None:
            return cached
    import trimesh  # ~1.8 s to import on a slow machine: only when the mesh is not in the cache

    if file_type == "obj":
        _check_obj_indices(blob, where)
    resolver = trimesh.resolvers.FilePathResolver(str(folder)) if folder is not None else None
    try:
        loaded = trimesh.load(io.BytesIO(blob), file_type=file_type, resolver=resolver, process=False,
                              maintain_order=True)
        arrays = _mesh_arrays_from_loaded(loaded, where)
    except HeadError:
        raise
    except Exception as exc:  # trimesh raises many types for malformed files, some lazily (a GLB's
        raise HeadError(f"{where}: cannot read mesh: {exc}") from None  # image decoded when copied)
    if cached_at is not None:
        _save_mesh_cache(cached_at, arrays)
    return arrays


def load_mesh_arrays(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Load (vertices, faces, uv, vertex normals) from a mesh file (see :func:`parse_mesh`), cached.

    Scenes are flattened with their transforms; polygons are triangulated.
    """
    if not path.is_file():
        raise HeadError(f"{path}: head mesh not found")
    blob = read_bounded(path, MAX_HEAD_FILE_BYTES, "head mesh", HeadError)
    return parse_mesh(blob, path.name, str(path), folder=path.parent, cache=True)


#: Bump when what :func:`parse_mesh` returns for the same bytes changes.
_MESH_CACHE_VERSION = 1
_MESH_FIELDS = ("vertices", "faces", "uv", "normals")


def _mesh_cache_path(blob: bytes) -> Path:
    """Where the validated arrays of the mesh file holding ``blob`` are cached.

    In the cache's ``mesh`` folder (:func:`core.cache.cache_dir`), keyed by the SHA-256 of the bytes
    (so an edited file is loaded again).
    """
    import hashlib

    from core.cache import cache_dir

    digest = hashlib.sha256(blob).hexdigest()[:32]
    return cache_dir("mesh") / f"{digest}-v{_MESH_CACHE_VERSION}.cache"


def _load_mesh_cache(cache: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """The cached (vertices, faces, uv, normals), or None when absent or not well-formed."""
    from core.cache import load_arrays

    data = load_arrays(cache, _MESH_CACHE_VERSION)  # None when absent or damaged (then deleted)
    if data is None or any(k not in data for k in _MESH_FIELDS):
        return None
    v, f, uv, n = (data[k] for k in _MESH_FIELDS)
    ok = (v.dtype == np.float64 and v.ndim == 2 and v.shape[1:] == (3,) and f.dtype == np.int64
          and f.ndim == 2 and f.shape[1:] == (3,) and 0 < len(f) <= MAX_FACES and uv.dtype == np.float64
          and uv.shape == (len(v), 2) and n.dtype == np.float64 and n.shape == v.shape)
    return (v, f, uv, n) if ok else None


def _save_mesh_cache(cache: Path, arrays: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]) -> None:
    """Store (vertices, faces, uv, normals) at ``cache`` (:func:`core.cache.save_arrays`; failures ignored)."""
    from core.cache import save_arrays

    save_arrays(cache, dict(zip(_MESH_FIELDS, arrays)), _MESH_CACHE_VERSION)


def _assemble(path: Path, arrays: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], meta: HeadMetadata,
              texture: Callable[[str, str], np.ndarray]) -> Head:
    """A :class:`Head` from its mesh arrays and metadata, wherever its files are.

    ``texture(rel, mode)`` gives the texture the metadata names ``rel``, decoded to Pillow ``mode``.
    """

    def optional(rel: str | None, mode: str) -> np.ndarray | None:
        return None if rel is None else texture(rel, mode)

    vertices, faces, uv, normals = arrays
    mask = optional(meta.skin_mask, "L")
    return Head(
        path=path,
        vertices=vertices,
        faces=faces,
        uv=uv,
        normals=normals,
        metadata=meta,
        albedo=optional(meta.albedo, "RGB"),
        normal_map=optional(meta.normal_map, "RGB"),
        specular_map=optional(meta.specular_map, "L"),
        roughness_map=optional(meta.roughness_map, "L"),
        skin_mask=None if mask is None else mask >= 128,
    )


def load_head(path: str | Path | None = None) -> Head:
    """Load a head from files: mesh (see :data:`MESH_TYPES`), sidecar metadata and textures.

    ``path=None`` loads the sample head from the assets (:data:`SAMPLE_HEAD`). Textures are found with
    :func:`resolve_texture_path`.
    """
    if path is None:
        from core.assets import find_asset

        path = find_asset(SAMPLE_HEAD)
    mesh_path = Path(path)
    arrays = load_mesh_arrays(mesh_path)
    meta = load_metadata(mesh_path, arrays[0])
    sidecar = find_sidecar(mesh_path)
    return _assemble(mesh_path, arrays, meta,
                     lambda rel, mode: _read_image(resolve_texture_path(rel, mesh_path, sidecar), mode))


def load_head_from_bytes(files: Mapping[str, bytes], mesh: str) -> Head:
    """Load a head from its files' bytes (e.g. embedded in a project); nothing touches the disk.

    The checks and caps are those of :func:`load_head` (the same functions parse the mesh, the
    sidecar and the textures).

    Args:
        files: each file's bytes keyed by its path relative to the mesh's folder, POSIX separators:
            the mesh, its sidecar as ``<mesh>`` + :data:`SIDECAR_SUFFIX` (optional) and the textures
            the sidecar names.
        mesh: the key of the mesh.

    Returns:
        The head; its ``path`` is ``<embedded>/<mesh>`` (:data:`EMBEDDED_FOLDER`; no file exists there).
    """
    where = f"embedded head {mesh!r}"
    blob = files.get(mesh)
    if blob is None:
        raise HeadError(f"{where}: the mesh is not among the head's files")
    if len(blob) > MAX_HEAD_FILE_BYTES:
        raise HeadError(f"{where}: {len(blob):,} bytes, over the limit of {MAX_HEAD_FILE_BYTES:,}")
    arrays = parse_mesh(blob, mesh, where)
    sidecar = files.get(mesh + SIDECAR_SUFFIX)
    meta = (default_metadata(PurePosixPath(mesh).stem, arrays[0]) if sidecar is None
            else parse_metadata(sidecar, f"embedded {mesh}{SIDECAR_SUFFIX}"))

    def texture(rel: str, mode: str) -> np.ndarray:
        key = rel.replace("\\", "/")
        if key not in files:
            raise HeadError(f"{where}: texture {rel!r} is not embedded")
        return decode_texture(files[key], f"embedded texture {key!r}", mode)

    return _assemble(EMBEDDED_FOLDER / mesh, arrays, meta, texture)
