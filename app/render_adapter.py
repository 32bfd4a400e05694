"""The viewport on the real renderer (``render.Renderer``, issue 3), with the same interface as the
stand-in :class:`app.preview_renderer.PreviewRenderer` so the viewport uses either.

What the adapter adds around ``render.Renderer``: the studio's camera and key light are copied in each
frame; the before/after split renders the bare skin into an offscreen target and draws its left part
over the made-up frame; the brush ring is drawn on the surface after a depth-only pass of the mesh.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from app.camera import OrbitCamera
from app.preview_renderer import PICK_VERT, Lighting

RING_FRAG = """
#version 330
uniform vec4 u_brush;
in vec3 v_pos;
out vec4 f_color;
void main() {
    float d = length(v_pos - u_brush.xyz);
    float w = max(u_brush.w * 0.08, 0.004);
    if (abs(d - u_brush.w) < w) f_color = vec4(1.0, 1.0, 1.0, 0.85);
    else if (d < w) f_color = vec4(1.0, 1.0, 1.0, 0.6);
    else discard;
}
"""

DEPTH_FRAG = """
#version 330
in vec3 v_pos;
out vec4 f_color;
void main() { f_color = vec4(0.0); }
"""

QUAD_VERT = """
#version 330
uniform float u_right;
out vec2 v_uv;
void main() {
    vec2 p = vec2(gl_VertexID & 1, gl_VertexID >> 1);
    v_uv = vec2(p.x * (u_right + 1.0) * 0.5, p.y);
    gl_Position = vec4(mix(-1.0, u_right, p.x), p.y * 2.0 - 1.0, 0.0, 1.0);
}
"""

QUAD_FRAG = """
#version 330
uniform sampler2D u_src;
in vec2 v_uv;
out vec4 f_color;
void main() { f_color = texture(u_src, v_uv); }
"""


def debug_views() -> list[str]:
    from render.renderer import DEBUG_VIEWS

    return list(DEBUG_VIEWS)


class RealViewportRenderer:
    """``render.Renderer`` in the studio's viewport."""

    name = "render.Renderer"

    def __init__(self, ctx: Any, head: Any, resolution: int) -> None:
        from render import Renderer

        self.ctx = ctx
        self.r = Renderer(ctx, head)
        self.views = debug_views()
        verts = np.ascontiguousarray(np.asarray(head.vertices, "f4"))
        self.vbo = ctx.buffer(verts.tobytes())
        self.ibo = ctx.buffer(np.asarray(head.faces, "i4").tobytes())
        self.depth_prog = ctx.program(vertex_shader=PICK_VERT, fragment_shader=DEPTH_FRAG)
        self.ring_prog = ctx.program(vertex_shader=PICK_VERT, fragment_shader=RING_FRAG)
        self.depth_vao = ctx.vertex_array(self.depth_prog, [(self.vbo, "3f", "in_pos")], self.ibo)
        self.ring_vao = ctx.vertex_array(self.ring_prog, [(self.vbo, "3f", "in_pos")], self.ibo)
        self.quad_prog = ctx.program(vertex_shader=QUAD_VERT, fragment_shader=QUAD_FRAG)
        self.quad_vao = ctx.vertex_array(self.quad_prog, [])
        self._before: Any = None
        self._before_size = (0, 0)
        self._last_fbo: Any = None
        self._n_layers = -1
        self._env: str | None = None
        self.environment = "none"
        self.debug_layer = 0

    # ------------------------------------------------------------------ cosmetics
    def set_layers(self, layers: list[tuple[np.ndarray, Any, float]],
                   tiles: list[tuple[int, int]] | None = None, tile: int = 64) -> None:
        from render import LayerInput

        if tiles is None or len(layers) != self._n_layers:
            self.r.set_layers([LayerInput(m, t, float(o)) for t, m, o in layers])
            self._n_layers = len(layers)
            return
        colrow = [(c, r) for r, c in tiles]
        for i, (t, _m, _o) in enumerate(layers):
            self.r.update_tiles(i, t, colrow)

    def set_debug_thickness(self, thickness: np.ndarray | None, tmax: float, index: int = 0) -> None:
        self.debug_layer = max(int(index), 0)

    # ------------------------------------------------------------------ frames
    def _sync(self, camera: OrbitCamera, lighting: Lighting, debug: int, reference: bool) -> None:
        from render import Light
        from render.lights import default_lights

        c = self.r.camera
        c.yaw, c.pitch, c.distance = float(camera.yaw), float(camera.pitch), float(camera.distance)
        c.target = np.asarray(camera.target, float)
        c.fov_y = float(camera.fov_y)
        key = Light.directional(float(lighting.azimuth), float(lighting.elevation),
                                float(lighting.intensity) * 0.7, tuple(float(x) for x in lighting.colour))
        self.r.lights = [key, *default_lights()[1:]]
        if self.environment != self._env:
            self.r.set_environment(None if self.environment in ("", "none") else self.environment)
            self._env = self.environment
        s = self.r.settings
        s.mode = "reference" if reference else "fast"
        s.debug_view = self.views[debug] if 0 <= debug < len(self.views) else "none"
        s.debug_layer = min(self.debug_layer, max(self._n_layers - 1, 0))

    def render(self, fbo: Any, size: tuple[int, int], camera: OrbitCamera, lighting: Lighting, *,
               split: float = 0.0, debug: int = 0, reference: bool = False, roughness: float = 0.4,
               brush: tuple[float, float, float, float] | None = None) -> None:
        import moderngl

        w, h = size
        self._last_fbo = fbo
        self._sync(camera, lighting, debug, reference)
        s = self.r.settings
        if split > 0.0:
            if self._before_size != (w, h):
                fbo.use()  # never release the framebuffer that is bound
                self._release_before()
                self._before = self.ctx.framebuffer([self.ctx.texture((w, h), 4)])
                self._before_size = (w, h)
            s.makeup = False
            try:
                self.r.render(self._before, (0, 0, w, h))
            finally:
                s.makeup = True
        self.r.render(fbo, (0, 0, w, h))
        fbo.use()
        self.ctx.viewport = (0, 0, w, h)
        self.ctx.scissor = None
        if split > 0.0:
            self.ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
            self._before.color_attachments[0].use(0)
            self.quad_prog["u_src"].value = 0
            self.quad_prog["u_right"].value = float(split) * 2.0 - 1.0
            self.quad_vao.render(moderngl.TRIANGLE_STRIP, vertices=4)
            x = int(split * w)
            self.ctx.scissor = (max(x - 1, 0), 0, 2, h)
            fbo.clear(1.0, 1.0, 1.0, 1.0)
            self.ctx.scissor = None
        if brush is not None:
            mvp = np.ascontiguousarray((camera.projection(w / max(h, 1)) @ camera.view()).T, dtype="f4")
            self.ctx.enable(moderngl.DEPTH_TEST)
            self.ctx.depth_func = "<="
            fbo.color_mask = (False, False, False, False)
            fbo.depth_mask = True
            fbo.use()
            self.ctx.viewport = (0, 0, w, h)
            fbo.clear(depth=1.0)
            self.depth_prog["u_mvp"].write(mvp.tobytes())
            self.depth_vao.render(moderngl.TRIANGLES)
            fbo.color_mask = (True, True, True, True)
            fbo.use()  # moderngl applies a framebuffer's masks when it is bound
            self.ctx.viewport = (0, 0, w, h)
            self.ctx.enable(moderngl.BLEND)
            # colour blended over the frame, the frame's alpha kept (Qt composes the widget with it)
            self.ctx.blend_func = (moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA, moderngl.ZERO, moderngl.ONE)
            self.ctx.blend_equation = moderngl.FUNC_ADD
            self.ring_prog["u_mvp"].write(mvp.tobytes())
            self.ring_prog["u_brush"].value = tuple(float(x) for x in brush)
            self.ring_vao.render(moderngl.TRIANGLES)
            self.ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST)
            self.ctx.depth_func = "<"

    def pick(self, x: int, y: int, size: tuple[int, int], camera: OrbitCamera) -> np.ndarray | None:
        p = self.r.pick(x, y)
        return None if p is None else np.asarray(p, float)

    def _release_before(self) -> None:
        if self._before is not None:
            for a in self._before.color_attachments:
                a.release()
            self._before.release()
            self._before = None
            self._before_size = (0, 0)

    def release(self) -> None:
        if self._before is not None and self._last_fbo is not None:
            self._last_fbo.use()  # never release the framebuffer that is bound
        self._release_before()
        for o in (self.depth_vao, self.ring_vao, self.quad_vao, self.depth_prog, self.ring_prog, self.quad_prog,
                  self.vbo, self.ibo):
            o.release()
        self.r.release()


class DualRenderer:
    """The real renderer when the view is still, the stand-in preview while it moves.

    Orbiting and painting need a frame every few tens of milliseconds; on a software rasteriser the full
    renderer (SSS, shadows, layered specular) takes several times that. While the view moves the viewport
    draws the preview (texture-space KM composite, one light) at reduced resolution, and 250 ms after the
    last change it draws the full renderer again. Picking always uses the preview's GPU position pass.

    ``real`` may arrive later (:meth:`attach_real`): the viewport shows the preview until then, so the
    first frame does not wait for the full renderer's start-up (its colour tables import colour-science).
    """

    def __init__(self, real: RealViewportRenderer | None, preview: Any) -> None:
        self.real, self.preview = real, preview
        self.interactive = False
        self._env = "none"
        self._layers: list[tuple[np.ndarray, Any, float]] | None = None
        self._thick: tuple[np.ndarray | None, float, int] | None = None
        self._deferred: set[tuple[int, int]] | None = None
        self._deferred_all = False

    @property
    def name(self) -> str:
        if self.real is None:
            return "preview (full renderer starting)"
        return "preview (moving)" if self.interactive else self.real.name

    @property
    def environment(self) -> str:
        return self._env

    @environment.setter
    def environment(self, value: str) -> None:
        self._env = value
        if self.real is not None:
            self.real.environment = value

    def attach_real(self, real: RealViewportRenderer) -> None:
        self.real = real
        real.environment = self._env
        if self._layers is not None:
            real.set_layers(self._layers, None)
        if self._thick is not None:
            real.set_debug_thickness(*self._thick)

    def set_layers(self, layers: list[tuple[np.ndarray, Any, float]],
                   tiles: list[tuple[int, int]] | None = None, tile: int = 64) -> None:
        """The preview updates at once; the full renderer's texture-space pass is deferred while the view
        moves (the dirty tiles are merged and evaluated before its next frame)."""
        self._layers = layers
        self.preview.set_layers(layers, tiles, tile)
        if self.real is None:
            return
        if tiles is None:
            self._deferred = None
            self._deferred_all = True
        elif not self._deferred_all:
            self._deferred = set(tiles) | (self._deferred or set())
        if not self.interactive:
            self._flush()

    def _flush(self) -> None:
        if self.real is None or self._layers is None:
            return
        if self._deferred_all:
            self.real.set_layers(self._layers, None)
        elif self._deferred:
            self.real.set_layers(self._layers, sorted(self._deferred))
        self._deferred, self._deferred_all = None, False

    def set_debug_thickness(self, thickness: np.ndarray | None, tmax: float, index: int = 0) -> None:
        self._thick = (thickness, tmax, index)
        self.preview.set_debug_thickness(thickness, tmax, index)
        if self.real is not None:
            self.real.set_debug_thickness(thickness, tmax, index)

    def render(self, fbo: Any, size: tuple[int, int], camera: OrbitCamera, lighting: Lighting, **kw: Any) -> None:
        if self.interactive or self.real is None:
            kw["debug"] = 0  # the preview's debug views differ from the renderer's: show the image
            self.preview.render(fbo, size, camera, lighting, **kw)
        else:
            self._flush()
            self.real.render(fbo, size, camera, lighting, **kw)

    def pick(self, x: int, y: int, size: tuple[int, int], camera: OrbitCamera) -> np.ndarray | None:
        return self.preview.pick(x, y, size, camera)

    def release(self) -> None:
        self.preview.release()
        if self.real is not None:
            self.real.release()


def preload_real_renderer(progress: Any = None, cancelled: Any = None) -> bool:
    """Import what ``render.Renderer`` needs (colour-science's tables via ``km.colour``) off the GUI thread."""
    import importlib

    for name in ("render.renderer", "km.colour"):
        importlib.import_module(name)
    return True
