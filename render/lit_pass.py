"""The frame's lit pass: the head drawn once into the G-buffer through the makeup, lit by the lights.

Step 2 of :class:`render.renderer.Renderer`'s frame, between the texture-space passes (KM, irradiance, the
lighting cache) it reads and the SSS passes that read its targets (diffuse, outer, factor and depth). The
program is specialised per frame shape (:meth:`LitPass.program`) and kept; :meth:`LitPass.draw` binds
every input and draws.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from render.glutil import set_uniform, write_uniform
from render.km_pass import MAX_LAYERS
from render.lights import rig_shape
from render.settings import DEBUG_VIEWS

if TYPE_CHECKING:
    from collections.abc import Callable

    import moderngl

    from render.gpu_head import GpuHead
    from render.irradiance import TextureIrradiance
    from render.km_pass import KMTextureSpace
    from render.lights import Light
    from render.lit_cache import TextureLighting
    from render.settings import RenderSettings
    from render.shaders import ShaderLibrary

# texture units of the lit pass (U_SHADOW: the shadow maps, bound for the irradiance pass too)
U_KM, U_SPEC0, U_THICK, U_SHADOW, U_LIT, U_SPEC1, U_IRR = 4, 8, 9, 17, 18, 24, 25

#: colour masks of the G-buffer's three targets: the clear writes the diffuse only, the lit pass all three
_DIFFUSE_ONLY = ((True,) * 4, (False,) * 4, (False,) * 4)
_ALL_THREE = ((True,) * 4,) * 3


def cull(ctx: moderngl.Context, on: bool) -> None:
    """Back-face culling on (counter-clockwise front faces, like the head's normals) or off."""
    if on:
        ctx.front_face = "ccw"
        ctx.cull_face = "back"
        ctx.enable(ctx.CULL_FACE)
    else:
        ctx.disable(ctx.CULL_FACE)


def frame_defines(n: int, rig: tuple[int, int, int], makeup: bool, debug: bool, cached: bool,
                  has_spec_map: bool, has_rough_map: bool, has_skin_mask: bool) -> dict[str, int]:
    """The defines of ``frame.frag`` for one frame shape (see :meth:`LitPass.program`).

    Args:
        n: active layers, 0..:data:`render.km_pass.MAX_LAYERS`.
        rig: the lights' :func:`render.lights.rig_shape`.
        makeup: the layers are drawn (needs ``n`` > 0).
        debug: the debug views are compiled in.
        cached: the lit pass reads the lighting cache (needs makeup, no debug view).
        has_spec_map: the head has a specular-intensity map.
        has_rough_map: the head has a roughness map.
        has_skin_mask: the head has a skin mask.
    """
    count, shadowed, points = rig
    return {"NL": n, "NLIGHTS": count, "MAKEUP": int(makeup), "DEBUG": int(debug), "CACHED": int(cached),
            "SHADOWED": shadowed, "POINT_LIGHTS": points, "HAS_SPEC_MAP": int(has_spec_map),
            "HAS_ROUGH_MAP": int(has_rough_map), "HAS_SKIN_MASK": int(has_skin_mask)}


class LitPass:
    """The lit pass of one head: its programs (by frame shape) and the draw into the G-buffer."""

    def __init__(self, ctx: moderngl.Context, shaders: ShaderLibrary, gpu_head: GpuHead, km: KMTextureSpace,
                 has_skin_mask: bool) -> None:
        """Keep what every frame's lit pass reads.

        Args:
            ctx: the GL context.
            shaders: where the GLSL files come from.
            gpu_head: the head's GPU mesh and maps.
            km: the texture-space KM pass (its active layers are the makeup drawn).
            has_skin_mask: whether the head has a skin mask (compiled in).
        """
        self.ctx = ctx
        self.shaders = shaders
        self.gpu_head = gpu_head
        self.km = km
        self.has_skin_mask = has_skin_mask
        self._programs: dict[tuple[int, ...], moderngl.Program] = {}

    def program(self, n: int, lights: list[Light], makeup: bool = True, debug: bool = True,
                cached: bool = False) -> moderngl.Program:
        """The lit pass for ``n`` layers and the ``lights`` (both loops unroll at compile time).

        Makeup, debug views, the head's optional maps, which lights cast shadows and which are point
        lights are compiled in or out: llvmpipe executes both sides of a branch, so a uniform switch
        would not save their texture fetches or maths.
        """
        gh = self.gpu_head
        rig = rig_shape(lights)
        key = (n, *rig, int(makeup), int(debug), int(cached))
        if key not in self._programs:
            self._programs[key] = self.shaders.program(
                self.ctx, "mesh.vert", "frame.frag",
                frame_defines(n, rig, makeup, debug, cached, gh.has_specular_map, gh.has_roughness_map,
                              self.has_skin_mask))
        return self._programs[key]

    def draw(self, gbuffer: moderngl.Framebuffer, size: tuple[int, int], settings: RenderSettings,
             lights: list[Light], view: np.ndarray, view_proj: np.ndarray, eye: np.ndarray,
             irradiance: TextureIrradiance, lighting: TextureLighting | None, lut_max: np.ndarray,
             upload_lights: Callable[[moderngl.Program], None]) -> None:
        """Clear the G-buffer and draw the head into it.

        Args:
            gbuffer: the frame's G-buffer (diffuse, outer, factor and depth).
            size: its (width, height) in pixels.
            settings: the frame's settings.
            lights: the lights (at most :data:`render.lights.MAX_LIGHTS`).
            view: the camera's view matrix (4×4, column vectors).
            view_proj: projection @ view (4×4).
            eye: the camera's position (mesh units).
            irradiance: the texture-space irradiance, up to date.
            lighting: the lighting cache to fetch (up to date at the frame's level), or None for the direct
                path.
            lut_max: the heat-map scale per active layer (µm), :data:`render.km_pass.MAX_LAYERS` long.
            upload_lights: writes the lights' uniforms into a program.
        """
        s, km, ctx = settings, self.km, self.ctx
        n = len(km.active)
        cached = lighting is not None
        prog = self.program(n, lights, s.makeup and n > 0, DEBUG_VIEWS[s.debug_view] != 0, cached)
        w, h = size
        # only the diffuse (read around the head by the SSS taps, the mask and the composite) and the depth
        # are cleared: outer and factor are read only where the diffuse says the head is, which this pass
        # writes (a third of the clear's cost). Cleared through the G-buffer itself with the other two
        # masked, so that clear and draw are one llvmpipe scene (a framebuffer change ends a scene).
        gb = gbuffer
        gb.color_mask = _DIFFUSE_ONLY
        gb.use()
        gb.viewport = (0, 0, w, h)
        gb.scissor = None
        ctx.scissor = None
        gb.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        gb.color_mask = _ALL_THREE
        gb.use()
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.BLEND)
        cull(ctx, s.cull_back_faces)
        self.gpu_head.bind_textures(0)
        km.bind(U_KM)
        km.bind_spec(U_SPEC0, U_SPEC1)
        for slot in range(n):
            km.thickness_textures[slot].use(U_THICK + slot)
        for j, tex in enumerate(irradiance.textures):
            tex.use(U_IRR + j)
        if lighting is not None:
            lighting.bind(U_LIT)
        units = {"u_albedo": 0, "u_normal_map": 1, "u_spec_map": 2, "u_rough_map": 3, "u_rtop": U_KM,
                 "u_trans": U_KM + 1, "u_rbottom": U_KM + 2, "u_spec0": U_SPEC0, "u_spec1": U_SPEC1,
                 "u_irr": U_IRR, "u_vis0": U_IRR + 1, "u_vis1": U_IRR + 2, "u_lit_diffuse": U_LIT,
                 "u_lit_outer": U_LIT + 1, "u_lit_factor": U_LIT + 2, "u_lit_trans": U_LIT + 3,
                 "u_lit_spec": U_LIT + 4}
        for name, unit in units.items():
            set_uniform(prog, name, unit)
        if n and "u_layer_thick" in prog:
            u = prog["u_layer_thick"]
            u.value = list(range(U_THICK, U_THICK + u.array_length)) if u.array_length > 1 else U_THICK
        write_uniform(prog, "u_view_proj", view_proj.T.reshape(1, 16))
        write_uniform(prog, "u_view", view.T.reshape(1, 16))
        set_uniform(prog, "u_eye", tuple(float(x) for x in eye))
        set_uniform(prog, "u_normal_strength", float(s.normal_strength))
        set_uniform(prog, "u_skin_roughness", float(s.skin_roughness))
        set_uniform(prog, "u_skin_f0", float(s.skin_f0))
        set_uniform(prog, "u_spec_intensity", float(s.spec_intensity))
        set_uniform(prog, "u_layer_spec_intensity", float(s.layer_spec_intensity))
        set_uniform(prog, "u_light_spread", math.radians(float(s.light_radius_deg)) ** 2 / 8.0)
        set_uniform(prog, "u_makeup_on", 1.0 if s.makeup and n > 0 else 0.0)
        if lighting is not None:
            set_uniform(prog, "u_lit_scale", tuple(float(x) for x in lighting.scale))
        gh = self.gpu_head
        set_uniform(prog, "u_has_maps", (int(gh.has_specular_map), int(gh.has_roughness_map),
                                         int(self.has_skin_mask)))
        set_uniform(prog, "u_debug", DEBUG_VIEWS[s.debug_view])
        set_uniform(prog, "u_debug_layer", int(s.debug_layer))
        write_uniform(prog, "u_layer_spec", km.layer_spec)
        write_uniform(prog, "u_layer_inv_m2", 1.0 / np.maximum(km.layer_spec[:, 0], 0.05) ** 2)
        write_uniform(prog, "u_lut_max", lut_max)
        opac = np.zeros(MAX_LAYERS, np.float32)
        for slot, i in enumerate(km.active):
            opac[slot] = km.layers[i].opacity
        write_uniform(prog, "u_opacity", opac)
        upload_lights(prog)
        gh.draw(prog)
        ctx.disable(ctx.DEPTH_TEST)
        cull(ctx, False)

    def release(self) -> None:
        """Free the programs (call with the context current)."""
        from render.glutil import release_all

        release_all(self.ctx, self._programs.values())
        self._programs = {}
