"""Exports (no Qt; run in a worker): layer thickness maps + manifest, the made-up face as glTF/GLB with
the makeup baked into its albedo under neutral light, and rendered images on a standalone GL context."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from km.errors import SheerError

Progress = Callable[[float, str], None]
IsCancelled = Callable[[], bool]


def _check_cancel(cancelled: IsCancelled) -> None:
    if cancelled():
        from app.workers import Cancelled

        raise Cancelled()


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("_") or "layer"


def layer_tuples(doc: Any, library: Any) -> list[tuple[np.ndarray, Any, float]]:
    """(thickness µm, material, opacity) of the visible layers, bottom first."""
    out = []
    for lay in doc.layers:
        if lay.visible and lay.material in library:
            out.append((lay.thickness, library.get(lay.material), float(lay.opacity)))
    return out


def export_maps(doc: Any, folder: str | Path, progress: Progress = lambda f, m: None,
                cancelled: IsCancelled = lambda: False, fmt: str = "png") -> Path:
    """Each layer's thickness map and ``manifest.json``: ``fmt="png"`` 16-bit PNG (value = thickness /
    scale_um × 65535, scale also in the PNG's text), or ``"exr"`` 32-bit float OpenEXR (µm)."""
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


def baked_albedo(doc: Any, library: Any) -> np.ndarray:
    """The made-up albedo at the head texture's resolution, uint8 sRGB, under neutral (white) light."""
    from PIL import Image

    from app.preview_renderer import MakeupCompositor

    head = doc.head
    albedo = head.albedo if head.albedo is not None else np.full((512, 512, 3), 200, np.uint8)
    res = doc.layers[0].thickness.shape[0] if doc.layers else 512
    hi = (albedo.astype(np.float32) / 255.0) ** 2.2
    small = np.asarray(Image.fromarray(albedo).resize((res, res), Image.BILINEAR)).astype(np.float32) / 255.0
    comp = MakeupCompositor(small ** 2.2)
    rgba = comp.composite(layer_tuples(doc, library), slice(0, res), slice(0, res))
    size = albedo.shape[1], albedo.shape[0]
    up = np.stack([np.asarray(Image.fromarray(rgba[..., k]).resize(size, Image.BILINEAR))
                   for k in range(4)], axis=-1)
    lo = np.stack([np.asarray(Image.fromarray(small[..., k] ** 2.2).resize(size, Image.BILINEAR))
                   for k in range(3)], axis=-1)
    out = np.clip(up[..., :3] + (hi - lo) * up[..., 3:4], 0.0, 1.0)
    return np.round(out ** (1.0 / 2.2) * 255.0).astype(np.uint8)


def export_gltf(doc: Any, library: Any, path: str | Path, progress: Progress = lambda f, m: None,
                cancelled: IsCancelled = lambda: False) -> Path:
    """The head as glTF (.gltf) or binary glTF (.glb) with the baked made-up albedo."""
    import trimesh
    from PIL import Image

    path = Path(path)
    if path.suffix.lower() not in (".glb", ".gltf"):
        raise SheerError(f"{path}: the file name must end in .glb or .gltf")
    progress(0.1, "baking the makeup into the albedo")
    tex = baked_albedo(doc, library)
    _check_cancel(cancelled)
    progress(0.6, "writing the mesh")
    head = doc.head
    material = trimesh.visual.material.PBRMaterial(
        name="sheer_madeup_skin", baseColorTexture=Image.fromarray(tex), metallicFactor=0.0, roughnessFactor=0.6)
    visual = trimesh.visual.TextureVisuals(uv=head.uv, material=material)
    mesh = trimesh.Trimesh(head.vertices, head.faces, vertex_normals=head.normals, visual=visual, process=False)
    scene = trimesh.Scene(mesh)
    scene.metadata["credit"] = head.credit
    data = scene.export(file_type=path.suffix.lower()[1:])
    from km.atomicio import atomic_write_bytes

    if isinstance(data, dict):  # .gltf: several files
        for name, blob in data.items():
            atomic_write_bytes(path.parent / (path.name if name == "model.gltf" else name), blob)
    else:
        atomic_write_bytes(path, data)
    progress(1.0, "done")
    return path


def render_image(head: Any, layers: list[tuple[np.ndarray, Any, float]], camera: Any, lighting: Any,
                 size: tuple[int, int], path: str | Path, reference: bool = False,
                 progress: Progress = lambda f, m: None, cancelled: IsCancelled = lambda: False) -> Path:
    """Render on a standalone (EGL) GL context in the calling thread and save a PNG."""
    import moderngl
    from PIL import Image

    from app import seams

    w, h = size
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise SheerError(f"image size {w}×{h} must be between 16 and 8192 pixels on a side")
    path = Path(path)
    progress(0.05, "starting OpenGL")
    ctx = moderngl.create_context(standalone=True, backend="egl")
    try:
        res = layers[0][0].shape[0] if layers else 512
        renderer = seams.create_renderer(ctx, head, res)
        try:
            progress(0.3, "compositing the layers")
            renderer.set_layers(layers, None)
            _check_cancel(cancelled)
            fbo = ctx.framebuffer(ctx.renderbuffer((w, h)), ctx.depth_renderbuffer((w, h)))
            progress(0.6, "rendering")
            renderer.render(fbo, (w, h), camera, lighting, reference=reference)
            img = np.frombuffer(fbo.read(components=3), np.uint8).reshape(h, w, 3)[::-1]
            for a in (*fbo.color_attachments, fbo.depth_attachment, fbo):
                a.release()
        finally:
            renderer.release()
    finally:
        ctx.release()
    Image.fromarray(img).save(path)
    progress(1.0, "done")
    return path
