"""The head on the GPU: mesh buffers (position, normal, uv, tangent) and textures.

Texture conventions follow :mod:`painting.head`: arrays are uploaded as they are (row 0 first) and
sampled with the UVs unchanged. The albedo is stored as ``GL_SRGB8_ALPHA8`` so sampling returns linear
colour; the normal map is linear RGB8 (tangent space, +Y up in the map).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import moderngl

    from painting.head import Head
    from painting.layout import UVLayout

GL_SRGB8_ALPHA8 = 0x8C43


def vertex_tangents(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Per-vertex tangents (N, 4): xyz orthonormal to the normal along +u, w = handedness (±1).

    Hand-written (Lengyel's accumulation of per-triangle UV gradients) because trimesh computes no
    tangent frames; it is vectorised with ``np.add.at``.
    """
    v0, v1, v2 = (vertices[faces[:, i]] for i in range(3))
    t0, t1, t2 = (uv[faces[:, i]] for i in range(3))
    e1, e2 = v1 - v0, v2 - v0
    d1, d2 = t1 - t0, t2 - t0
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    r = np.where(np.abs(det) > 1e-20, 1.0 / np.where(det == 0, 1.0, det), 0.0)[:, None]
    sdir = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * r
    tdir = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * r
    tan1 = np.zeros_like(vertices)
    tan2 = np.zeros_like(vertices)
    for i in range(3):
        np.add.at(tan1, faces[:, i], sdir)
        np.add.at(tan2, faces[:, i], tdir)
    n = normals
    t = tan1 - n * np.sum(n * tan1, axis=1, keepdims=True)
    length = np.linalg.norm(t, axis=1, keepdims=True)
    # degenerate: any vector orthogonal to n
    fallback = np.cross(n, np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
    t = np.where(length > 1e-12, t / np.maximum(length, 1e-30), fallback / np.linalg.norm(fallback, axis=1,
                                                                                             keepdims=True))
    w = np.where(np.sum(np.cross(n, t) * tan2, axis=1) < 0.0, -1.0, 1.0)
    return np.concatenate([t, w[:, None]], axis=1)


class GpuHead:
    """GPU buffers and textures of a :class:`painting.head.Head`.

    Attributes: ``centre`` and ``radius`` (bounding sphere, mesh units), ``mm_per_unit``, ``has_normal_map``.
    Attribute names for programs: ``in_position``, ``in_normal``, ``in_uv``, ``in_tangent``.
    Texture units used by :meth:`bind_textures`: albedo 0, normal 1, specular 2, roughness 3.
    """

    ATTRIBUTES = ("in_position", "in_normal", "in_uv", "in_uv_paint", "in_tangent")

    def __init__(self, ctx: moderngl.Context, head: Head, layout: UVLayout | None = None,
                 alpha_mask: np.ndarray | None = None) -> None:
        """Upload ``head``'s mesh and textures to ``ctx``.

        ``layout``: the painting document's UV layout (``doc.layout``). When it is not the mesh's own
        UVs (``layout.source != "mesh"``, an xatlas unwrap), the layout's split vertices are drawn and its
        UVs address the thickness/KM maps (``in_uv_paint``) while the head's UVs address the textures.
        ``alpha_mask``: a bool (H, W) map in the head's UV space (e.g. the skin mask) stored as the albedo
        texture's alpha (resampled to the albedo's size by nearest texel), so a shader reads both with
        one fetch; without it the alpha is 1.
        """
        self.ctx = ctx
        self.head = head
        v = np.asarray(head.vertices, dtype=np.float64)
        n = np.asarray(head.normals, dtype=np.float64)
        faces = np.asarray(head.faces)
        uv = np.asarray(head.uv, dtype=np.float64)
        paint_uv = uv
        #: the paint maps are in the mesh's own UVs (texel p of a paint map = texel p of the head's maps)
        self.paint_uv_is_mesh_uv = layout is None or getattr(layout, "source", "mesh") == "mesh"
        if not self.paint_uv_is_mesh_uv:
            vmap = np.asarray(layout.vertex_map)
            v = np.asarray(layout.vertices, dtype=np.float64)
            n = np.asarray(layout.normals, dtype=np.float64)
            faces = np.asarray(layout.faces)
            uv = uv[vmap]
            paint_uv = np.asarray(layout.uv, dtype=np.float64)
        n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
        tangents = vertex_tangents(v, faces, uv, n)
        self.centre = (v.min(0) + v.max(0)) / 2.0
        self.radius = float(np.linalg.norm(v - self.centre, axis=1).max())
        self.mm_per_unit = float(head.mm_per_unit)
        self._buffers = {
            "in_position": (ctx.buffer(v.astype("f4").tobytes()), "3f"),
            "in_normal": (ctx.buffer(n.astype("f4").tobytes()), "3f"),
            "in_uv": (ctx.buffer(uv.astype("f4").tobytes()), "2f"),
            "in_uv_paint": (ctx.buffer(paint_uv.astype("f4").tobytes()), "2f"),
            "in_tangent": (ctx.buffer(tangents.astype("f4").tobytes()), "4f"),
        }
        self.index_buffer = ctx.buffer(np.asarray(faces, dtype="u4").tobytes())
        import hashlib

        # identifies the mesh's texture-space footprint (UVs and triangles), for caches of UV-space data
        self.uv_key = hashlib.sha256(np.ascontiguousarray(uv, dtype="<f4").tobytes()
                                     + np.ascontiguousarray(faces, dtype="<u4").tobytes()).hexdigest()[:32]
        self.triangle_count = len(faces)
        self.vertices = v
        self._vaos: dict[int, moderngl.VertexArray] = {}
        white = np.full((1, 1, 3), 255, np.uint8)
        self.albedo = self._texture(head.albedo if head.albedo is not None else white, srgb=True, alpha=alpha_mask)
        flat = np.array([[[128, 128, 255]]], np.uint8)
        self.has_normal_map = head.normal_map is not None
        self.normal = self._texture(head.normal_map if head.normal_map is not None else flat)
        self.has_specular_map = head.specular_map is not None
        self.has_roughness_map = head.roughness_map is not None
        one = np.full((1, 1), 255, np.uint8)
        self.specular = self._texture(head.specular_map if head.specular_map is not None else one)
        self.roughness = self._texture(head.roughness_map if head.roughness_map is not None else one)

    def _texture(self, img: np.ndarray, srgb: bool = False, alpha: np.ndarray | None = None) -> moderngl.Texture:
        img = np.ascontiguousarray(img, dtype=np.uint8)
        h, w = img.shape[:2]
        comps = 1 if img.ndim == 2 else img.shape[2]
        if srgb:  # GL_SRGB8_ALPHA8 needs 4 components (the alpha is linear)
            if alpha is not None and (h, w) == (1, 1):  # a constant albedo: take the mask's size
                h, w = np.asarray(alpha).shape[:2]
                img = np.ascontiguousarray(np.broadcast_to(img, (h, w, *img.shape[2:])))
            a = np.full((h, w, 1), 255, np.uint8)
            if alpha is not None:
                m = np.asarray(alpha, dtype=bool)
                rows = np.minimum((np.arange(h) + 0.5) * m.shape[0] // h, m.shape[0] - 1).astype(int)
                cols = np.minimum((np.arange(w) + 0.5) * m.shape[1] // w, m.shape[1] - 1).astype(int)
                a = np.where(m[rows][:, cols], 255, 0).astype(np.uint8)[..., None]
            img = np.concatenate([img[..., :3] if img.ndim == 3 else np.repeat(img[..., None], 3, 2), a], axis=2)
            tex = self.ctx.texture((w, h), 4, img.tobytes(), internal_format=GL_SRGB8_ALPHA8)
        else:
            tex = self.ctx.texture((w, h), comps, img.tobytes(), alignment=1)
        # bilinear without mipmaps: at portrait framing the face texture is magnified, and llvmpipe's
        # trilinear filtering costs several times more per fetch
        tex.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
        return tex

    def vertex_array(self, program: moderngl.Program) -> moderngl.VertexArray:
        """A vertex array binding the attributes ``program`` uses (cached per program)."""
        key = program.glo
        vao = self._vaos.get(key)
        if vao is None:
            content = [(buf, fmt, name) for name, (buf, fmt) in self._buffers.items() if name in program]
            vao = self.ctx.vertex_array(program, content, self.index_buffer)
            self._vaos[key] = vao
        return vao

    def draw(self, program: moderngl.Program) -> None:
        """Draw the mesh's triangles with ``program`` (its uniforms and textures set by the caller)."""
        self.vertex_array(program).render()

    def bind_textures(self, start: int = 0) -> None:
        """Bind albedo, normal, specular and roughness to units ``start`` .. ``start + 3``."""
        for i, tex in enumerate((self.albedo, self.normal, self.specular, self.roughness)):
            tex.use(start + i)

    def release(self) -> None:
        """Free every GPU object (call with the context current)."""
        for vao in self._vaos.values():
            vao.release()
        self._vaos.clear()
        for buf, _ in self._buffers.values():
            buf.release()
        self._buffers.clear()
        self.index_buffer.release()
        for tex in (self.albedo, self.normal, self.specular, self.roughness):
            tex.release()
