"""Unpack a project for other tools: layer maps, materials, a manifest, optionally an OpenRaster stack.

The maps are written as EXR float32 (exact µm) and 16-bit PNG; the OpenRaster (``.ora``) stack is what
GIMP and Krita open.

``manifest.json`` lists, per layer (bottom first): name, material, visibility, opacity, maximum
thickness (µm), the EXR file (exact µm values), the PNG file and its ``scale_um`` (µm per count).
OpenRaster layers are 8-bit greyscale-with-alpha PNGs, thickness / the layer's maximum thickness as
the grey level and the coverage as alpha, stacked top first as the OpenRaster spec requires.
"""

from __future__ import annotations

import io
import json
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from core.atomicio import atomic_write_bytes
from painting.maps_io import encode_exr, encode_png16, png16_um_per_count, quantise
from project.container import container_bytes
from project.io import open_project

if TYPE_CHECKING:
    from project.model import Project


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", text).strip("-.")[:60] or "layer"


def export_project(path: str | Path, out_dir: str | Path, *, ora: bool = False) -> dict[str, Any]:
    """Write the maps and ``manifest.json`` of the project at ``path`` into ``out_dir``; returns the manifest."""
    project = open_project(path, verify_head=False)
    out = Path(out_dir)
    (out / "layers").mkdir(parents=True, exist_ok=True)
    layers = []
    for i, layer in enumerate(project.layers):
        stem = f"layers/{i:03d}-{_slug(layer.name)}"
        scale = png16_um_per_count(layer.thickness)
        atomic_write_bytes(out / f"{stem}.exr", encode_exr(layer.thickness))
        atomic_write_bytes(out / f"{stem}.png", encode_png16(quantise(layer.thickness, scale)))
        layers.append({"name": layer.name, "material": layer.material, "visible": layer.visible,
                       "opacity": layer.opacity, "max_thickness_um": layer.max_thickness_um,
                       "resolution": layer.resolution, "exr": f"{stem}.exr", "png": f"{stem}.png", "scale_um": scale,
                       "max_um": float(layer.thickness.max(initial=0.0))})
    manifest: dict[str, Any] = {
        "project": project.name, "source": str(Path(path).absolute()),
        "units": "thickness in micrometres; png value × scale_um = µm",
        "resolution": project.resolution,
        "head": {"name": project.head.name, "files": project.head.files,
                 "path": None if project.head.mesh_path is None else str(project.head.mesh_path)},
        "layers": layers, "lights": project.lights, "camera": project.camera, "look": project.look,
        "materials": "materials.json",
    }
    atomic_write_bytes(out / "materials.json",
                       json.dumps(project.materials, indent=1, ensure_ascii=False).encode("utf-8"))
    if ora:
        atomic_write_bytes(out / "layers.ora", ora_bytes(project))
        manifest["openraster"] = "layers.ora"
    atomic_write_bytes(out / "manifest.json", json.dumps(manifest, indent=2, ensure_ascii=False).encode("utf-8"))
    return manifest


def _png(arr: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(arr).save(buf, format="PNG")
    return buf.getvalue()


def ora_bytes(project: Project) -> bytes:
    """An OpenRaster file of the project's layers (see the module docstring)."""
    from xml.sax.saxutils import quoteattr

    # OpenRaster layers share one canvas: the largest layer resolution; smaller maps are upscaled
    # (nearest texel) so that they cover the same UV square.
    side = max([layer.resolution for layer in project.layers] + [project.resolution])
    h = w = side
    entries: list[tuple[str, bytes, bool]] = [("mimetype", b"image/openraster", False)]
    stack = []
    merged = np.zeros((h, w), dtype=np.float64)
    for i, layer in enumerate(project.layers):
        k = side // layer.resolution
        thickness = np.repeat(np.repeat(layer.thickness, k, axis=0), k, axis=1) if k > 1 else layer.thickness
        level = np.clip(thickness / max(layer.max_thickness_um, 1e-9), 0.0, 1.0)
        merged = np.maximum(merged, level * layer.opacity * layer.visible)
        grey = np.rint(level * 255).astype(np.uint8)
        la = np.stack([grey, np.where(thickness > 0, 255, 0).astype(np.uint8)], axis=-1)
        name = f"data/layer{i:03d}.png"
        entries.append((name, _png(la), False))
        stack.append(f'  <layer name={quoteattr(layer.name)} src="{name}" opacity="{layer.opacity:.4f}" '
                     f'visibility="{"visible" if layer.visible else "hidden"}" x="0" y="0"/>')
    xml = ('<?xml version="1.0" encoding="UTF-8"?>\n'
           f'<image version="0.0.3" w="{w}" h="{h}">\n<stack name={quoteattr(project.name)}>\n'
           + "\n".join(reversed(stack)) + "\n</stack>\n</image>\n")
    entries.append(("stack.xml", xml.encode("utf-8"), True))
    grey = np.rint(merged * 255).astype(np.uint8)
    rgba = np.stack([grey, grey, grey, np.full_like(grey, 255)], axis=-1)
    entries.append(("mergedimage.png", _png(rgba), False))
    from PIL import Image

    thumb = Image.fromarray(rgba)
    thumb.thumbnail((256, 256))
    buf = io.BytesIO()
    thumb.save(buf, format="PNG")
    entries.append(("Thumbnails/thumbnail.png", buf.getvalue(), False))
    return container_bytes(entries)
