"""Exports, run in a worker (no Qt): thickness maps, the made-up face as glTF/GLB, rendered images.

Layer thickness maps with a manifest, the head as glTF/GLB with the makeup baked into its albedo under
neutral light, and rendered images on a standalone GL context.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from core.errors import SheerError

if TYPE_CHECKING:
    from app.view.camera import Lighting
    from km.library import Library
    from painting import Document
    from painting.head import Head
    from painting.layout import UVLayout
    from render.camera import OrbitCamera
    from render.km_pass import LayerInput

Progress = Callable[[float, str], None]
IsCancelled = Callable[[], bool]


def _check_cancel(cancelled: IsCancelled) -> None:
    if cancelled():
        from app.workers import Cancelled

        raise Cancelled()


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("_") or "layer"


def export_maps(doc: Document, folder: str | Path, progress: Progress = lambda f, m: None,
                cancelled: IsCancelled = lambda: False, fmt: str = "png") -> Path:
    """Write each layer's thickness map and ``manifest.json`` into ``folder``; returns the manifest's path.

    ``fmt="png"``: 16-bit PNG (value = thickness / scale_um × 65535, the scale also in the PNG's text);
    ``"exr"``: 32-bit float OpenEXR (µm).
    """
    from PIL import Image

    if fmt not in ("png", "exr"):
        raise SheerError(f"map format must be png or exr, got {fmt!r}")
    try:
        from painting.maps_io import write_thickness
    except ImportError:
        write_thickness = None
    if fmt == "exr" and write_thickness is None:
        raise SheerError("EXR export needs painting.maps_io, which this build lacks")

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    entries = []
    n = max(len(doc.layers), 1)
    used: set[str] = set()
    for i, lay in enumerate(doc.layers):
        _check_cancel(cancelled)
        progress(i / n, f"layer {lay.name}")
        base = _safe(f"{i:02d}_{lay.name}")
        while base in used:
            base += "_"
        used.add(base)
        scale = float(max(lay.max_thickness, float(np.max(lay.thickness)) if lay.thickness.size else 0.0, 1e-6))
        name = f"{base}.{fmt}"
        if write_thickness is not None:
            write_thickness(folder / name, np.asarray(lay.thickness, np.float32),
                            scale_um=scale if fmt == "png" else None, credit=getattr(doc.head, "credit", ""))
        else:
            q = np.clip(np.round(lay.thickness / scale * 65535.0), 0, 65535).astype(np.uint16)
            Image.fromarray(q).save(folder / name)
        entries.append({"file": name, "name": lay.name, "material": lay.material,
                        "visible": bool(lay.visible), "opacity": float(lay.opacity),
                        "max_thickness_um": float(lay.max_thickness),
                        "scale_um": scale if fmt == "png" else None,
                        "encoding": "uint16 PNG; thickness_um = value / 65535 * scale_um" if fmt == "png"
                        else "float32 OpenEXR; thickness in µm",
                        "size": list(lay.thickness.shape)})
    manifest = {"schema_version": 1, "head": str(doc.head.path), "credit": doc.head.credit,
                "texture_space": "row 0 = top of image = v 0 (UVs as trimesh loads them)",
                "order": "bottom first", "layers": entries}
    (folder / "manifest.json").write_text(json.dumps(manifest, indent=2), encoding="utf-8")
    progress(1.0, "done")
    return folder / "manifest.json"


def baked_albedo(doc: Document, library: Library) -> np.ndarray:
    """The made-up albedo, uint8 sRGB under neutral light (see :func:`catalogue.glb.baked_albedo`)."""
    from catalogue.glb import baked_albedo as bake

    return bake(doc, library)


def export_gltf(doc: Document, library: Library, path: str | Path, progress: Progress = lambda f, m: None,
                cancelled: IsCancelled = lambda: False) -> Path:
    """The head as glTF (.gltf) or binary glTF (.glb) with the baked made-up albedo (:mod:`catalogue.glb`)."""
    from catalogue.glb import write_gltf

    progress(0.1, "baking the makeup into the albedo")
    _check_cancel(cancelled)
    write_gltf(doc, library, path)
    progress(1.0, "done")
    return Path(path)


def render_image(head: Head, layers: list[LayerInput], camera: OrbitCamera, lighting: Lighting,
                 size: tuple[int, int], path: str | Path, mode: str = "fast", environment: str = "none",
                 layout: UVLayout | None = None, progress: Progress = lambda f, m: None,
                 cancelled: IsCancelled = lambda: False, face: object = None) -> Path:
    """Render the view to a PNG at ``path`` (``size``: width, height in pixels, 16..8192 each).

    ``render.Renderer`` (or, ``mode="lightweight"``, the lightweight engine with the captured ``face``)
    on a standalone (EGL) GL context in the calling thread (a worker), through the same
    :class:`render.view.ViewRenderer` as the viewport. ``layers``: ``render.LayerInput`` of every document
    layer (copies: the document may change meanwhile).
    """
    from PIL import Image

    from render.context import standalone_context
    from render.view import ViewRenderer

    w, h = size
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise SheerError(f"image size {w}×{h} must be between 16 and 8192 pixels on a side")
    path = Path(path)
    progress(0.05, "starting OpenGL")
    ctx = standalone_context(require=330)
    try:
        renderer = ViewRenderer(ctx, head, layout)
        try:
            progress(0.3, "evaluating the layers")
            renderer.set_layers(layers)
            renderer.environment = environment
            renderer.set_face(face)
            _check_cancel(cancelled)
            progress(0.6, "rendering")
            img = renderer.render_image((w, h), camera, lighting.key_light(), mode)
        finally:
            renderer.release()
    finally:
        ctx.release()
    Image.fromarray(img).save(path)
    progress(1.0, "done")
    return path
