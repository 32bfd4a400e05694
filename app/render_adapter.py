"""The studio's viewport on the real renderer (``render.Renderer``) — the only renderer the studio uses.

What this adds around ``render.Renderer``:

- the studio's camera and key light are copied in before each frame, and the renderer's settings (mode,
  debug view, thickness-view layer) set from the viewport's state;
- the document's layers as ``render.LayerInput`` (hidden layers included, so the renderer's layer
  indices are the document's; see :func:`layer_inputs`);
- the made-up frame is kept in an offscreen target and drawn again only when something it shows changed
  (camera, lights, layers, settings, size): moving the brush ring alone costs a copy of that frame and one
  depth-tested pass of the mesh, not a new frame;
- the before/after split renders the bare skin too and shows its left part;
- the thickness debug view maps the selected *document* layer to the renderer's *active* slot
  (:func:`debug_slot`);
- mode ``"lightweight"``: a captured face (``capture.pipeline.load_face``) drawn by the lightweight engine
  (``render.lightweight.LightweightRenderer``, Paris et al. 2003) with the same camera and lights, and the
  physical renderer's texture-space KM outputs as its makeup — as ``sheer render --mode lightweight``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Sequence

    from app.camera import Lighting, OrbitCamera

MESH_VERT = """
#version 330
uniform mat4 u_mvp;
in vec3 in_pos;
out vec3 v_pos;
void main() { v_pos = in_pos; gl_Position = u_mvp * vec4(in_pos, 1.0); }
"""

RING_FRAG = """
#version 330
uniform vec4 u_brush;
uniform sampler2D u_depth;
in vec3 v_pos;
out vec4 f_color;
void main() {
    // the frame's own depth (same mesh, same matrix): draw only the visible surface
    if (gl_FragCoord.z > texelFetch(u_depth, ivec2(gl_FragCoord.xy), 0).r + 1e-6) discard;
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


#: The viewport's render modes: the physical renderer's two SSS modes, and the lightweight engine.
RENDER_MODES: tuple[str, ...] = ("fast", "reference", "lightweight")


def debug_views() -> list[str]:
    """The renderer's view names, index 0 the normal image (``render.DEBUG_VIEWS``)."""
    from render.renderer import DEBUG_VIEWS

    return list(DEBUG_VIEWS)


def debug_slot(active: Sequence[int], layer_index: int) -> int | None:
    """The renderer's slot for document layer ``layer_index`` in the thickness view.

    ``settings.debug_layer`` indexes the renderer's *active* layers (``renderer.km.active``: the visible,
    non-transparent document layers, bottom first), not the document's: with a hidden layer below the
    selected one the two differ. None when the layer is not active (hidden): it has nothing to show.
    """
    active = list(active)
    return active.index(layer_index) if layer_index in active else None


def layer_inputs(doc: Any, library: Any) -> list[Any]:
    """Every document layer as a ``render.LayerInput`` (bottom first, hidden ones with ``visible=False``),
    so index *i* is document layer *i*. The material comes from the studio's ``library`` (edits there show
    at once), else the layer's own copy (``material_object``).
    """
    from render import LayerInput

    out = []
    for i, lay in enumerate(doc.layers):
        mat = library.get(lay.material) if lay.material in library else getattr(lay, "material_object", None)
        visible = bool(lay.visible) and mat is not None
        if mat is None:  # a layer whose material is nowhere: kept (indices) but not drawn
            mat = next(iter(library))
        out.append(LayerInput(mat, lay.thickness, float(lay.opacity), visible, str(getattr(lay, "name", i))))
    return out


class ViewportRenderer:
    """``render.Renderer`` drawing the studio's view into a framebuffer it is given (see module doc)."""

    name = "render.Renderer"

    def __init__(self, ctx: Any, head: Any, layout: Any = None) -> None:
        from render import Renderer

        self.ctx = ctx
        self.r = Renderer(ctx, head, layout=layout)
        self.views = debug_views()
        verts = np.ascontiguousarray(np.asarray(head.vertices, "f4"))
        self.vbo = ctx.buffer(verts.tobytes())
        self.ibo = ctx.buffer(np.asarray(head.faces, "i4").tobytes())
        self.depth_prog = ctx.program(vertex_shader=MESH_VERT, fragment_shader=DEPTH_FRAG)
        self.ring_prog = ctx.program(vertex_shader=MESH_VERT, fragment_shader=RING_FRAG)
        self.depth_vao = ctx.vertex_array(self.depth_prog, [(self.vbo, "3f", "in_pos")], self.ibo)
        self.ring_vao = ctx.vertex_array(self.ring_prog, [(self.vbo, "3f", "in_pos")], self.ibo)
        self.quad_prog = ctx.program(vertex_shader=QUAD_VERT, fragment_shader=QUAD_FRAG)
        self.quad_vao = ctx.vertex_array(self.quad_prog, [])
        self._frame: Any = None  # the made-up frame (colour) + the mesh's depth, at the view's size
        self._before: Any = None  # the bare skin, for the before/after split
        self._scene_key: Any = None
        self._depth_key: Any = None  # the scene whose mesh depth _frame holds
        self._before_lw: Any = None  # the bare frame's colour with a depth buffer (lightweight split)
        self._blit_ok = True
        self._layers_version = 0
        self._env: str | None = None
        self.environment = "none"
        self.layer_index = 0  # the document layer the thickness view shows
        self.debug_hidden = False  # the thickness view's layer is hidden (nothing to show)
        self.frames_drawn = 0  # full renderer frames (not ring-only redraws)
        self.face: Any = None  # a captured face (capture.pipeline.Face) for the lightweight mode
        self._lw: Any = None  # its LightweightRenderer, created on first use
        self.drawn_by = ""  # the engine that drew the kept frame

    # ------------------------------------------------------------------ the lightweight engine
    def set_face(self, face: Any) -> None:
        """Use ``face`` (``capture.pipeline.Face``, for this head) in the lightweight mode; None removes it."""
        if self._lw is not None:
            self._lw.release()
            self._lw = None
        self.face = face
        self._scene_key = None

    def _lightweight(self) -> Any:
        from core.errors import SheerError

        if self.face is None:
            raise SheerError("the lightweight mode needs a captured face (File → Open Captured Face…)")
        if self._lw is None:
            from render.lightweight import LightweightRenderer

            self._lw = LightweightRenderer(self.ctx, self.r.head, self.face)
        return self._lw

    # ------------------------------------------------------------------ cosmetics
    def set_layers(self, layers: list[Any]) -> None:
        """All the document's layers (``render.LayerInput``, see :func:`layer_inputs`): a full evaluation."""
        self.r.set_layers(layers)
        self._layers_version += 1

    def update_tiles(self, layer_index: int, thickness: np.ndarray, tiles_rc: list[tuple[int, int]]) -> None:
        """Document layer ``layer_index`` changed in the 64² tiles ``tiles_rc`` = [(row, column), …]."""
        self.r.update_tiles(layer_index, thickness, [(c, r) for r, c in tiles_rc])
        self._layers_version += 1

    @property
    def active(self) -> list[int]:
        """Document indices of the layers the renderer draws (visible, bottom first)."""
        return list(self.r.km.active)

    # ------------------------------------------------------------------ frames
    def _sync(self, camera: OrbitCamera, lighting: Lighting, debug: int, mode: str) -> None:
        from render.lights import default_lights

        c = self.r.camera
        c.yaw, c.pitch, c.distance = float(camera.yaw), float(camera.pitch), float(camera.distance)
        c.target = np.asarray(camera.target, float)
        c.fov_y = float(camera.fov_y)
        self.r.lights = [lighting.key_light(), *default_lights()[1:]]
        if self.environment != self._env:
            self.r.set_environment(None if self.environment in ("", "none") else self.environment)
            self._env = self.environment
        s = self.r.settings
        s.mode = mode if mode in ("fast", "reference") else "fast"
        view = self.views[debug] if 0 <= debug < len(self.views) else "none"
        self.debug_hidden = False
        if view == "thickness":
            slot = debug_slot(self.r.km.active, self.layer_index)
            if slot is None:  # the selected layer is hidden: show the image (the viewport says why)
                self.debug_hidden, view = True, "none"
            else:
                s.debug_layer = slot
        s.debug_view = view

    def _targets(self, size: tuple[int, int], split: bool) -> None:
        if self._frame is not None and self._frame.size != size:
            self._release_targets()
        if self._frame is None:
            colour = self.ctx.texture(size, 4)
            depth = self.ctx.depth_texture(size)
            self._frame = self.ctx.framebuffer([colour], depth)
            self._scene_key = None
        if split and self._before is None:
            self._before = self.ctx.framebuffer([self.ctx.texture(size, 4)])

    def render(self, fbo: Any, size: tuple[int, int], camera: OrbitCamera, lighting: Lighting, *,
               split: float = 0.0, debug: int = 0, mode: str = "fast",
               brush: tuple[float, float, float, float] | None = None) -> bool:
        """Draw the view into ``fbo`` (``size`` pixels). Returns True when the renderer drew a new frame,
        False when the kept frame was reused (only the brush ring moved).
        """
        import moderngl

        w, h = size
        # bind the target first: creating a framebuffer makes moderngl re-bind the one it last knew, which
        # may be the widget's previous one (Qt replaces it on a resize): GL_INVALID_OPERATION
        fbo.use()
        self._targets((w, h), split > 0.0)
        key = (w, h, float(camera.yaw), float(camera.pitch), float(camera.distance),
               tuple(np.asarray(camera.target, float).tolist()), float(camera.fov_y),
               (lighting.azimuth, lighting.elevation, tuple(lighting.colour), lighting.intensity),
               self.environment, float(split), int(debug), mode, self.layer_index, self._layers_version)
        fresh = key != self._scene_key
        if fresh:
            self._sync(camera, lighting, debug, mode)
            if mode == "lightweight":
                self._draw_lightweight(w, h, split > 0.0)
            else:
                s = self.r.settings
                if split > 0.0:
                    s.makeup = False
                    try:
                        self.r.render(self._before, (0, 0, w, h))
                    finally:
                        s.makeup = True
                self.r.render(self._frame, (0, 0, w, h))
            self.drawn_by = mode
            self._scene_key = key
            self.frames_drawn += 1
        fbo.use()
        self.ctx.viewport = (0, 0, w, h)
        self.ctx.scissor = None
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        if split > 0.0:
            self._draw_quad(self._frame.color_attachments[0], 1.0)
            self._draw_quad(self._before.color_attachments[0], float(split) * 2.0 - 1.0)
            self.ctx.scissor = (max(int(split * w) - 1, 0), 0, 2, h)
            fbo.clear(1.0, 1.0, 1.0, 1.0)
            self.ctx.scissor = None
        else:
            self._copy_frame(fbo)
        if brush is not None:
            self._draw_ring(fbo, camera, w, h, brush)
        return fresh

    def _draw_lightweight(self, w: int, h: int, split: bool) -> None:
        """The kept frame (and the bare one for the split) by the lightweight engine, with the physical
        renderer's camera, lights, environment and texture-space KM outputs.
        """
        lw = self._lightweight()
        lw.camera = self.r.camera
        lw.lights = list(self.r.lights)
        lw.environment = self.r.environment
        if split:
            lw.makeup = None
            self._before_depth(w, h)
            lw.render(self._before_lw, (0, 0, w, h))
        lw.makeup = self.r.km if self.r.km.active else None
        lw.render(self._frame, (0, 0, w, h))
        self._depth_key = None  # the engine wrote its own depth into _frame: the ring pass redoes it

    def _before_depth(self, w: int, h: int) -> None:
        """A depth attachment for the bare frame (the lightweight engine depth-tests)."""
        if self._before_lw is None or self._before_lw.size != (w, h):
            from render.glutil import release_all

            if self._before_lw is not None:
                release_all(self.ctx, [self._before_lw, self._before_lw.depth_attachment])
            self._before_lw = self.ctx.framebuffer(self._before.color_attachments, self.ctx.depth_renderbuffer((w, h)))

    def _copy_frame(self, fbo: Any) -> None:
        """The kept frame into ``fbo``: a framebuffer blit (≈ 1.5 ms at 1280×720 on llvmpipe), or a
        textured quad where the blit is refused.
        """
        import moderngl

        if self._blit_ok:
            self.ctx.copy_framebuffer(fbo, self._frame)
            if self.ctx.error == "GL_NO_ERROR":
                fbo.use()
                return
            self._blit_ok = False  # e.g. a multisampled target: the quad from now on
            fbo.use()
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        self._draw_quad(self._frame.color_attachments[0], 1.0)

    def _draw_ring(self, fbo: Any, camera: OrbitCamera, w: int, h: int,
                   brush: tuple[float, float, float, float]) -> None:
        """The brush ring on the surface, against the mesh's depth (drawn once per frame, on demand), only
        inside the ring's box on screen.
        """
        import moderngl

        mvp = self._mvp(camera, w, h)
        if self._depth_key != self._scene_key:
            self._frame.color_mask = (False, False, False, False)
            self._frame.use()
            self.ctx.viewport = (0, 0, w, h)
            self.ctx.scissor = None
            self._frame.clear(depth=1.0)
            self.ctx.enable(moderngl.DEPTH_TEST)
            self.ctx.depth_func = "<"
            self.depth_prog["u_mvp"].write(mvp)
            self.depth_vao.render(moderngl.TRIANGLES)
            self.ctx.disable(moderngl.DEPTH_TEST)
            self._frame.color_mask = (True, True, True, True)
            self._depth_key = self._scene_key
            fbo.use()
            self.ctx.viewport = (0, 0, w, h)
        box = self._screen_box(camera, w, h, brush)
        if box is None:
            return
        self.ctx.scissor = box
        self.ctx.enable(moderngl.BLEND)
        # colour blended over the frame, the frame's alpha kept (Qt composes the widget with it)
        self.ctx.blend_func = (moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA, moderngl.ZERO, moderngl.ONE)
        self.ctx.blend_equation = moderngl.FUNC_ADD
        self._frame.depth_attachment.use(0)
        self.ring_prog["u_depth"].value = 0
        self.ring_prog["u_mvp"].write(mvp)
        self.ring_prog["u_brush"].value = tuple(float(x) for x in brush)
        self.ring_vao.render(moderngl.TRIANGLES)
        self.ctx.disable(moderngl.BLEND)
        self.ctx.scissor = None

    @staticmethod
    def _screen_box(camera: OrbitCamera, w: int, h: int,
                    brush: tuple[float, float, float, float]) -> tuple[int, int, int, int] | None:
        """Pixel box (x, y, w, h; GL's origin bottom-left) around the ring's sphere, or None if behind."""
        vp = camera.view_projection(w / max(h, 1))
        c, r = np.asarray(brush[:3], float), float(brush[3]) * 1.2
        corners = np.array([[c[0] + dx * r, c[1] + dy * r, c[2] + dz * r, 1.0]
                            for dx in (-1, 1) for dy in (-1, 1) for dz in (-1, 1)])
        clip = corners @ vp.T
        if np.any(clip[:, 3] <= 1e-6):
            return 0, 0, w, h
        ndc = clip[:, :2] / clip[:, 3:4]
        x0, y0 = ((ndc.min(axis=0) + 1.0) * 0.5 * (w, h)).astype(int) - 2
        x1, y1 = ((ndc.max(axis=0) + 1.0) * 0.5 * (w, h)).astype(int) + 3
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
        if x1 <= x0 or y1 <= y0:
            return None
        return int(x0), int(y0), int(x1 - x0), int(y1 - y0)

    @staticmethod
    def _mvp(camera: OrbitCamera, w: int, h: int) -> bytes:
        vp = camera.view_projection(w / max(h, 1))
        return np.ascontiguousarray(vp.T, dtype="f4").tobytes()

    def _draw_quad(self, texture: Any, right: float) -> None:
        import moderngl

        texture.use(0)
        self.quad_prog["u_src"].value = 0
        self.quad_prog["u_right"].value = right
        self.quad_vao.render(moderngl.TRIANGLE_STRIP, vertices=4)

    def invalidate(self) -> None:
        """Draw a new frame next time even if nothing the key covers changed (e.g. a material edit)."""
        self._scene_key = None

    def pick(self, x: int, y: int, camera: OrbitCamera | None = None) -> np.ndarray | None:
        """The surface point (mesh units) under pixel (x, y) of the last frame (origin top-left), or None.
        A lightweight frame is picked from its own depth (``camera``: the frame's camera).
        """
        if self.drawn_by != "lightweight" or self._frame is None or camera is None:
            p = self.r.pick(x, y)
            return None if p is None else np.asarray(p, float)
        from painting.hit import pixel_to_ndc, unproject

        w, h = self._frame.size
        if not (0 <= x < w and 0 <= y < h):
            return None
        raw = self._frame.read(viewport=(int(x), int(h - 1 - y), 1, 1), attachment=-1, dtype="f4")
        z = float(np.frombuffer(raw, np.float32)[0])
        if z >= 1.0:
            return None
        inv = np.linalg.inv(camera.view_projection(w / max(h, 1)))
        return unproject(pixel_to_ndc(x, y, w, h), z, inv)

    def render_image(self, size: tuple[int, int], camera: OrbitCamera, lighting: Lighting,
                     mode: str = "fast") -> np.ndarray:
        """An offscreen frame of ``size`` as uint8 (H, W, 3), top row first."""
        self._sync(camera, lighting, 0, mode)
        self._scene_key = None
        if mode != "lightweight":
            return self.r.render_image(size)
        lw = self._lightweight()
        lw.camera, lw.lights, lw.environment = self.r.camera, list(self.r.lights), self.r.environment
        lw.makeup = self.r.km if self.r.km.active else None
        return lw.render_image(size)

    def _release_targets(self) -> None:
        from render.glutil import release_all

        objs: list[Any] = []
        for fb in (self._frame, self._before):
            if fb is not None:
                objs += [*fb.color_attachments, *([fb.depth_attachment] if fb.depth_attachment else []), fb]
        if self._before_lw is not None:
            objs += [self._before_lw.depth_attachment, self._before_lw]
        release_all(self.ctx, objs)
        self._frame = self._before = self._before_lw = None
        self._scene_key = self._depth_key = None

    def release(self) -> None:
        """Free every GPU object (call with the context current)."""
        from render.glutil import release_all

        self._release_targets()
        if self._lw is not None:
            self._lw.release()
            self._lw = None
        release_all(self.ctx, [self.depth_vao, self.ring_vao, self.quad_vao, self.depth_prog, self.ring_prog,
                               self.quad_prog, self.vbo, self.ibo])
        self.r.release()


def preload_renderer(progress: Any = None, cancelled: Any = None) -> bool:
    """Import ``render.Renderer`` and load the spectral → RGB matrices it and the swatches need, off the GUI
    thread: from km's disk cache, or (the first run on a machine) made with colour-science, which takes
    seconds to import.
    """
    import importlib

    importlib.import_module("render.renderer")
    from km.cache import spectral_rgb_matrix_cached
    from km.spectra import DEFAULT_GRID
    from render.km_pass import default_wavelengths, spectral_matrix

    spectral_matrix(default_wavelengths())
    spectral_rgb_matrix_cached(DEFAULT_GRID.wavelengths)
    return True
