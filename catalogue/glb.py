"""The made-up head as glTF/GLB: the makeup baked into the albedo under neutral light (for web shops).

One implementation for the studio's File → Export glTF (:func:`app.export.export_gltf`), ``sheer project
export FILE --gltf OUT.glb`` and the catalogue's GLB jobs. It lives here, above ``render``, because the
bake runs the renderer's own texture-space KM pass on a GL context.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from core.errors import SheerError

if TYPE_CHECKING:
    import moderngl

    from km.library import Library
    from painting import Document
    from painting.head import Head
    from render.km_pass import LayerInput


def baked_albedo(doc: Document, library: Library | None, ctx: moderngl.Context | None = None,
                 inputs: list[LayerInput] | None = None) -> np.ndarray:
    """The made-up albedo at the head texture's resolution, uint8 sRGB (H, W, 3), under neutral (white) light.

    The cosmetic stack is evaluated by the renderer's own texture-space KM pass (``render.KMTextureSpace``,
    spectral, float32) into R_top, T and R_bottom, and combined with the skin's albedo ρ as the renderer's
    "unlit" view does: R_top + ρ·T² / (1 − R_bottom·ρ). The maps are evaluated at the document's resolution;
    the skin's own detail above that resolution is kept.

    Args:
        doc: the document (head and layers).
        library: materials looked up by name first (see :func:`render.binding.layer_inputs`).
        ctx: a GL 4.5 context to use (made current by the caller), or None for a new standalone EGL one.
        inputs: the layers to bake instead of the document's (e.g. with a product swapped in).
    """
    from PIL import Image

    from km.srgb import srgb_decode, srgb_encode
    from render import KMTextureSpace, ShaderLibrary
    from render.binding import layer_inputs

    head = doc.head
    albedo = head.albedo if head.albedo is not None else np.full((512, 512, 3), 200, np.uint8)
    inputs = layer_inputs(doc, library) if inputs is None else inputs
    if not any(inp.visible for inp in inputs):
        return np.ascontiguousarray(albedo[..., :3])
    own = ctx is None
    if ctx is None:
        from render.context import standalone_context

        ctx = standalone_context(require=330)
    try:
        km = KMTextureSpace(ctx, ShaderLibrary(), dtype="f4")
        try:
            km.set_layers(inputs)
            r_top, trans, r_bot = km.read()
        finally:
            km.release()
    finally:
        if own:
            ctx.release()
    res = r_top.shape[0]
    hi = srgb_decode(albedo[..., :3].astype(np.float32) / 255.0)
    small = srgb_decode(np.asarray(Image.fromarray(np.ascontiguousarray(albedo[..., :3]))
                                   .resize((res, res), Image.Resampling.BILINEAR)).astype(np.float32) / 255.0)
    # what the makeup does to the skin at the maps' resolution: a gain (through it) and an offset (its own
    # reflection), applied to the full-resolution skin so its detail stays
    gain = trans * trans / np.maximum(1.0 - r_bot * small, 1e-4)
    size = albedo.shape[1], albedo.shape[0]

    def up(a: np.ndarray) -> np.ndarray:
        return np.stack([np.asarray(Image.fromarray(np.ascontiguousarray(a[..., k], np.float32))
                                    .resize(size, Image.Resampling.BILINEAR)) for k in range(3)], axis=-1)

    out = np.clip(up(r_top) + hi * up(gain), 0.0, 1.0)
    return np.round(srgb_encode(out.astype(np.float64)) * 255.0).astype(np.uint8)  # float64, as km encodes


def gltf_export(head: Head, texture: np.ndarray, suffix: str) -> bytes | dict[str, bytes]:
    """The head with ``texture`` (uint8 sRGB albedo) as a PBR base colour, exported by trimesh.

    Args:
        head: the mesh (vertices, faces, UVs, normals, credit).
        texture: uint8 (H, W, 3) sRGB, top row first.
        suffix: ".glb" (one binary blob) or ".gltf" (a dict of file name → bytes).
    """
    import trimesh
    from PIL import Image

    material = trimesh.visual.material.PBRMaterial(
        name="sheer_madeup_skin", baseColorTexture=Image.fromarray(texture), metallicFactor=0.0, roughnessFactor=0.6)
    visual = trimesh.visual.TextureVisuals(uv=head.uv, material=material)
    mesh = trimesh.Trimesh(head.vertices, head.faces, vertex_normals=head.normals, visual=visual, process=False)
    scene = trimesh.Scene(mesh)
    scene.metadata["credit"] = head.credit
    return scene.export(file_type=suffix.lower().lstrip("."))


def write_gltf(doc: Document, library: Library | None, path: str | Path, ctx: moderngl.Context | None = None,
               inputs: list[LayerInput] | None = None) -> Path:
    """Bake (:func:`baked_albedo`) and write the made-up head to ``path`` (.glb or .gltf), atomically.

    Raises:
        SheerError: the file name does not end in .glb or .gltf.
    """
    from core.atomicio import atomic_write_bytes

    path = Path(path)
    if path.suffix.lower() not in (".glb", ".gltf"):
        raise SheerError(f"{path}: the file name must end in .glb or .gltf")
    data = gltf_export(doc.head, baked_albedo(doc, library, ctx, inputs), path.suffix)
    if isinstance(data, dict):  # .gltf: several files
        for name, blob in data.items():
            atomic_write_bytes(path.parent / (path.name if name == "model.gltf" else name), blob)
    else:
        atomic_write_bytes(path, data)
    return path
