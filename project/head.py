"""Load a head embedded in a self-contained project, from memory (nothing is extracted to disk).

The mesh is parsed by trimesh from a byte stream (``file_type`` from the extension), the sidecar by
:meth:`painting.head.HeadMetadata.from_json`, textures by Pillow from the embedded bytes, with the
same checks and caps as :func:`painting.head.load_head` (which reads from files; this is its in-memory
twin, since a kiosk may not write anywhere while loading).
"""

from __future__ import annotations

import io
import json
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np

from painting.head import (
    MAX_TEXTURE_SIDE,
    SIDECAR_SUFFIX,
    Head,
    HeadError,
    HeadMetadata,
    mesh_arrays_from_loaded,
)
from project.errors import ProjectError

_MESH_TYPES = {".glb": "glb", ".gltf": "gltf", ".obj": "obj", ".ply": "ply", ".stl": "stl", ".off": "off"}


def _mesh_arrays(blob: bytes, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    import trimesh

    file_type = _MESH_TYPES.get(PurePosixPath(name).suffix.lower())
    if file_type is None:
        raise HeadError(f"embedded head {name!r}: unsupported mesh type")
    try:
        loaded = trimesh.load(io.BytesIO(blob), file_type=file_type, process=False, maintain_order=True)
    except Exception as exc:  # trimesh raises many types for malformed files
        raise HeadError(f"embedded head {name!r}: cannot read mesh: {exc}") from None
    return mesh_arrays_from_loaded(loaded, f"embedded head {name!r}")


def _image(blob: bytes, name: str, mode: str) -> np.ndarray:
    import warnings

    from PIL import Image

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(io.BytesIO(blob)) as im:
                if max(im.size) > MAX_TEXTURE_SIDE:
                    raise HeadError(f"embedded texture {name!r}: {im.size[0]}×{im.size[1]}, over the "
                                    f"{MAX_TEXTURE_SIDE} limit")
                return np.asarray(im.convert(mode))
    except HeadError:
        raise
    except Exception as exc:
        raise HeadError(f"embedded texture {name!r}: cannot decode: {exc}") from None


def load_embedded_head(ref: Any) -> Head:
    """A :class:`painting.head.Head` from an embedded :class:`project.io.HeadRef`.

    ``Head.path`` is a virtual ``<embedded>/<mesh>`` path (no file exists there).
    """
    data: dict[str, bytes] | None = ref.data
    if data is None:
        raise ProjectError(f"head '{ref.name}' is not embedded")
    vertices, faces, uv, normals = _mesh_arrays(data[ref.mesh], ref.mesh)
    sidecar = data.get(ref.mesh + SIDECAR_SUFFIX)
    if sidecar is None:
        extent = float(np.ptp(vertices, axis=0).max()) or 1.0
        meta = HeadMetadata(name=ref.name, mm_per_unit=230.0 / extent, calibrated=False,
                            scale_note="uncalibrated: guessed from the bounding box (230 mm tall head)")
    else:
        try:
            raw = json.loads(sidecar.decode("utf-8"))
        except (UnicodeDecodeError, ValueError) as exc:
            raise HeadError(f"embedded head metadata: {exc}") from None
        meta = HeadMetadata.from_json(raw, f"embedded {ref.mesh}{SIDECAR_SUFFIX}")

    def texture(rel: str | None, mode: str) -> np.ndarray | None:
        if rel is None:
            return None
        key = rel.replace("\\", "/")
        if key not in data:
            raise HeadError(f"embedded head: texture {rel!r} is not embedded")
        return _image(data[key], key, mode)

    mask = texture(meta.skin_mask, "L")
    return Head(path=Path("<embedded>") / ref.mesh, vertices=vertices, faces=faces, uv=uv, normals=normals,
                metadata=meta, albedo=texture(meta.albedo, "RGB"), normal_map=texture(meta.normal_map, "RGB"),
                specular_map=texture(meta.specular_map, "L"), roughness_map=texture(meta.roughness_map, "L"),
                skin_mask=None if mask is None else mask >= 128)
