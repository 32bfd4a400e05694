"""The studio's stand-in renderer, used while ``render.Renderer`` is not available in this build.

A deliberately small moderngl renderer: the head with its albedo, the cosmetic layers composited in
texture space with Kubelka–Munk (R, T per layer, inter-reflection kept: c = R + T² c / (1 − R c)),
one draggable key light (Lambert with a wrap term standing in for subsurface scattering in "reference"
mode), an ambient term from the light preset or the HDR environment's mean colour, Blinn specular from
the top layer's roughness, a before/after split, debug views, a brush ring drawn on the surface and a
GPU position pass for picking. It is *not* the physically based renderer of issue 3.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from app.camera import OrbitCamera

VERT = """
#version 330
uniform mat4 u_mvp;
in vec3 in_pos; in vec3 in_normal; in vec2 in_uv;
out vec3 v_pos; out vec3 v_normal; out vec2 v_uv;
void main() {
    v_pos = in_pos; v_normal = in_normal; v_uv = in_uv;
    gl_Position = u_mvp * vec4(in_pos, 1.0);
}
"""

FRAG = """
#version 330
uniform sampler2D u_albedo;     // sRGB texture
uniform sampler2D u_makeup;     // rgb = made-up albedo - skin * a (linear, low res), a = detail weight (T^2)
uniform sampler2D u_thick;      // selected layer thickness / max (debug)
uniform vec3 u_eye; uniform vec3 u_light_dir; uniform vec3 u_light_col; uniform vec3 u_ambient;
uniform float u_rough; uniform float u_split; uniform float u_viewport_w; uniform int u_debug;
uniform int u_reference; uniform vec4 u_brush; uniform float u_exposure;
in vec3 v_pos; in vec3 v_normal; in vec2 v_uv;
out vec4 f_color;
// cheap transfer functions (llvmpipe's pow is slow): polynomial sRGB decode, sqrt-chain encode
vec3 to_linear(vec3 c) { return c * (c * (c * 0.305306011 + 0.682171111) + 0.012522878); }
vec3 to_srgb(vec3 x) {
    vec3 s1 = sqrt(x); vec3 s2 = sqrt(s1); vec3 s3 = sqrt(s2);
    return 0.662002687 * s1 + 0.684122060 * s2 - 0.323583601 * s3 - 0.0225411470 * x;
}
void main() {
    vec3 n = normalize(v_normal);
    vec3 hi = to_linear(texture(u_albedo, v_uv).rgb);
    vec4 mk = texture(u_makeup, v_uv);
    bool before = gl_FragCoord.x < u_split * u_viewport_w;
    vec3 albedo = before ? hi : clamp(hi * mk.a + mk.rgb, 0.0, 1.0);
    vec3 l = normalize(u_light_dir);
    vec3 v = normalize(u_eye - v_pos);
    float ndl = dot(n, l);
    float diff = u_reference == 1 ? max((ndl + 0.3) / 1.3, 0.0) : max(ndl, 0.0);
    vec3 h = normalize(l + v);
    float rough = before ? 0.45 : u_rough;
    float shin = 2.0 / max(rough * rough, 0.01);
    float spec = pow(max(dot(n, h), 0.0), shin) * (shin + 8.0) / 25.0 * 0.04 * max(ndl, 0.0);
    vec3 col = albedo * (u_light_col * diff + u_ambient) + u_light_col * spec;
    if (u_debug == 1) col = albedo;
    else if (u_debug == 2) { float t = texture(u_thick, v_uv).r; col = mix(hi * 0.3, vec3(t, t * 0.4, 1.0 - t), step(0.001, t)); }
    else if (u_debug == 3) col = clamp(hi * mk.a + mk.rgb, 0.0, 1.0);
    else if (u_debug == 4) col = n * 0.5 + 0.5;
    col *= u_exposure;
    col = col / (1.0 + col);
    col = to_srgb(clamp(col, 0.0, 1.0));
    if (u_debug == 4) col = n * 0.5 + 0.5;
    if (u_brush.w > 0.0) {
        float d = length(v_pos - u_brush.xyz);
        float w = max(u_brush.w * 0.08, 0.004);
        if (abs(d - u_brush.w) < w) col = mix(col, vec3(1.0, 1.0, 1.0), 0.85);
        else if (d < w) col = mix(col, vec3(1.0), 0.6);
    }
    if (u_split > 0.0 && abs(gl_FragCoord.x - u_split * u_viewport_w) < 1.0) col = vec3(1.0);
    f_color = vec4(col, 1.0);
}
"""

PICK_VERT = """
#version 330
uniform mat4 u_mvp;
in vec3 in_pos;
out vec3 v_pos;
void main() { v_pos = in_pos; gl_Position = u_mvp * vec4(in_pos, 1.0); }
"""

PICK_FRAG = """
#version 330
in vec3 v_pos;
out vec4 f_pos;
void main() { f_pos = vec4(v_pos, 1.0); }
"""

DEBUG_VIEWS = ("beauty", "albedo", "thickness", "made-up albedo", "normals")


@dataclass
class Lighting:
    """Key light direction (azimuth/elevation in degrees, azimuth 0 = from the camera side +Z),
    colour × intensity, ambient colour, exposure."""

    azimuth: float = 30.0
    elevation: float = 25.0
    colour: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 2.2
    ambient: tuple[float, float, float] = (0.35, 0.35, 0.38)
    exposure: float = 1.4

    def direction(self) -> np.ndarray:
        a, e = np.radians(self.azimuth), np.radians(self.elevation)
        return np.array([np.sin(a) * np.cos(e), np.sin(e), np.cos(a) * np.cos(e)], np.float32)


class MakeupCompositor:
    """Texture-space Kubelka–Munk stack of the visible layers over the low-resolution skin albedo."""

    LUT_SIZE = 64

    def __init__(self, skin_linear: np.ndarray) -> None:
        self.skin = skin_linear.astype(np.float32)  # (H, W, 3) at the document's resolution
        self._luts: dict[tuple[str, int], tuple[np.ndarray, np.ndarray, float]] = {}

    def invalidate(self, material: str | None = None) -> None:
        if material is None:
            self._luts.clear()
        else:
            self._luts = {k: v for k, v in self._luts.items() if k[0] != material}

    def lut(self, material: Any) -> tuple[np.ndarray, np.ndarray, float]:
        from app.fallback import km_layer_rt, spectrum_to_rgb

        key = (material.name, id(material))
        if key not in self._luts:
            tmax = float(max(material.max_thickness_um, 1e-3))
            t_um = np.linspace(0.0, tmax, self.LUT_SIZE)
            R, T = km_layer_rt(np.asarray(material.S), np.asarray(material.K), t_um[:, None] / 1000.0)
            wl = np.asarray(material.wavelengths)
            self._luts[key] = (spectrum_to_rgb(R, wl).astype(np.float32),
                               spectrum_to_rgb(T, wl).astype(np.float32), tmax)
        return self._luts[key]

    def _layer(self, c: np.ndarray, t: np.ndarray, R: np.ndarray, T: np.ndarray,
               tmax: float) -> tuple[np.ndarray, np.ndarray]:
        """One layer of thickness ``t`` over colours ``c``: (new colours, detail weight factor)."""
        idx = np.clip(t / tmax * (self.LUT_SIZE - 1), 0, self.LUT_SIZE - 1)
        i0 = np.floor(idx).astype(int)
        i1 = np.minimum(i0 + 1, self.LUT_SIZE - 1)
        f = (idx - i0)[..., None]
        r = R[i0] * (1 - f) + R[i1] * f
        tr = T[i0] * (1 - f) + T[i1] * f
        return r + tr * tr * c / np.maximum(1.0 - r * c, 1e-4), (tr * tr).mean(axis=-1)

    def composite(self, layers: list[tuple[np.ndarray, Any, float]], rows: slice, cols: slice) -> np.ndarray:
        """RGBA (made-up albedo, detail weight) for the region; ``layers`` bottom first:
        (thickness µm, material, opacity)."""
        c = self.skin[rows, cols].copy()
        weight = np.ones(c.shape[:2], np.float32)
        for thick, material, opacity in layers:
            t = thick[rows, cols] * opacity
            if not np.any(t > 0):
                continue
            R, T, tmax = self.lut(material)
            if np.all(R[0] == 0.0) and np.all(T[0] == 1.0):
                # texels without this layer are left exactly as they are (R = 0, T = 1 at zero
                # thickness): compute only the painted ones (a look covers a few % of the atlas)
                sel = np.nonzero(t > 0)
                painted, w = self._layer(c[sel], t[sel], R, T, tmax)
                c = c.astype(np.result_type(c, painted), copy=False)  # promoted as the full path does
                c[sel] = painted
                weight[sel] *= w
            else:
                c, w = self._layer(c, t, R, T, tmax)
                weight *= w
        return np.concatenate([c, weight[..., None]], axis=-1).astype(np.float32)


class PreviewRenderer:
    """Draws the head into a given framebuffer; owns its GL objects and releases them explicitly."""

    name = "preview (stand-in)"

    def __init__(self, ctx: Any, head: Any, doc_resolution: int) -> None:
        import moderngl

        self.ctx = ctx
        self.head = head
        self.res = doc_resolution
        verts = np.hstack([head.vertices, head.normals, head.uv]).astype("f4")
        self.vbo = ctx.buffer(verts.tobytes())
        self.ibo = ctx.buffer(np.asarray(head.faces, dtype="i4").tobytes())
        self.prog = ctx.program(vertex_shader=VERT, fragment_shader=FRAG)
        self.pick_prog = ctx.program(vertex_shader=PICK_VERT, fragment_shader=PICK_FRAG)
        fmt = [(self.vbo, "3f 3f 2f", "in_pos", "in_normal", "in_uv")]
        self.vao = ctx.vertex_array(self.prog, fmt, self.ibo)
        self.pick_vao = ctx.vertex_array(self.pick_prog, [(self.vbo, "3f 20x", "in_pos")], self.ibo)
        albedo = head.albedo if head.albedo is not None else np.full((4, 4, 3), 200, np.uint8)
        self.albedo = ctx.texture(albedo.shape[1::-1], 3, np.ascontiguousarray(albedo).tobytes())
        self.albedo.filter = (moderngl.LINEAR, moderngl.LINEAR)
        from PIL import Image

        small = np.asarray(Image.fromarray(albedo).resize((doc_resolution, doc_resolution), Image.BILINEAR))
        skin = (small.astype(np.float32) / 255.0) ** 2.2
        self.compositor = MakeupCompositor(skin)
        rgba = np.concatenate([np.zeros_like(skin), np.ones(skin.shape[:2] + (1,), np.float32)], axis=-1)
        self.makeup = ctx.texture((doc_resolution, doc_resolution), 4, rgba.astype("f2").tobytes(), dtype="f2")
        self.thick = ctx.texture((doc_resolution, doc_resolution), 1, dtype="f4")
        self._pick_fbo: Any = None
        self._pick_size = (0, 0)
        self.layers: list[tuple[np.ndarray, Any, float]] = []

    # ------------------------------------------------------------------ cosmetics
    def set_layers(self, layers: list[tuple[np.ndarray, Any, float]],
                   tiles: list[tuple[int, int]] | None = None, tile: int = 64) -> None:
        """Recompute the made-up albedo; ``tiles`` (row, col) of ``tile``² texels, or None for all."""
        self.layers = layers
        if tiles is None:
            tiles = [(0, 0)]
            tile = self.res
        for r, c in tiles:
            rows = slice(r * tile, min((r + 1) * tile, self.res))
            cols = slice(c * tile, min((c + 1) * tile, self.res))
            if rows.start >= rows.stop or cols.start >= cols.stop:
                continue
            block = self.compositor.composite(layers, rows, cols)
            block[..., :3] -= self.compositor.skin[rows, cols] * block[..., 3:4]
            self.makeup.write(np.ascontiguousarray(block.astype("f2")).tobytes(),
                              viewport=(cols.start, rows.start, cols.stop - cols.start, rows.stop - rows.start))

    def set_debug_thickness(self, thickness: np.ndarray | None, tmax: float, index: int = 0) -> None:
        data = np.zeros((self.res, self.res), np.float32) if thickness is None else thickness / max(tmax, 1e-6)
        self.thick.write(np.ascontiguousarray(data, dtype="f4").tobytes())

    # ------------------------------------------------------------------ frames
    def render(self, fbo: Any, size: tuple[int, int], camera: OrbitCamera, lighting: Lighting, *,
               split: float = 0.0, debug: int = 0, reference: bool = False, roughness: float = 0.4,
               brush: tuple[float, float, float, float] | None = None) -> None:
        import moderngl

        w, h = size
        fbo.use()
        self.ctx.viewport = (0, 0, w, h)
        self.ctx.clear(0.16, 0.16, 0.18, 1.0, depth=1.0)
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.ctx.disable(moderngl.CULL_FACE)
        mvp = camera.projection(w / max(h, 1)) @ camera.view()
        p = self.prog
        p["u_mvp"].write(np.ascontiguousarray(mvp.T, dtype="f4").tobytes())
        self._set(p, "u_eye", tuple(camera.eye().astype(float)))
        self._set(p, "u_light_dir", tuple(lighting.direction().astype(float)))
        self._set(p, "u_light_col", tuple(float(c) * lighting.intensity for c in lighting.colour))
        self._set(p, "u_ambient", tuple(float(c) for c in lighting.ambient))
        self._set(p, "u_exposure", float(lighting.exposure))
        self._set(p, "u_rough", float(roughness))
        self._set(p, "u_split", float(split))
        self._set(p, "u_viewport_w", float(w))
        self._set(p, "u_debug", int(debug))
        self._set(p, "u_reference", int(reference))
        self._set(p, "u_brush", tuple(brush) if brush else (0.0, 0.0, 0.0, 0.0))
        self._set(p, "u_albedo", 0)
        self._set(p, "u_makeup", 1)
        self._set(p, "u_thick", 2)
        self.albedo.use(0)
        self.makeup.use(1)
        self.thick.use(2)
        self.vao.render(moderngl.TRIANGLES)

    @staticmethod
    def _set(prog: Any, name: str, value: Any) -> None:
        if name in prog:
            prog[name].value = value

    def pick(self, x: int, y: int, size: tuple[int, int], camera: OrbitCamera) -> np.ndarray | None:
        """The surface point (mesh units) under pixel (x, y) (origin top-left), or None."""
        import moderngl

        w, h = size
        if not (0 <= x < w and 0 <= y < h):
            return None
        if self._pick_size != (w, h):
            if self._pick_fbo is not None:
                for a in (*self._pick_fbo.color_attachments, self._pick_fbo.depth_attachment):
                    a.release()
                self._pick_fbo.release()
            self._pick_fbo = self.ctx.framebuffer(self.ctx.texture((w, h), 4, dtype="f4"),
                                                  self.ctx.depth_renderbuffer((w, h)))
            self._pick_size = (w, h)
        fbo = self._pick_fbo
        fbo.use()
        self.ctx.viewport = (0, 0, w, h)
        gy = h - 1 - y
        self.ctx.scissor = (x, gy, 1, 1)
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self.ctx.enable(moderngl.DEPTH_TEST)
        mvp = camera.projection(w / max(h, 1)) @ camera.view()
        self.pick_prog["u_mvp"].write(np.ascontiguousarray(mvp.T, dtype="f4").tobytes())
        self.pick_vao.render(moderngl.TRIANGLES)
        self.ctx.scissor = None
        px = np.frombuffer(fbo.read(viewport=(x, gy, 1, 1), components=4, dtype="f4"), np.float32)
        if px[3] < 0.5:
            return None
        return px[:3].astype(float)

    def release(self) -> None:
        objs = [self.vao, self.pick_vao, self.prog, self.pick_prog, self.vbo, self.ibo, self.albedo,
                self.makeup, self.thick]
        if self._pick_fbo is not None:
            objs += [*self._pick_fbo.color_attachments, self._pick_fbo.depth_attachment, self._pick_fbo]
        for o in objs:
            o.release()
        self._pick_fbo = None
