"""Unpack a project for other tools: layer maps, materials, a manifest, optionally an OpenRaster stack.

The maps are written as EXR float32 (exact µm) and 16-bit PNG; the OpenRaster (``.ora``) stack is what
GIMP and Krita open (:func:`document_ora_bytes`).

``manifest.json`` lists, per layer (bottom first): name, material, visibility, opacity, maximum
thickness (µm), the EXR file (exact µm values), the PNG file and its ``scale_um`` (µm per count).
In the OpenRaster stack each cosmetic is a layer of its colour with its coverage as alpha (a painting
program composites them as the studio shows the makeup, :func:`film_rgba`), and each thickness map is a
grey data layer in a hidden group; stacked top first as the OpenRaster specification requires.
"""

from __future__ import annotations

import io
import json
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from core.atomicio import atomic_write_bytes, check_can_create
from painting.maps_io import encode_exr, encode_png16, png16_um_per_count, quantise
from project.container import container_bytes
from project.io import open_project

if TYPE_CHECKING:
    from project.model import Project


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", text).strip("-.")[:60] or "layer"


def export_project(path: str | Path, out_dir: str | Path, *, ora: bool = False) -> dict[str, Any]:
    """Write the maps and ``manifest.json`` of the project at ``path`` into ``out_dir``; returns the manifest.

    An ``out_dir`` that cannot be created (a read-only folder, a file in the way) is refused before the
    project is read, with a :class:`core.errors.SheerError` naming it.
    """
    out = Path(out_dir)
    check_can_create(out / "layers")
    project = open_project(path, verify_head=False)
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


#: One layer as :func:`document_ora_bytes` draws it: name, material (a ``km.Material``, or None when
#: unknown: grey), thickness map (µm, the mask applied), maximum thickness (µm), opacity, visible.
OraLayer = tuple[str, Any, np.ndarray, float, float, bool]
#: Thickness levels of a layer's colour table (:func:`film_rgba`): the map is quantised to this many steps.
_LEVELS = 256


def ora_bytes(project: Project) -> bytes:
    """An OpenRaster file of the project's layers (:func:`document_ora_bytes`).

    The maps are the project's, with each layer's mask applied when the head is at hand to make its
    regions (:func:`project.document.document_from_project`); without the head they are drawn unmasked.
    """
    from core.errors import SheerError

    maps = [layer.thickness for layer in project.layers]
    if any(layer.mask is not None or layer.mask_channel is not None for layer in project.layers):
        try:
            from project.document import document_from_project

            doc = document_from_project(project)
            maps = [np.asarray(lay.effective_thickness(), np.float32) for lay in doc.layers]
        except (SheerError, OSError):
            pass  # (the head is missing or changed: the maps as painted)
    layers: list[OraLayer] = []
    for layer, thickness in zip(project.layers, maps):
        try:
            material = project.material(layer.material)
        except SheerError:
            material = None
        layers.append((layer.name, material, thickness, float(layer.max_thickness_um), float(layer.opacity),
                       bool(layer.visible)))
    return document_ora_bytes(project.name, layers)


def film_rgba(material: Any, thickness_um: np.ndarray) -> np.ndarray:
    """The colour and alpha (float RGBA in [0, 1], sRGB-encoded) of ``material``'s film at each thickness.

    The colour is the cosmetic's own (its opaque colour, R∞); the alpha is its coverage at the texel's
    thickness: the value for which a painting program's src-over of that colour, in sRGB, comes closest
    (least squares) to Kubelka–Munk's film over black, mid grey and white backgrounds. No film is
    transparent; an opaque one is alpha 1; alpha grows with thickness. The map is quantised to
    :data:`_LEVELS` thicknesses between 0 and its peak.
    """
    from km.srgb import srgb_encode

    t = np.nan_to_num(np.asarray(thickness_um, np.float64), nan=0.0, posinf=0.0, neginf=0.0).clip(0.0)
    peak = float(t.max(initial=0.0))
    if material is None or peak <= 0.0:  # no film: transparent; an unknown material: grey where painted
        out = np.full((*t.shape, 4), 0.5, np.float32)
        out[..., 3] = (t > 0) & (material is None)
        return out

    def encoded(linear: np.ndarray) -> np.ndarray:
        return np.asarray(srgb_encode(np.clip(np.asarray(linear, np.float64), 0.0, 1.0)), np.float64)

    colour = encoded(material.swatch_rgb("opaque", encoded=False))
    backgrounds = [(encoded(material.swatch_rgb(b, 0.0, encoded=False)), b) for b in (0.0, 0.5, 1.0)]
    levels = np.linspace(0.0, peak, _LEVELS)
    alpha = np.zeros(_LEVELS)
    for k, th in enumerate(levels[1:], start=1):
        num = den = 0.0
        for bg, b in backgrounds:
            film = encoded(material.swatch_rgb(b, float(th), encoded=False))
            num += float((colour - bg) @ (film - bg))
            den += float((colour - bg) @ (colour - bg))
        alpha[k] = np.clip(num / den, 0.0, 1.0) if den > 0 else 1.0
    alpha = np.maximum.accumulate(alpha)  # (more of the film never shows less of it)
    table = np.zeros((_LEVELS, 4), np.float32)
    table[:, :3] = colour
    table[:, 3] = alpha
    index = np.rint(t / peak * (_LEVELS - 1)).astype(np.intp)
    return table[index]


def _over(dst: np.ndarray, src: np.ndarray) -> np.ndarray:
    """``src`` over ``dst`` (straight-alpha float RGBA, sRGB values as a painting program blends them)."""
    sa, da = src[..., 3:4], dst[..., 3:4]
    a = sa + da * (1.0 - sa)
    rgb = (src[..., :3] * sa + dst[..., :3] * da * (1.0 - sa)) / np.where(a > 0, a, 1.0)
    return np.concatenate([rgb, a], axis=-1)


def _rgba8(rgba: np.ndarray) -> np.ndarray:
    return np.rint(np.clip(rgba, 0.0, 1.0) * 255.0).astype(np.uint8)


def _upscaled(thickness: np.ndarray, side: int) -> np.ndarray:
    """A layer's map on the canvas (``side``²): smaller maps are upscaled (nearest texel) over the same UV square."""
    k = side // thickness.shape[0]
    return np.repeat(np.repeat(thickness, k, axis=0), k, axis=1) if k > 1 else thickness


def document_ora_bytes(name: str, layers: list[OraLayer]) -> bytes:
    """An OpenRaster file (specification 0.0.5, baseline) of ``layers`` (bottom first; see :data:`OraLayer`).

    A painting program shows the makeup: each cosmetic is a layer of its own colour whose alpha is its
    coverage at each texel's thickness (:func:`film_rgba`), with the layer's opacity and visibility, over
    a transparent canvas (the paint layout's UV square, row 0 = v 0). Under them, a hidden group
    "thickness maps (data)" holds each layer's thickness as an opaque grey layer, white at the layer's
    peak, which the layer's name states in µm. ``mergedimage.png`` is the visible layers composited as
    a reader composites them (src-over), and ``Thumbnails/thumbnail.png`` the same at most 256².
    """
    from xml.sax.saxutils import quoteattr

    from PIL import Image

    side = max([int(t.shape[0]) for _n, _m, t, *_ in layers] + [64])
    entries: list[tuple[str, bytes, bool]] = [("mimetype", b"image/openraster", False)]
    colour_xml, data_xml = [], []
    merged = np.zeros((side, side, 4), np.float32)
    for i, (layer_name, material, thickness, _max_um, opacity, visible) in enumerate(layers):
        t = _upscaled(np.asarray(thickness, np.float64), side)
        film8 = _rgba8(film_rgba(material, t))
        film = film8.astype(np.float32) / 255.0  # (the merged image composites the layers a reader reads)
        src = f"data/layer{i:03d}.png"
        entries.append((src, _png(film8), False))
        label = layer_name if material is None or material.name == layer_name else f"{layer_name} ({material.name})"
        colour_xml.append(f'  <layer name={quoteattr(label)} src="{src}" x="0" y="0" opacity="{opacity:.4f}" '
                          f'visibility="{"visible" if visible else "hidden"}" composite-op="svg:src-over"/>')
        if visible and opacity > 0:
            merged = _over(merged, film * np.array([1.0, 1.0, 1.0, opacity], np.float32))
        peak = float(np.nan_to_num(t).max(initial=0.0))
        grey = np.rint(np.clip(t / peak, 0.0, 1.0) * 255.0).astype(np.uint8) if peak > 0 else np.zeros(t.shape, np.uint8)
        data_src = f"data/thickness{i:03d}.png"
        entries.append((data_src, _png(np.stack([grey, grey, grey, np.full_like(grey, 255)], axis=-1)), False))
        data_xml.append(f'    <layer name={quoteattr(f"{layer_name} thickness: white = {peak:.1f} µm")} '
                        f'src="{data_src}" x="0" y="0" opacity="1.0000" visibility="hidden" '
                        f'composite-op="svg:src-over"/>')
    xml = ('<?xml version="1.0" encoding="UTF-8"?>\n'
           f'<image version="0.0.5" w="{side}" h="{side}">\n<stack name={quoteattr(name)}>\n'
           + "\n".join(reversed(colour_xml)) + ("\n" if colour_xml else "")
           + '  <stack name="thickness maps (data)" visibility="hidden" opacity="1.0000" isolation="isolate">\n'
           + "\n".join(reversed(data_xml)) + ("\n" if data_xml else "")
           + "  </stack>\n</stack>\n</image>\n")
    entries.append(("stack.xml", xml.encode("utf-8"), True))
    rgba = _rgba8(merged)
    entries.append(("mergedimage.png", _png(rgba), False))
    thumb = Image.fromarray(rgba)
    thumb.thumbnail((256, 256))
    buf = io.BytesIO()
    thumb.save(buf, format="PNG")
    entries.append(("Thumbnails/thumbnail.png", buf.getvalue(), False))
    return container_bytes(entries)
