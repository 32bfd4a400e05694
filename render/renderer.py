"""The frame: shadow maps → lit pass through the makeup → SSS (fast or reference) → composite → display.

See :mod:`render` for the API. One :class:`Renderer` per head and GL context; it owns every GPU object
it creates and frees them in :meth:`Renderer.release`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from km.srgb import srgb_encode_scalar
from render.camera import OrbitCamera
from render.cover import CoverMesh, compute_cover, load_cover
from render.errors import RenderError
from render.glutil import read_depth, set_uniform, write_uniform
from render.gpu_head import GpuHead
from render.irradiance import TextureIrradiance
from render.km_pass import MAX_LAYERS, KMTextureSpace
from render.lights import MAX_LIGHTS, Environment, Light, ShadowMaps, default_lights, upload_lights
from render.lit_cache import MAX_LEVEL as MAX_CACHE_LEVEL
from render.lit_cache import TexelDensity, TextureLighting, irradiance_encoding, level_for
from render.lit_pass import U_SHADOW, LitPass, cull
from render.settings import DEBUG_VIEWS, RenderSettings
from render.shaders import ShaderLibrary
from render.sss_passes import SSSPasses
from render.targets import frame_targets

if TYPE_CHECKING:
    import moderngl

    from painting.head import Head
    from painting.layout import UVLayout
    from render.km_pass import LayerInput

#: Frame target sets kept (by size): the interactive and the full-resolution frame, and one more for a
#: resize or a scale change in between.
KEPT_TARGET_SIZES = 3


@dataclass
class FrameInfo:
    """What the last frame used (for picking and overlays)."""

    size: tuple[int, int] = (0, 0)
    view: np.ndarray = field(default_factory=lambda: np.eye(4))
    view_proj: np.ndarray = field(default_factory=lambda: np.eye(4))
    scissor: tuple[int, int, int, int] = (0, 0, 0, 0)


class Renderer:
    """The cosmetic renderer for one head on one ``moderngl.Context`` (see :mod:`render`).

    Its cosmetic layers come from :meth:`set_layers`, or from a :class:`render.binding.DocumentBinding`
    that follows a ``painting.Document`` (the one document → GPU path). ``km`` is the texture-space KM
    pass (its ``layers`` are the renderer's, index *i* = the document's layer *i*; ``active`` lists the
    visible ones).
    """

    def __init__(self, ctx: moderngl.Context, head: Head, shaders: ShaderLibrary | None = None,
                 km_dtype: str = "srgb8", layout: UVLayout | None = None) -> None:
        """Upload ``head`` and build the passes.

        Args:
            ctx: the GL context every GPU object is created on (GL 4.5 core).
            head: the head (mesh, albedo, normal map, skin mask, landmarks).
            shaders: where the GLSL files come from (default: ``resources/shaders``).
            km_dtype: the texture-space KM outputs, ``"srgb8"`` (shipped), ``"f2"`` or ``"f4"``.
            layout: the painting document's UV layout when its maps are not in the mesh's own UVs (see
                :class:`render.gpu_head.GpuHead`).
        """
        self.ctx = ctx
        self.shaders = shaders or ShaderLibrary()
        self.settings = RenderSettings()
        self.gpu_head = GpuHead(ctx, head, layout, alpha_mask=head.skin_mask)
        self.head = head
        self.camera = OrbitCamera.for_face(head.vertices, head.metadata.landmarks)
        self.lights: list[Light] = default_lights()
        self.environment: Environment | None = None
        self.km = KMTextureSpace(ctx, self.shaders, dtype=km_dtype)
        self.shadows = ShadowMaps(ctx, self.shaders, self.settings.shadow_size)
        self.irradiance = TextureIrradiance(ctx, self.shaders, self.settings.irradiance_size)
        self._irradiances: dict[int, TextureIrradiance] = {self.irradiance.size: self.irradiance}
        self.lighting = TextureLighting(ctx, self.shaders)
        # (irradiance key, irradiance_bound of it, whether its range needs the cache's half floats)
        self._bound: tuple[Any, np.ndarray, bool] | None = None
        #: a full frame whose cache level is out of date as a whole draws on the direct path and leaves the
        #: rebuild to :meth:`build_deferred_cache` (the studio's settle frames after a relight: the rebuild
        #: costs more than the direct path's extra, issue #13); False: the frame rebuilds it
        self.defer_cache = False
        self._deferred: tuple[Any, int] | None = None  # (irradiance key, level) left to build_deferred_cache
        self._density = TexelDensity(head.uv, head.vertices, head.faces)  # for the cache's level
        self.lit = LitPass(ctx, self.shaders, self.gpu_head, self.km, head.skin_mask is not None)
        self.sss = SSSPasses(ctx, self.shaders, self.gpu_head.mm_per_unit)
        self._composites: dict[tuple[int, int], moderngl.Program] = {}
        self._baseline: moderngl.Program | None = None
        self._cover: CoverMesh | None = None  # the head's convex hull for the composite (render.cover)
        self._cover_job: list[Any] | None = None  # [thread, result] while the hull is computed, [] after
        self._start_cover()
        self._lut_max = np.ones(MAX_LAYERS, np.float32)  # heat-map scale per layer (µm)
        self._targets: dict[str, Any] = {}  # textures and framebuffers by name (see _ensure_targets)
        self._target_sets: dict[tuple[int, int], dict[str, Any]] = {}  # by size, least recently used first
        self._size: tuple[int, int] = (0, 0)
        self.last = FrameInfo()

    # -- layers -----------------------------------------------------------------------------------
    def set_layers(self, layers: list[LayerInput]) -> None:
        """Replace the cosmetic layers (bottom first, at most 8) and evaluate them in texture space."""
        self.km.set_layers(layers)
        self._update_layer_tables()

    def _update_layer_tables(self) -> None:
        self._lut_max[:] = 1.0
        for slot, i in enumerate(self.km.active):
            mat = self.km.layers[i].material
            self._lut_max[slot] = float(getattr(mat, "max_thickness_um", 100.0) or 100.0)

    # -- the composite's cover --------------------------------------------------------------------
    def _start_cover(self) -> None:
        """Load the head's hull from the render cache (it is computed by :meth:`_compute_cover` otherwise)."""
        got = load_cover(self.gpu_head.vertices)
        if got is not None:
            self._cover = CoverMesh(self.ctx, *got)

    def _compute_cover(self) -> None:
        """Compute the hull on a background thread (scipy's import takes half a second).

        Started by the first frame that is not interactive, so it never delays a start-up's first frame;
        until the hull is there the composite draws the head itself (the same pixels, more triangles).
        """
        import threading

        job: list[Any] = []

        def run() -> None:
            try:
                job.append(compute_cover(self.gpu_head.vertices))
            except Exception:  # noqa: BLE001 — no hull (e.g. a flat mesh): the head stays the cover
                job.append(None)

        thread = threading.Thread(target=run, name="sheer-hull", daemon=True)
        self._cover_job = [thread, job]
        thread.start()

    def _composite_cover(self) -> CoverMesh | None:
        """The hull once the background job has made it (its GPU objects made here, on the GL thread)."""
        if self._cover is None and self._cover_job is None and not self.settings.interactive:
            self._compute_cover()
        if self._cover is None and self._cover_job:
            thread, job = self._cover_job
            if not thread.is_alive():
                self._cover_job = []
                if job and job[0] is not None:
                    self._cover = CoverMesh(self.ctx, *job[0])
        return self._cover

    # -- environment ------------------------------------------------------------------------------
    def set_environment(self, name_or_path: str | None, intensity: float = 0.5) -> None:
        """Ambient light from an HDR environment (sample name like ``"studio"`` or an EXR path)."""
        self.environment = None if name_or_path is None else Environment.load(name_or_path, intensity)

    # -- targets ----------------------------------------------------------------------------------
    def _ensure_targets(self, size: tuple[int, int]) -> None:
        """The frame's targets at ``size``, kept for the last :data:`KEPT_TARGET_SIZES` sizes.

        Progressive refinement alternates between an interactive (reduced) size and the full one: both
        sets stay, so neither is made again each time the view settles or starts moving.
        """
        if size == self._size:
            return
        sets = self._target_sets
        if size in sets:
            sets[size] = sets.pop(size)  # most recent last
        else:
            sets[size] = frame_targets(self.ctx, size)
            while len(sets) > KEPT_TARGET_SIZES:
                old_size = next(iter(sets))
                old = sets.pop(old_size)
                sets[size]["gbuffer"].use()  # never leave a freed framebuffer bound
                for obj in old.values():
                    obj.release()
        self._targets = sets[size]
        self._targets["gbuffer"].use()
        self._size = size

    # -- programs ---------------------------------------------------------------------------------
    def _irradiance_at(self, size: int) -> TextureIrradiance:
        """The texture-space irradiance of side ``size`` (texels), made on first use and kept."""
        if size not in self._irradiances:
            self._irradiances[size] = TextureIrradiance(self.ctx, self.shaders, size)
        return self._irradiances[size]

    def _composite_program(self, mode: int, debug: bool) -> moderngl.Program:
        """The composite specialised for an SSS mode (0 off, 1 reference, 2 fast) and debug views."""
        key = (mode, int(debug))
        if key not in self._composites:
            self._composites[key] = self.shaders.program(self.ctx, "composite.vert", "composite.frag",
                                                         {"MODE": mode, "DEBUG": int(debug)})
        return self._composites[key]

    _set = staticmethod(set_uniform)
    _write = staticmethod(write_uniform)

    # -- the frame --------------------------------------------------------------------------------
    def _screen_rect(self, view_proj: np.ndarray, size: tuple[int, int]) -> tuple[int, int, int, int]:
        v = self.head.vertices
        lo, hi = v.min(0), v.max(0)
        corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        c = corners @ view_proj.T
        w, h = size
        if np.any(c[:, 3] <= 1e-6):
            return (0, 0, w, h)
        ndc = c[:, :2] / c[:, 3:4]
        x0 = int(np.floor((ndc[:, 0].min() * 0.5 + 0.5) * w)) - 2
        x1 = int(np.ceil((ndc[:, 0].max() * 0.5 + 0.5) * w)) + 2
        y0 = int(np.floor((ndc[:, 1].min() * 0.5 + 0.5) * h)) - 2
        y1 = int(np.ceil((ndc[:, 1].max() * 0.5 + 0.5) * h)) + 2
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
        return (x0, y0, max(x1 - x0, 0), max(y1 - y0, 0))

    def _validate_lights(self) -> None:
        if len(self.lights) > MAX_LIGHTS:
            raise RenderError(f"at most {MAX_LIGHTS} lights, got {len(self.lights)}")
        for i, lt in enumerate(self.lights):
            lt.validate(f"light {i}")

    def render(self, fbo: moderngl.Framebuffer, viewport: tuple[int, int, int, int] | None = None) -> FrameInfo:
        """Render one frame into ``fbo`` (e.g. ``ctx.detect_framebuffer(...)``); leaves ``fbo`` bound.

        Args:
            fbo: the target; only its colour is written (sRGB-encoded unless ``settings.tonemap`` is
                ``"raw"``).
            viewport: (x, y, width, height) in pixels of ``fbo``, sides 1..16384; default all of it.

        Returns:
            What the frame used (size, matrices, the head's screen rectangle), also in :attr:`last`.
        """
        s = self.settings
        s.validate()
        self._validate_lights()
        vx, vy, w, h = viewport if viewport is not None else (0, 0, *fbo.size)
        self._ensure_targets((w, h))
        ctx = self.ctx
        aspect = w / h
        view = self.camera.view()
        view_proj = self.camera.projection(aspect) @ view
        rect = self._screen_rect(view_proj, (w, h))
        self.last = FrameInfo((w, h), view, view_proj, rect)

        irr_key = self._light(s)
        self._lit_pass(s, irr_key, view, view_proj, (w, h))
        self._compose(fbo, (vx, vy, w, h), rect)
        ctx.scissor = None
        fbo.scissor = None
        return self.last

    def _light(self, s: RenderSettings) -> Any:
        """Step 1: the shadow maps (cached until a light moves) and the texture-space irradiance; its key."""
        ctx = self.ctx
        if self.shadows.size != s.shadow_size:
            self.shadows.release()
            self.shadows = ShadowMaps(ctx, self.shaders, s.shadow_size)
        shadowed = [lt for lt in self.lights if lt.shadows]
        if shadowed:
            self.shadows.update(self.lights, self.gpu_head.centre, self.gpu_head.radius, self.gpu_head.draw)
        env = self.environment
        irr_key = (tuple((lt.kind, tuple(lt.vector), tuple(lt.colour), lt.intensity, lt.shadows,
                          lt.reference_distance) for lt in self.lights),
                   None if env is None else env.coefficients.tobytes(), s.normal_strength, s.pcf_radius,
                   s.shadow_size)
        # while a light is dragged (an interactive frame whose lights differ from the full-resolution
        # irradiance's), relight at half its side: a quarter of the texture-space pass
        size = s.irradiance_size
        if s.interactive and not self._irradiance_at(size).is_current(irr_key):
            size = max(size // 2, 64)
        self.irradiance = self._irradiance_at(size)

        def setup_irradiance(p: moderngl.Program) -> None:
            self.shadows.texture.use(U_SHADOW)
            self._set(p, "u_shadow", U_SHADOW)
            self._set(p, "u_normal_strength", float(s.normal_strength))
            self._upload_lights(p)

        self.irradiance.update(irr_key, self.gpu_head, setup_irradiance, self.lights, env is not None)
        return irr_key

    def _lit_pass(self, s: RenderSettings, irr_key: Any, view: np.ndarray, view_proj: np.ndarray,
                  size: tuple[int, int]) -> None:
        """Step 2: the texture-space lighting cache (view-independent terms), then the lit pass into the G-buffer."""
        w, h = size
        n = len(self.km.active)
        debug_on = DEBUG_VIEWS[s.debug_view] != 0
        cached = s.lighting_cache and self.gpu_head.paint_uv_is_mesh_uv and n > 0 and s.makeup and not debug_on
        if cached:
            # the cache's level whose texels match this frame's pixels
            level = level_for(max(self.lighting.target_size(self.km, self.gpu_head)),
                              self._density.median(view_proj, (w, h)), self.lighting.max_level(self.km, self.gpu_head))
            if s.interactive and self.lighting.needs_whole(self.irradiance, self.km, level):
                # an interactive frame never recomputes a level whole (while a light moves that would be
                # every frame): it takes the nearest level that is up to date, or draws on the direct path
                # until the view settles
                current = [lv for lv in range(MAX_CACHE_LEVEL + 1)
                           if not self.lighting.needs_whole(self.irradiance, self.km, lv)]
                cached = bool(current)
                level = min(current, key=lambda lv: abs(lv - level)) if current else level
            elif self.defer_cache and self.lighting.needs_whole(self.irradiance, self.km, level):
                cached, self._deferred = False, (irr_key, level)
        if cached:
            self._update_cache(irr_key, level)
        elif len(self.km.dirty_tiles) > 4096:  # long unused (direct path, bare skin, debug views)
            self.km.dirty_tiles = []
            self.lighting.invalidate()  # recomputed whole when it is used again
        self.lit.draw(self._targets["gbuffer"], (w, h), s, self.lights, view, view_proj, self.camera.eye(),
                      self.irradiance, self.lighting if cached else None, self._lut_max, self._upload_lights)


    def _compose(self, fbo: moderngl.Framebuffer, viewport: tuple[int, int, int, int],
                 rect: tuple[int, int, int, int]) -> None:
        """Steps 3-6: SSS, the composite and the display pass into ``fbo``'s ``viewport``."""
        s = self.settings
        vx, vy, w, h = viewport
        tonemap = {"raw": -1, "none": 0, "aces": 1}[s.tonemap]
        px_per_mm = h / (2.0 * math.tan(math.radians(self.camera.fov_y) / 2.0)) / self.gpu_head.mm_per_unit
        t = self._targets
        rx, ry, rw, rh = rect
        debug = DEBUG_VIEWS[s.debug_view]
        mode = 0
        w0: tuple[float, ...] = (1.0, 1.0, 1.0)
        accum = t["accum"]
        mm_per_px = (self.camera.distance * 2.0 * math.tan(math.radians(self.camera.fov_y) / 2.0) / h
                     * self.gpu_head.mm_per_unit)
        if debug == 0 and s.mode == "fast":
            # wide lobes on the half-resolution grid, the kernel's centre (c²·E) at full resolution
            mode = 2
            accum, w0 = self.sss.fast(t, s, rect, px_per_mm, mm_per_px)
        elif debug == 0 and s.mode == "reference":
            mode = 1
            accum, w0, whalf = self.sss.reference(t, s, rect, px_per_mm, mm_per_px)
            t["half_b"].use(4)
            cp = self._composite_program(mode, debug != 0)
            self._set(cp, "u_accum_half", 4)
            self._set(cp, "u_whalf", tuple(float(x) for x in whalf))
        cp = self._composite_program(mode, debug != 0)
        t["diffuse"].use(0)
        accum.use(1)
        t["factor"].use(3)
        for name, unit in (("u_src", 0), ("u_accum", 1), ("u_factor", 3)):
            self._set(cp, name, unit)
        self._set(cp, "u_w0", w0)
        self._set(cp, "u_mode", mode)
        self._set(cp, "u_origin", (int(vx), int(vy)))
        self._display_common(cp, tonemap, debug)
        self.draw_composite(fbo, (vx, vy, w, h), rect, cp)

    def _update_cache(self, irr_key: Any, level: int) -> bool:
        """Bring the lighting cache's ``level`` up to date with the irradiance of ``irr_key``."""
        if self._bound is None or self._bound[0] != irr_key:
            self._bound = (irr_key, *irradiance_encoding(self.lights, self.environment, self.gpu_head.vertices))
        _, bound, wide = self._bound
        return self.lighting.update(self.km, self.irradiance, self.gpu_head, bound, level, wide)

    def build_deferred_cache(self) -> bool:
        """Rebuild the cache level a :attr:`defer_cache` frame left out of date (call with the context current).

        Only while the full-size irradiance of that frame is still the current one (a light that moved
        since makes it moot). Returns True if anything was recomputed.
        """
        deferred, self._deferred = self._deferred, None
        if (deferred is None or self.irradiance.size != self.settings.irradiance_size
                or not self.irradiance.is_current(deferred[0])):
            return False
        return self._update_cache(*deferred)

    def _display_common(self, prog: moderngl.Program, tonemap: int, debug: int) -> None:
        self._targets["outer"].use(2)
        self._set(prog, "u_outer", 2)
        self._set(prog, "u_background", tuple(float(x) for x in self.settings.background))
        self._set(prog, "u_exposure", float(self.settings.exposure))
        self._set(prog, "u_tonemap", tonemap)
        self._set(prog, "u_debug", debug)

    def draw_composite(self, fbo: moderngl.Framebuffer, viewport: tuple[int, int, int, int],
                       rect: tuple[int, int, int, int], prog: moderngl.Program) -> None:
        """Clear ``fbo``'s viewport to the background, then run ``prog`` over the head's screen rectangle.

        The frame's composite and display pass (``sheer bench render`` times it on its own).
        """
        ctx = self.ctx
        vx, vy, w, h = viewport
        fbo.use()
        fbo.viewport = viewport
        bg = self.settings.background
        if self.settings.tonemap == "raw":
            enc = [float(c) for c in bg]
        else:
            enc = [srgb_encode_scalar(float(c)) for c in bg]
        ctx.scissor = viewport
        fbo.clear(enc[0], enc[1], enc[2], 1.0, viewport=viewport)
        rx, ry, rw, rh = rect
        ctx.scissor = (vx + rx, vy + ry, rw, rh)
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST)
        if rw > 0 and rh > 0:  # the head's pixels: its hull (or the head), the lit pass's transform, culling
            self._write(prog, "u_view_proj", self.last.view_proj.T.reshape(1, 16))
            # the cover's pixels that are not the head's show the background: exactly the clear's values
            self._set(prog, "u_clear_colour", tuple(enc[:3]))
            self._cull(True)
            cover = self._composite_cover()
            proj = self.camera.projection(w / h)
            near = float(proj[2, 3] / (proj[2, 2] - 1.0))
            if cover is not None and self.settings.cull_back_faces and cover.usable(
                    self.camera.eye(), self.last.view, near):
                cover.draw(prog)
            else:
                self.gpu_head.draw(prog)
            self._cull(False)
        ctx.scissor = None

    def _cull(self, on: bool) -> None:
        """Back-face culling for closed heads, if ``on`` and ``settings.cull_back_faces``.

        The mesh winds counter-clockwise like its normals: about halves the fragments shaded. Open meshes seen from behind need it off.
        """
        cull(self.ctx, on and self.settings.cull_back_faces)

    def _upload_lights(self, prog: moderngl.Program) -> None:
        upload_lights(prog, self.lights, self.shadows, self.settings.pcf_radius, self.environment)

    # -- baseline (benchmark) ---------------------------------------------------------------------
    def render_baseline(self, fbo: moderngl.Framebuffer, viewport: tuple[int, int, int, int] | None = None) -> None:
        """The benchmark baseline: same mesh and albedo, one Lambert light, no post-processing.

        Args:
            fbo: the target, with a depth attachment.
            viewport: (x, y, width, height) in pixels; default all of ``fbo``.
        """
        if self._baseline is None:
            self._baseline = self.shaders.program(self.ctx, "mesh.vert", "baseline.frag")
        vx, vy, w, h = viewport if viewport is not None else (0, 0, *fbo.size)
        prog = self._baseline
        fbo.use()
        fbo.viewport = (vx, vy, w, h)
        fbo.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
        self.ctx.enable(self.ctx.DEPTH_TEST)
        vp = self.camera.view_projection(w / h)
        self._write(prog, "u_view_proj", vp.T.reshape(1, 16))
        self._write(prog, "u_view", self.camera.view().T.reshape(1, 16))
        key = self.lights[0] if self.lights else Light()
        d = np.asarray(key.vector, float)
        self._set(prog, "u_light_dir", tuple(float(x) for x in d / np.linalg.norm(d)))
        self.gpu_head.albedo.use(0)
        self._set(prog, "u_albedo", 0)
        self._cull(True)
        self.gpu_head.draw(prog)
        self._cull(False)
        self.ctx.disable(self.ctx.DEPTH_TEST)

    # -- picking ----------------------------------------------------------------------------------
    def depth_at(self, x: int, y: int) -> float | None:
        """Window depth in [0, 1] of the last frame at pixel (x, y), origin top-left; None = background."""
        if "gbuffer" not in self._targets:
            return None
        return read_depth(self._targets["gbuffer"], x, y)

    def inverse_view_projection(self) -> np.ndarray:
        """Inverse of the last frame's view-projection matrix (4×4 float64, column vectors)."""
        return np.linalg.inv(self.last.view_proj)

    def unproject(self, x: float, y: float, depth: float) -> np.ndarray:
        """World point (mesh units) of pixel (x, y) (origin top-left, pixel centres at +0.5) at window depth."""
        from painting.hit import pixel_to_ndc, unproject

        w, h = self.last.size
        return unproject(pixel_to_ndc(x, y, w, h), depth, self.inverse_view_projection())

    def pick(self, x: int, y: int) -> np.ndarray | None:
        """The surface point (mesh units) under pixel (x, y) of the last frame, or None."""
        z = self.depth_at(x, y)
        return None if z is None else self.unproject(x, y, z)

    # -- convenience ------------------------------------------------------------------------------
    def render_image(self, size: tuple[int, int], linear: bool = False) -> np.ndarray:
        """Render to an offscreen target of ``size`` (width, height in pixels) and return the image.

        Returns:
            Top row first: uint8 (H, W, 3) sRGB, or float32 (H, W, 3) linear values if ``linear`` (sets
            ``tonemap='raw'`` for this frame).
        """
        w, h = size
        dtype = "f4" if linear else "f1"
        colour = self.ctx.texture((w, h), 4, dtype=dtype)
        fbo = self.ctx.framebuffer([colour])
        saved = self.settings.tonemap
        try:
            if linear:
                self.settings.tonemap = "raw"
            self.render(fbo, (0, 0, w, h))
            raw = fbo.read(components=3, dtype=dtype)
        finally:
            self.settings.tonemap = saved
            if "gbuffer" in self._targets:  # never leave a deleted framebuffer bound (moderngl re-binds it)
                self._targets["gbuffer"].use()
            fbo.release()
            colour.release()
        a = np.frombuffer(raw, np.float32 if linear else np.uint8).reshape(h, w, 3)
        return np.ascontiguousarray(a[::-1])

    def skin_pixel_mask(self) -> np.ndarray:
        """Bool (H, W), top row first: the last frame's skin pixels (before SSS; for tests and ΔE)."""
        tex = self._targets["diffuse"]
        w, h = tex.size
        a = np.frombuffer(tex.read(), np.float16).reshape(h, w, 4)[..., 3]
        return np.ascontiguousarray(a[::-1] > 0)

    def release(self) -> None:
        """Free every GPU object (call with this renderer's context current)."""
        objs: list[Any] = [*self._composites.values(),
                           *(o for t in self._target_sets.values() for o in t.values())]
        if self._baseline is not None:
            objs.append(self._baseline)
        from render.glutil import release_all

        release_all(self.ctx, objs)
        self._targets, self._target_sets = {}, {}
        self._size = (0, 0)
        self.lit.release()
        self.sss.release()
        self._composites = {}
        self.km.release()
        self.lighting.release()
        for irr in self._irradiances.values():
            irr.release()
        self._irradiances = {}
        self.shadows.release()
        if self._cover is not None:
            self._cover.release()
            self._cover = None
        self.gpu_head.release()
