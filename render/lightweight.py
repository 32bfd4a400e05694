"""The lightweight engine (Paris et al. 2003, §5): a captured face rendered fast under any lights.

Per light, Phong with the fitted skin parameters (:mod:`capture.phong`), evaluated per vertex as the
paper's fixed-function ``GL_LIGHTING`` did (the fragment shader only fetches the detail texture and one
shadow comparison per light: on llvmpipe that is what keeps 8 lights within a few baseline frames), shadow maps (the physical
renderer's :class:`render.lights.ShadowMaps`, PCF), up to 8 lights and optional SH environment irradiance
(:class:`render.lights.Environment`), then the detail texture modulates the result and the sensor clamp
comes last — so overexposure loses the detail in the highlights, as the paper's Fig. 10a. The paper's
[0, 2ⁿ] texture range with n doubling passes is replaced by a float texture (one pass).

Eye highlights: two purely specular hemispheres of the cornea's 7.8 mm radius (converted with the
head's mm per unit) at the ``left_eye``/``right_eye`` landmarks, exponent 500, added on top of the
face's display value.

Cosmetic layers: the skin albedo is detail × fitted diffuse; the texture-space KM outputs of the
physical renderer (:class:`render.km_pass.KMTextureSpace`: R_top, T, R_bottom) apply as there:
diffuse out = E·(R_top + a·T² / (1 − R_bottom·a)), the skin's specular attenuated by T², and — when the
makeup is a KM pass (it has ``bind_spec``) — the layers' own Kelemen lobes per pixel and light, as the
physical renderer adds them (``km_compose.glsl``; shadowed per pixel only in the per-pixel shadow mode).

Reuses: :class:`render.gpu_head.GpuHead` (mesh upload), :class:`render.shaders.ShaderLibrary`
(``lighting.glsl``, ``common.glsl``), :class:`render.camera.OrbitCamera`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from render.camera import OrbitCamera
from render.errors import RenderError
from render.glutil import set_uniform, write_uniform
from render.gpu_head import GpuHead
from render.lights import MAX_LIGHTS, Environment, Light, ShadowMaps, upload_lights
from render.settings import RenderSettings
from render.shaders import ShaderLibrary

if TYPE_CHECKING:
    import moderngl

    from painting.head import Head
    from render.captured import CapturedFace

#: Cornea radius (Wyszecki & Stiles, via the paper), millimetres.
CORNEA_RADIUS_MM = 7.8
EYE_SHININESS = 500.0


def hemisphere(radius: float, rings: int = 8, segments: int = 32) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A +Z hemisphere mesh: (vertices (N, 3), normals (N, 3), faces (F, 3)); 8×32 → 257 vertices."""
    verts = [np.array([0.0, 0.0, 1.0])]
    for r in range(1, rings + 1):
        th = (np.pi / 2) * r / rings
        for s in range(segments):
            ph = 2 * np.pi * s / segments
            verts.append(np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)]))
    v = np.asarray(verts)
    faces = [[0, 1 + s, 1 + (s + 1) % segments] for s in range(segments)]
    for r in range(1, rings):
        a0 = 1 + (r - 1) * segments
        b0 = 1 + r * segments
        for s in range(segments):
            s1 = (s + 1) % segments
            faces.append([a0 + s, b0 + s, b0 + s1])
            faces.append([a0 + s, b0 + s1, a0 + s1])
    return v * radius, v.copy(), np.asarray(faces, dtype=np.int64)


def upload_layer_lobes(prog: moderngl.Program, km: Any, rho: float) -> None:
    """Upload the layers' specular parameters of a :class:`render.km_pass.KMTextureSpace` for ``km_compose.glsl``.

    ``u_layer_spec`` (roughness, F0, smooths skin, coverage scale per active layer), ``u_layer_inv_m2``
    (1 / max(roughness, 0.05)²) and ``u_rho`` (ρ_s, the lobes' intensity).
    """
    spec = np.zeros((8, 4), np.float32)
    n = min(len(km.active), 8)
    spec[:n] = km.layer_spec[:n]
    write_uniform(prog, "u_layer_spec", spec)
    write_uniform(prog, "u_layer_inv_m2", (1.0 / np.maximum(spec[:, 0], 0.05) ** 2).astype(np.float32))
    set_uniform(prog, "u_rho", float(rho))


def face_defines(n_lights: int, shadows: int, env: bool, makeup: bool, lobes: int = 0) -> dict[str, int]:
    """The defines of the lightweight face program (see :meth:`LightweightRenderer.program_for`).

    ``n_lights`` 0..:data:`render.lights.MAX_LIGHTS`; ``shadows`` 0 off, 1 per pixel, 2 per vertex;
    ``lobes`` the layers' own specular lobes, 0..8, with ``makeup`` only.
    """
    return {"LW_NLIGHTS": n_lights, "LW_SHADOWS": int(shadows), "LW_ENV": int(env), "LW_MAKEUP": int(makeup),
            "LW_NL": int(lobes) if makeup else 0}


class LightweightRenderer:
    """The lightweight engine for one captured face on a ``moderngl.Context``.

    The face is a :class:`render.captured.CapturedFace` (its ``params`` and ``detail`` are read).

    Attributes (set, then :meth:`render`): ``camera`` (:class:`OrbitCamera`), ``lights`` (≤ 8
    :class:`Light`; intensities in the photograph's units, 1 = the capture's flash), ``environment``,
    ``exposure``, ``ambient`` (None: the capture's k·A), ``shadows_on``, ``eye_highlights``, ``makeup`` (an object with ``bind(unit)`` binding
    R_top, T, R_bottom — e.g. a :class:`render.km_pass.KMTextureSpace` — or None).
    """

    def __init__(self, ctx: moderngl.Context, head: Head, face: CapturedFace,
                 shaders: ShaderLibrary | None = None, shadow_size: int = 512) -> None:
        self.ctx = ctx
        self.head = head
        self.face = face
        self.shaders = shaders or ShaderLibrary()
        self.gpu_head = GpuHead(ctx, head)
        self.camera = OrbitCamera.for_face(head.vertices, head.metadata.landmarks)
        p = face.params
        self.lights: list[Light] = [Light("directional", (0.0, 0.0, 1.0), tuple(float(x) for x in p.flash_rgb),
                                          1.0, True)]
        self.environment: Environment | None = None
        self.exposure = 1.0
        self.shadows_on = True
        self.eye_highlights = True
        self.makeup: Any = None
        #: the scale of the layers' own specular lobes (the physical renderer's default: 1, their Fresnel reflection)
        self.layer_spec_intensity = RenderSettings().layer_spec_intensity
        #: linear RGB ambient irradiance (photograph units) instead of the capture's k·A, or None
        self.ambient: tuple[float, float, float] | None = None
        self.pcf_radius = 2.5
        self.cull_back_faces = True
        #: lay down depth first, then shade each visible pixel once; None = when ≥ 2 lights cast per-pixel
        #: shadows
        self.depth_prepass: bool | None = None
        #: "pixel" (one PCF tap per pixel and light), "vertex" (per vertex, interpolated: soft, and what
        #: keeps 8 shadowed lights near the frame-time target on llvmpipe) or "auto" (pixel for ≤ 2
        #: shadowed lights, vertex above)
        self.shadow_mode = "auto"
        self.depth_program = self.shaders.program(ctx, "shadow.vert", "shadow.frag")
        self._programs: dict[tuple[int, int, int, int, int], Any] = {}
        self.eye_program = self.shaders.program(ctx, "lightweight_eye.vert", "lightweight_eye.frag")
        self.shadows = ShadowMaps(ctx, self.shaders, shadow_size)
        # Half floats (RGBA16F): [0, 8] with 11 bits of mantissa, and llvmpipe fetches them faster than RGB32F.
        det = np.asarray(face.detail, dtype=np.float32)
        det = np.ascontiguousarray(np.concatenate([det, np.ones(det.shape[:2] + (1,), np.float32)], axis=2),
                                   dtype=np.float16)
        self.detail = ctx.texture((det.shape[1], det.shape[0]), 4, det.tobytes(), dtype="f2")
        self.detail.filter = (ctx.LINEAR, ctx.LINEAR)
        self._dummy = ctx.texture((1, 1), 4, np.zeros(4, np.float32).tobytes(), dtype="f4")
        self._eyes = self._eye_geometry()
        self._offscreen: tuple[Any, Any, Any] | None = None

    def _eye_geometry(self) -> Any:
        lm = self.head.metadata.landmarks
        if "left_eye" not in lm or "right_eye" not in lm:
            return None
        r = CORNEA_RADIUS_MM / float(self.head.mm_per_unit)
        v, n, f = hemisphere(r)
        verts, norms, faces = [], [], []
        for k, name in enumerate(("left_eye", "right_eye")):
            # The sphere's front touches the landmark (on the lid/cornea surface), lifted by 0.3 mm so
            # it wins the depth test against the lid it sits on.
            centre = np.asarray(lm[name], float) - np.array([0.0, 0.0, r]) + np.array([0.0, 0.0, 0.3 / self.head.mm_per_unit])
            verts.append(v + centre)
            norms.append(n)
            faces.append(f + k * len(v))
        vb = self.ctx.buffer(np.concatenate(verts).astype("f4").tobytes())
        nb = self.ctx.buffer(np.concatenate(norms).astype("f4").tobytes())
        ib = self.ctx.buffer(np.concatenate(faces).astype("u4").tobytes())
        vao = self.ctx.vertex_array(self.eye_program, [(vb, "3f", "in_position"), (nb, "3f", "in_normal")], ib)
        return (vao, vb, nb, ib)

    _set = staticmethod(set_uniform)
    _write = staticmethod(write_uniform)

    def program_for(self, n_lights: int, shadows: int, env: bool, makeup: bool, lobes: int = 0) -> moderngl.Program:
        """The face program specialised for this configuration (compiled once, cached).

        ``n_lights`` 0..8; ``shadows`` 0 (off), 1 (per pixel) or 2 (per vertex); ``lobes``: the cosmetic
        layers whose own specular lobes are added (0..8, with ``makeup``).
        """
        defines = face_defines(n_lights, shadows, env, makeup, lobes)
        key = tuple(defines.values())
        prog = self._programs.get(key)
        if prog is None:
            prog = self.shaders.program(self.ctx, "lightweight_face.vert", "lightweight_face.frag", defines)
            self._programs[key] = prog
        return prog

    def _upload_lights(self, prog: moderngl.Program) -> None:
        if len(self.lights) > MAX_LIGHTS:
            raise RenderError(f"the lightweight engine takes at most {MAX_LIGHTS} lights, got {len(self.lights)}")
        for i, lt in enumerate(self.lights):
            lt.validate(f"light {i + 1}")
        upload_lights(prog, self.lights, self.shadows, self.pcf_radius, self.environment, self.shadows_on)

    def shadows_in_use(self) -> str:
        """How a frame with the current lights compares shadows: ``"off"``, ``"pixel"`` or ``"vertex"``.

        ``shadow_mode`` resolved: ``"auto"`` is per pixel for at most 2 shadowed lights, per vertex above.

        Raises:
            RenderError: an unknown ``shadow_mode``.
        """
        n_shadowed = sum(1 for lt in self.lights if lt.shadows) if self.shadows_on else 0
        mode = self.shadow_mode if self.shadow_mode != "auto" else ("pixel" if n_shadowed <= 2 else "vertex")
        if mode not in ("pixel", "vertex"):
            raise RenderError(f"shadow_mode must be 'auto', 'pixel' or 'vertex', got {self.shadow_mode!r}")
        return "off" if n_shadowed == 0 else mode

    def render(self, fbo: moderngl.Framebuffer, viewport: tuple[int, int, int, int] | None = None) -> None:
        """Draw a frame into ``fbo`` (which needs a depth attachment)."""
        ctx = self.ctx
        vx, vy, w, h = viewport if viewport is not None else (0, 0, *fbo.size)
        if len(self.lights) <= MAX_LIGHTS and self.shadows_on and any(lt.shadows for lt in self.lights):
            self.shadows.update(self.lights, self.gpu_head.centre, self.gpu_head.radius, self.gpu_head.draw)
        fbo.use()
        fbo.viewport = (vx, vy, w, h)
        fbo.clear(0.045, 0.047, 0.052, 1.0, depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.BLEND | ctx.CULL_FACE)
        if self.cull_back_faces:  # the head is closed and wound counter-clockwise
            ctx.cull_face = "back"
            ctx.enable(ctx.CULL_FACE)
        if len(self.lights) > MAX_LIGHTS:
            raise RenderError(f"the lightweight engine takes at most {MAX_LIGHTS} lights, got {len(self.lights)}")
        shadows = ("off", "pixel", "vertex").index(self.shadows_in_use())  # 0 off, 1 per pixel, 2 per vertex
        n_shadowed = sum(1 for lt in self.lights if lt.shadows) if self.shadows_on else 0
        lobes = len(getattr(self.makeup, "active", ())) if hasattr(self.makeup, "bind_spec") else 0
        prog = self.program_for(len(self.lights), shadows, self.environment is not None, self.makeup is not None,
                                lobes)
        vp = self.camera.view_projection(w / h)
        eye = tuple(float(x) for x in self.camera.eye())
        self._write(prog, "u_view_proj", vp.T.reshape(1, 16))
        p = self.face.params
        self._set(prog, "u_diffuse", tuple(float(x) for x in p.diffuse))
        self._set(prog, "u_spec", float(p.specular))
        self._set(prog, "u_shininess", float(p.exponent))
        ambient = p.ambient_scale * np.asarray(p.ambient_rgb) if self.ambient is None else self.ambient
        self._set(prog, "u_ambient", tuple(float(x) for x in ambient))
        self._set(prog, "u_eye", eye)
        self._set(prog, "u_exposure", float(self.exposure))
        self._upload_lights(prog)
        self.detail.use(0)
        self._set(prog, "u_detail", 0)
        if self.makeup is not None:
            self.makeup.bind(1)
        else:
            for u in (1, 2, 3):
                self._dummy.use(u)
        self._set(prog, "u_r_top", 1)
        self._set(prog, "u_transmittance", 2)
        self._set(prog, "u_r_bottom", 3)
        self.shadows.texture.use(4)
        self._set(prog, "u_shadow", 4)
        if lobes:
            upload_layer_lobes(prog, self.makeup, self.layer_spec_intensity)
            self.makeup.bind_spec(5, 6)
            self._set(prog, "u_spec0", 5)
            self._set(prog, "u_spec1", 6)
            self._set(prog, "u_eye", eye)
        prepass = self.depth_prepass
        if prepass is None:
            prepass = shadows == 1 and n_shadowed >= 2
        if prepass:
            # Early depth: lay down depth cheaply, then shade each visible pixel once (depth "==").
            fbo.color_mask = (False, False, False, False)
            self._write(self.depth_program, "u_mvp", vp.T.reshape(1, 16))
            self.gpu_head.draw(self.depth_program)
            fbo.color_mask = (True, True, True, True)
            ctx.depth_func = "<="
        self.gpu_head.draw(prog)
        ctx.depth_func = "<"
        if self.eye_highlights and self._eyes is not None:
            ep = self.eye_program
            self._write(ep, "u_view_proj", vp.T.reshape(1, 16))
            self._set(ep, "u_eye", eye)
            self._set(ep, "u_shininess", EYE_SHININESS)
            self._set(ep, "u_exposure", float(self.exposure))
            self._upload_lights(ep)
            self._set(ep, "u_shadow", 4)  # a shadow sampler must not sit on a colour texture's unit
            ctx.enable(ctx.BLEND)
            ctx.blend_func = ctx.ONE, ctx.ONE
            ctx.depth_func = "<="
            self._eyes[0].render()
            ctx.depth_func = "<"
            ctx.disable(ctx.BLEND)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE)

    def render_image(self, size: tuple[int, int]) -> np.ndarray:
        """Render ``size`` (width, height in pixels) offscreen and return uint8 sRGB (H, W, 3), top row first.

        The offscreen target is kept for the next call of the same size.
        """
        if self._offscreen is None or self._offscreen[0].size != tuple(size):
            self._release_offscreen()
            w, h = size
            color = self.ctx.renderbuffer((w, h), 4)
            depth = self.ctx.depth_renderbuffer((w, h))
            self._offscreen = (self.ctx.framebuffer(color_attachments=[color], depth_attachment=depth),
                               color, depth)
        fbo = self._offscreen[0]
        self.render(fbo)
        raw = fbo.read(components=3)
        w, h = size
        return np.frombuffer(raw, np.uint8).reshape(h, w, 3)[::-1].copy()

    def _release_offscreen(self) -> None:
        if self._offscreen is not None:
            # moderngl re-binds the last used framebuffer when it creates one: never leave a deleted one bound
            self.ctx.detect_framebuffer(0).use()
            for obj in self._offscreen:
                obj.release()
            self._offscreen = None

    def release(self) -> None:
        """Release every GPU object this engine owns."""
        # moderngl re-binds the last used framebuffer when it creates one: never leave a deleted one bound.
        self.ctx.detect_framebuffer(0).use()
        self._release_offscreen()
        if self._eyes is not None:
            for obj in self._eyes:
                obj.release()
            self._eyes = None
        for obj in (*self._programs.values(), self.eye_program, self.depth_program, self.detail, self._dummy):
            obj.release()
        self._programs.clear()
        self.shadows.release()
        self.gpu_head.release()
