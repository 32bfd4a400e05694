"""The frame: shadow maps → lit pass through the makeup → SSS (fast or reference) → composite → display.

See :mod:`render` for the API. One :class:`Renderer` per head and GL context; it owns every GPU object
it creates and frees them in :meth:`Renderer.release`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from render.camera import OrbitCamera
from render.errors import RenderError
from render.glutil import set_uniform, write_uniform
from render.gpu_head import GpuHead
from render.km_pass import MAX_LAYERS, KMTextureSpace, LayerInput
from render.lights import MAX_LIGHTS, Environment, Light, ShadowMaps, default_lights, upload_lights
from render.shaders import ShaderLibrary

#: Debug views (``RenderSettings.debug_view``) → shader code.
DEBUG_VIEWS: dict[str, int] = {
    "none": 0, "albedo": 1, "thickness": 2, "r_top": 3, "transmittance": 4, "irradiance": 5, "unlit": 6,
}
MODES = ("fast", "reference", "off")
FAST_TAPS = (11, 17, 25)

#: d'Eon et al. 2007 (GPU Gems 3 ch. 14): the skin diffusion profile as a sum of Gaussians,
#: (variance mm², R, G, B weights). Each column sums to 1.
SKIN_GAUSSIANS: tuple[tuple[float, float, float, float], ...] = (
    (0.0064, 0.233, 0.455, 0.649),
    (0.0484, 0.100, 0.336, 0.344),
    (0.187, 0.118, 0.198, 0.0),
    (0.567, 0.113, 0.007, 0.007),
    (1.99, 0.358, 0.004, 0.0),
    (7.41, 0.078, 0.0, 0.0),
)
REFERENCE_TAPS = 13


def reference_taps(sigma_texels: float) -> int:
    """Taps of one reference-mode Gaussian pass (odd, 5..REFERENCE_TAPS): enough to space them at most one
    source texel apart over ±3σ, with a 25 % margin for the nearer parts of the face. Taps closer than a
    texel would re-read the same bilinear interpolation: a narrow Gaussian costs fewer taps, not less
    accuracy (the kernel is normalised by its tap weights either way).
    """
    n = int(math.ceil(6.0 * max(sigma_texels, 0.0) * 1.25)) + 1
    n += 1 - n % 2
    return max(5, min(REFERENCE_TAPS, n))

# texture units of the lit pass
_U_KM, _U_SPEC0, _U_THICK, _U_SHADOW, _U_SPEC1, _U_IRR = 4, 8, 9, 17, 24, 25
#: NDC depth of an SSS pass's triangle against sss_mask.frag's classes (skin 0.25, head 0.5, background 1
#: as window depth): _Z_HEAD (window 0.75) passes on the head, _Z_SKIN (0.375) on skin only
_Z_HEAD, _Z_SKIN = 0.5, -0.25


class TextureIrradiance:
    """Diffuse irradiance (lights with PCF shadows + SH environment, normal-mapped) in the head's texture
    space, plus each light's shadow visibility for the specular term. Lights are fixed to the head, so
    this is recomputed only when the lights, the environment or the normal strength change (orbiting the
    camera or painting reuses it); each frame then fetches E instead of shading lights and shadows per
    pixel. ``version`` counts recomputations.

    Texels outside the UV charts are padded in one gather pass: each copies its nearest covered texel
    (Euclidean, from scipy's distance transform of the first computation's coverage; the charts depend
    only on the mesh, so the index map is made once). Before, four 3×3 dilation passes cost most of a
    relight (each texel 30 fetches per pass); now the padding is one pass of four fetches per texel and
    reaches every texel, so no sampling footprint finds background.
    """

    def __init__(self, ctx: Any, shaders: ShaderLibrary, size: int = 1024) -> None:
        self.ctx = ctx
        self.size = size
        self.shaders = shaders
        self.programs: dict[tuple[int, ...], Any] = {}
        self.gather = shaders.program(ctx, "fullscreen.vert", "pad_gather.frag")
        self.gather_quad = ctx.vertex_array(self.gather, [])
        self.index: Any = None  # RG32I texture: source texel of every texel (see the class docstring)
        self.sets = []
        for _ in range(2):
            texs = [ctx.texture((size, size), 4, dtype="f2"), ctx.texture((size, size), 4),
                    ctx.texture((size, size), 4)]
            for t in texs:
                t.repeat_x = t.repeat_y = False
                t.filter = (ctx.LINEAR, ctx.LINEAR)
            self.sets.append((texs, ctx.framebuffer(texs)))
        self.current = 0
        self._key: Any = None
        self.version = 0

    @property
    def textures(self) -> list[Any]:
        return self.sets[self.current][0]

    def _make_index(self, uv_key: str) -> None:
        """The nearest covered texel of every texel, from the coverage (alpha) of the raw irradiance; kept
        on disk per mesh footprint and size (scipy's distance transform plus the read-back take about
        0.6 s of a start-up).
        """
        from core.cache import cache_dir, save_array

        n = self.size
        path = cache_dir("render") / f"pad-index-{uv_key}-{n}-v1.npy"
        idx = None
        try:
            idx = np.load(path, allow_pickle=False)
            if idx.shape != (n, n, 2) or idx.dtype != np.int32 or idx.min() < 0 or idx.max() >= n:
                idx = None
        except (OSError, ValueError, EOFError):
            idx = None
        if idx is None:
            from scipy.ndimage import distance_transform_edt

            alpha = np.frombuffer(self.sets[0][0][2].read(), np.uint8).reshape(n, n, 4)[..., 3]  # irradiance.frag
            covered = alpha > 0
            if covered.any():
                iy, ix = distance_transform_edt(~covered, return_distances=False, return_indices=True)
            else:
                iy, ix = np.mgrid[0:n, 0:n]
            idx = np.ascontiguousarray(np.stack([ix, iy], axis=-1).astype(np.int32))
            save_array(path, idx)
        self.index = self.ctx.texture((n, n), 2, idx.tobytes(), dtype="i4")
        self.index.filter = (self.ctx.NEAREST, self.ctx.NEAREST)

    def program(self, lights: list[Light], env: bool) -> Any:
        """irradiance.frag specialised on the light count, which lights cast shadows and which are point
        lights, and whether there is an environment (loops unroll; nothing is computed for what is off).
        """
        key = (len(lights), sum(1 << i for i, lt in enumerate(lights) if lt.shadows),
               sum(1 << i for i, lt in enumerate(lights) if lt.kind != "directional"), int(env))
        if key not in self.programs:
            self.programs[key] = self.shaders.program(
                self.ctx, "uvspace.vert", "irradiance.frag",
                {"NLIGHTS": key[0], "SHADOWED": key[1], "POINT_LIGHTS": key[2], "ENV": key[3]})
        return self.programs[key]

    def update(self, key: Any, gpu_head: GpuHead, setup: Any, lights: list[Light], env: bool) -> bool:
        """Recompute if ``key`` changed; ``setup(program)`` sets the lighting uniforms. Returns True if
        it recomputed.
        """
        if key == self._key:
            return False
        self._key = key
        ctx = self.ctx
        texs, fbo = self.sets[0]
        fbo.use()
        fbo.viewport = (0, 0, self.size, self.size)
        ctx.scissor = None
        fbo.clear(0.0, 0.0, 0.0, 0.0)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        prog = self.program(lights, env)
        setup(prog)
        gpu_head.normal.use(1)
        prog["u_normal_map"].value = 1
        gpu_head.draw(prog)
        if self.index is None:
            self._make_index(gpu_head.uv_key)
        self.index.use(3)
        for i, t in enumerate(texs):
            t.use(i)
        for i in range(3):
            self.gather[f"u_src{i}"].value = i
        self.gather["u_index"].value = 3
        self.sets[1][1].use()
        self.sets[1][1].viewport = (0, 0, self.size, self.size)
        self.gather_quad.render(vertices=3)
        self.current = 1
        self.version += 1
        return True

    def invalidate(self) -> None:
        self._key = None

    def release(self) -> None:
        from render.glutil import release_all

        release_all(self.ctx, [o for texs, fbo in self.sets for o in (fbo, *texs)]
                    + [self.gather_quad, self.gather, *self.programs.values(), self.index])
        self.programs = {}


@dataclass
class RenderSettings:
    """Everything that changes how a frame looks (one plain object; set fields, then render).

    Attributes:
        mode: ``"fast"`` (Jimenez 2015 separable SSS), ``"reference"`` (Jimenez 2009 sum of Gaussians)
            or ``"off"`` (no subsurface scattering).
        taps: fast-mode kernel taps, 11, 17 or 25.
        exposure: multiplier before tone mapping. tonemap: ``"aces"``, ``"none"`` (clamp) or ``"raw"``
            (linear values, for float targets and tests).
        debug_view: a key of :data:`DEBUG_VIEWS`; debug_layer: layer index for ``"thickness"``.
        makeup: render the cosmetic layers (False = bare skin, for before/after).
        sss_width: scale of the skin profile (1 = d'Eon's measured skin). follow_surface: strength of
            the depth test that stops the blur at silhouettes.
        skin_roughness (Beckmann m), skin_f0 (Fresnel at normal incidence), spec_intensity (rho_s).
        normal_strength: tangent-space normal map strength. background: linear RGB.
        shadow_size: shadow-map side (texels); pcf_radius: PCF radius in shadow-map texels.
        irradiance_size: side of the texture-space irradiance cache (texels).
        cull_back_faces: skip triangles facing away (the head and the baseline alike).
        reference_full_resolution: run every Gaussian of the reference mode at full resolution (default:
            Gaussians wider than 3 pixels run on the half-resolution grid, like the fast mode's wide lobes).
    """

    mode: str = "fast"
    taps: int = 17
    exposure: float = 1.0
    tonemap: str = "aces"
    debug_view: str = "none"
    debug_layer: int = 0
    makeup: bool = True
    sss_width: float = 1.0
    follow_surface: float = 1.0
    skin_roughness: float = 0.35
    skin_f0: float = 0.028
    spec_intensity: float = 0.18
    normal_strength: float = 1.0
    background: tuple[float, float, float] = (0.045, 0.047, 0.052)
    shadow_size: int = 1024
    pcf_radius: float = 2.5
    irradiance_size: int = 1024
    reference_full_resolution: bool = False
    cull_back_faces: bool = True

    def validate(self) -> None:
        if self.mode not in MODES:
            raise RenderError(f"render mode must be one of {', '.join(MODES)}, got {self.mode!r}")
        if self.taps not in FAST_TAPS:
            raise RenderError(f"fast SSS taps must be one of {FAST_TAPS}, got {self.taps!r}")
        if self.debug_view not in DEBUG_VIEWS:
            raise RenderError(f"unknown debug view {self.debug_view!r} (known: {', '.join(DEBUG_VIEWS)})")
        if self.tonemap not in ("aces", "none", "raw"):
            raise RenderError(f"tonemap must be 'aces', 'none' or 'raw', got {self.tonemap!r}")
        for name in ("exposure", "sss_width", "follow_surface", "skin_roughness", "spec_intensity"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise RenderError(f"render setting {name} must be a finite number ≥ 0, got {v!r}")


def fast_kernel(taps: int, width: float = 1.0, exponent: float = 2.0, core_mm: float = 0.0) -> np.ndarray:
    """The pre-integrated separable kernel (Jimenez et al. 2015) of the d'Eon skin profile.

    Returns (taps, 4): RGB weights (each channel sums to 1) and the offset in mm; tap 0 is the centre.
    Offsets are spaced as ``range·t|t|`` (denser near the centre); each weight integrates the 1D profile
    over the tap's interval (midpoints to the neighbours). Taps closer than ``core_mm`` to the centre
    (below a pixel on screen) are merged into it, so the core can be applied at full resolution.
    """
    if taps % 2 == 0 or taps < 3:
        raise RenderError(f"kernel taps must be odd and ≥ 3, got {taps}")
    sig = np.sqrt(np.array([g[0] for g in SKIN_GAUSSIANS])) * width
    w = np.array([g[1:] for g in SKIN_GAUSSIANS])  # (6, 3)
    rng = 3.0 * sig.max()
    t = np.linspace(-1.0, 1.0, taps)
    off = rng * np.sign(t) * np.abs(t) ** exponent
    edges = np.concatenate([[-np.inf], (off[1:] + off[:-1]) / 2.0, [np.inf]])
    # math.erf on a few dozen values: scipy.special's import alone cost half a second of the studio's start-up
    erf = np.vectorize(math.erf, otypes=[np.float64])

    def cdf(x: np.ndarray) -> np.ndarray:  # (n,) → (n, 3): the 1D profile's cumulative distribution
        z = x[:, None] / (np.sqrt(2.0) * sig[None, :])
        return (0.5 * (1.0 + erf(z))) @ w

    weights = cdf(edges[1:]) - cdf(edges[:-1])
    weights /= weights.sum(axis=0, keepdims=True)
    k = np.concatenate([weights, off[:, None]], axis=1)
    c = taps // 2
    core = np.abs(off) <= core_mm
    core[c] = True
    k[c, :3] = weights[core].sum(axis=0)
    k[core & (np.arange(taps) != c), :3] = 0.0
    return np.concatenate([k[c:c + 1], k[:c], k[c + 1:]], axis=0).astype(np.float32)


@dataclass
class FrameInfo:
    """What the last frame used (for picking and overlays)."""

    size: tuple[int, int] = (0, 0)
    view: np.ndarray = field(default_factory=lambda: np.eye(4))
    view_proj: np.ndarray = field(default_factory=lambda: np.eye(4))
    scissor: tuple[int, int, int, int] = (0, 0, 0, 0)


class Renderer:
    """The cosmetic renderer for one head on one ``moderngl.Context`` (see :mod:`render`)."""

    def __init__(self, ctx: Any, head: Any, shaders: ShaderLibrary | None = None, km_dtype: str = "srgb8",
                 layout: Any = None) -> None:
        """``head``: a :class:`painting.head.Head`; ``layout``: the painting document's UV layout when its
        maps are not in the mesh's own UVs (see :class:`render.gpu_head.GpuHead`).
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
        self._frame_programs: dict[tuple[int, int], Any] = {}
        self._fast_programs: dict[int, Any] = {}
        self._gauss_programs: dict[int, Any] = {}
        self._sss_mask = self.shaders.program(ctx, "fullscreen_z.vert", "sss_mask.frag")
        self._composites: dict[tuple[int, int], Any] = {}
        self._baseline: Any = None
        self._quads: dict[int, Any] = {}
        self._lut_max = np.ones(MAX_LAYERS, np.float32)  # heat-map scale per layer (µm)
        self._targets: dict[str, Any] = {}
        self._size: tuple[int, int] = (0, 0)
        self.last = FrameInfo()

    # -- layers -----------------------------------------------------------------------------------
    def set_layers(self, layers: list[LayerInput]) -> None:
        """Replace the cosmetic layers (bottom first) and evaluate them in texture space."""
        self.km.set_layers(layers)
        self._update_layer_tables()

    @classmethod
    def for_document(cls, ctx: Any, doc: Any, **kwargs: Any) -> Renderer:
        """A renderer of a ``painting.Document``'s head and layers (kept in sync by :meth:`attach`)."""
        r = cls(ctx, doc.head, layout=getattr(doc, "layout", None), **kwargs)
        r.sync_document(doc)
        return r

    def update_tiles(self, layer_index: int, thickness: np.ndarray | None, tiles: list[tuple[int, int]]) -> None:
        """A layer's map changed in the 64² tiles ``tiles`` = [(column, row), …]: re-evaluate those.
        (``painting.ChangeEvent.tiles`` are (row, column): :meth:`on_document_event` converts.)
        """
        self.km.update_tiles(layer_index, thickness, tiles)

    def on_document_event(self, doc: Any, event: Any) -> None:
        """Apply a ``painting.ChangeEvent``: "paint" → re-evaluate the touched tiles of that layer; any
        other change (layers, material) → :meth:`sync_document`. Then call :meth:`render`.
        """
        if getattr(event, "kind", "") == "paint" and event.layer is not None:
            for i, lay in enumerate(doc.layers):
                if lay.id == event.layer:
                    if i < len(self.km.layers) and self.km.layers[i].thickness.shape == lay.thickness.shape:
                        self.update_tiles(i, lay.thickness, [(c, r) for r, c in event.tiles])
                        return
                    break
        self.sync_document(doc)

    def attach(self, doc: Any) -> Any:
        """Follow ``doc``'s change events (see :meth:`on_document_event`); returns the unsubscribe function.
        Events are applied synchronously: call it with this renderer's GL context current.
        """
        self.sync_document(doc)
        return doc.subscribe(lambda event: self.on_document_event(doc, event))

    def sync_document(self, doc: Any) -> None:
        """Read every layer of a ``painting.Document`` (``doc.layers``: ``.material_object`` or
        ``.material`` — a km Material or a library name —, ``.thickness``, ``.visible``, ``.opacity``).
        """
        layers = []
        lib = None
        for i, lay in enumerate(getattr(doc, "layers", [])):
            mat = getattr(lay, "material_object", None) or lay.material
            if isinstance(mat, str):
                if lib is None:
                    import km

                    lib = getattr(doc, "library", None) or km.default_library()
                mat = lib.get(mat)
            layers.append(LayerInput(mat, lay.thickness, float(getattr(lay, "opacity", 1.0)),
                                     bool(getattr(lay, "visible", True)), str(getattr(lay, "name", f"layer {i}"))))
        self.set_layers(layers)

    def _update_layer_tables(self) -> None:
        self._lut_max[:] = 1.0
        for slot, i in enumerate(self.km.active):
            mat = self.km.layers[i].material
            self._lut_max[slot] = float(getattr(mat, "max_thickness_um", 100.0) or 100.0)

    # -- environment ------------------------------------------------------------------------------
    def set_environment(self, name_or_path: str | None, intensity: float = 0.5) -> None:
        """Ambient light from an HDR environment (sample name like ``"studio"`` or an EXR path)."""
        self.environment = None if name_or_path is None else Environment.load(name_or_path, intensity)

    # -- targets ----------------------------------------------------------------------------------
    def _ensure_targets(self, size: tuple[int, int]) -> None:
        if size == self._size:
            return
        w, h = size
        if w < 1 or h < 1 or w > 16384 or h > 16384:
            raise RenderError(f"viewport size {w}×{h} is out of range (1..16384)")
        old = list(self._targets.values())
        t: dict[str, Any] = {}
        for name in ("diffuse", "outer", "factor", "tmp", "accum"):  # RGBA16F, linear HDR
            tex = self.ctx.texture(size, 4, dtype="f2")
            tex.repeat_x = tex.repeat_y = False
            tex.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
            t[name] = tex
        t["depth"] = self.ctx.depth_texture(size)
        t["gbuffer_clear"] = self.ctx.framebuffer([t["diffuse"]], t["depth"])
        t["gbuffer"] = self.ctx.framebuffer([t["diffuse"], t["outer"], t["factor"]], t["depth"])
        t["tmp_fbo"] = self.ctx.framebuffer([t["tmp"]])
        t["accum_fbo"] = self.ctx.framebuffer([t["accum"]])
        half = ((w + 1) // 2, (h + 1) // 2)
        # SSS pass targets with a depth mask (never written): the G-buffer's depth at full resolution,
        # sss_mask.frag's classes at half resolution; a depth test skips the pixels a pass leaves alone
        # two half-resolution masks: the horizontal passes' centres (the diffuse, nearest) and the vertical
        # passes' (the horizontal result, bilinear: its alpha is what the vertical pass tests)
        for name in ("half_depth", "half_depth_v"):
            t[name] = self.ctx.depth_texture(half)
            t[name.replace("depth", "mask") + "_fbo"] = self.ctx.framebuffer(depth_attachment=t[name])
        for name in ("tmp", "accum"):
            t[name + "_zfbo"] = self.ctx.framebuffer([t[name]], t["depth"])
        for name in ("half_a", "half_b"):
            tex = self.ctx.texture(half, 4, dtype="f2")
            tex.repeat_x = tex.repeat_y = False
            tex.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
            t[name] = tex
            t[name + "_fbo"] = self.ctx.framebuffer([tex])
            t[name + "_zfbo"] = self.ctx.framebuffer([tex], t["half_depth" if name == "half_a" else "half_depth_v"])
        for name in ("tmp_zfbo", "accum_zfbo", "half_a_zfbo", "half_b_zfbo"):
            t[name].depth_mask = False
        t["gbuffer"].use()
        for obj in old:  # not bound: the new G-buffer is
            obj.release()
        self._targets = t
        self._size = size

    # -- programs ---------------------------------------------------------------------------------
    def _frame_program(self, n: int, lights: int, makeup: bool = True, debug: bool = True) -> Any:
        """The lit pass for ``n`` layers and ``lights`` lights (both loops unroll at compile time).
        Makeup, debug views, the head's optional maps, which lights cast shadows and which are point
        lights are compiled in or out: llvmpipe executes both sides of a branch, so a uniform switch
        would not save their texture fetches or maths.
        """
        gh = self.gpu_head
        shadowed = sum(1 << i for i, lt in enumerate(self.lights[:lights]) if lt.shadows)
        points = sum(1 << i for i, lt in enumerate(self.lights[:lights]) if lt.kind != "directional")
        key = (n, lights, int(makeup), int(debug), shadowed, points)
        if key not in self._frame_programs:
            self._frame_programs[key] = self.shaders.program(
                self.ctx, "mesh.vert", "frame.frag",
                {"NL": n, "NLIGHTS": lights, "MAKEUP": int(makeup), "DEBUG": int(debug),
                 "SHADOWED": shadowed, "POINT_LIGHTS": points,
                 "HAS_SPEC_MAP": int(gh.has_specular_map), "HAS_ROUGH_MAP": int(gh.has_roughness_map),
                 "HAS_SKIN_MASK": int(self.head.skin_mask is not None)})
        return self._frame_programs[key]

    def _fast_program(self, taps: int) -> Any:
        if taps not in self._fast_programs:
            self._fast_programs[taps] = self.shaders.program(self.ctx, "fullscreen_z.vert", "sss_fast.frag",
                                                             {"NTAPS": taps})
        return self._fast_programs[taps]

    def _gauss_program(self, taps: int) -> Any:
        if taps not in self._gauss_programs:
            self._gauss_programs[taps] = self.shaders.program(self.ctx, "fullscreen_z.vert", "sss_gauss.frag",
                                                              {"NTAPS": taps})
        return self._gauss_programs[taps]

    def _composite_program(self, mode: int, debug: bool) -> Any:
        """The composite specialised for an SSS mode (0 off, 1 reference, 2 fast) and debug views."""
        key = (mode, int(debug))
        if key not in self._composites:
            self._composites[key] = self.shaders.program(self.ctx, "mesh.vert", "composite.frag",
                                                         {"MODE": mode, "DEBUG": int(debug)})
        return self._composites[key]

    def _quad(self, program: Any) -> Any:
        q = self._quads.get(program.glo)
        if q is None:
            q = self._quads[program.glo] = self.ctx.vertex_array(program, [])
        return q

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

    def render(self, fbo: Any, viewport: tuple[int, int, int, int] | None = None) -> FrameInfo:
        """Render one frame into ``fbo`` (e.g. ``ctx.detect_framebuffer(...)``) over ``viewport``
        (x, y, width, height in pixels; default the whole framebuffer). Leaves ``fbo`` bound.
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

        # 1. shadow maps (cached until a light moves)
        if self.shadows.size != s.shadow_size:
            self.shadows.release()
            self.shadows = ShadowMaps(ctx, self.shaders, s.shadow_size)
        shadowed = [lt for lt in self.lights if lt.shadows]
        if shadowed:
            self.shadows.update(self.lights, self.gpu_head.centre, self.gpu_head.radius, self.gpu_head.draw)
        if self.irradiance.size != s.irradiance_size:
            self.irradiance.release()
            self.irradiance = TextureIrradiance(ctx, self.shaders, s.irradiance_size)
        env = self.environment
        irr_key = (tuple((lt.kind, tuple(lt.vector), tuple(lt.colour), lt.intensity, lt.shadows,
                          lt.reference_distance) for lt in self.lights),
                   None if env is None else env.coefficients.tobytes(), s.normal_strength, s.pcf_radius,
                   s.shadow_size)

        def setup_irradiance(p: Any) -> None:
            self.shadows.texture.use(_U_SHADOW)
            self._set(p, "u_shadow", _U_SHADOW)
            self._set(p, "u_normal_strength", float(s.normal_strength))
            self._upload_lights(p)

        self.irradiance.update(irr_key, self.gpu_head, setup_irradiance, self.lights, env is not None)

        # 2. lit pass into the G-buffer
        n = len(self.km.active)
        prog = self._frame_program(n, len(self.lights), s.makeup and n > 0, DEBUG_VIEWS[s.debug_view] != 0)
        gb = self._targets["gbuffer"]
        # only the diffuse (read around the head by the SSS taps and the masks) and the depth are
        # cleared: outer and factor are read only at the head's pixels (the composite draws the same
        # mesh), which this pass writes (a third of the clear's cost)
        gc = self._targets["gbuffer_clear"]
        gc.use()
        gc.viewport = (0, 0, w, h)
        gc.scissor = None
        ctx.scissor = None
        gc.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        gb.use()
        gb.viewport = (0, 0, w, h)
        gb.scissor = None
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.BLEND)
        self._cull(True)
        self.gpu_head.bind_textures(0)
        self.km.bind(_U_KM)
        self.km.bind_spec(_U_SPEC0, _U_SPEC1)
        for slot in range(n):
            self.km.thickness_textures[slot].use(_U_THICK + slot)
        for j, tex in enumerate(self.irradiance.textures):
            tex.use(_U_IRR + j)
        units = {"u_albedo": 0, "u_normal_map": 1, "u_spec_map": 2, "u_rough_map": 3, "u_rtop": _U_KM,
                 "u_trans": _U_KM + 1, "u_rbottom": _U_KM + 2, "u_spec0": _U_SPEC0, "u_spec1": _U_SPEC1,
                 "u_irr": _U_IRR, "u_vis0": _U_IRR + 1, "u_vis1": _U_IRR + 2}
        for name, unit in units.items():
            self._set(prog, name, unit)
        if n and "u_layer_thick" in prog:
            u = prog["u_layer_thick"]
            u.value = list(range(_U_THICK, _U_THICK + u.array_length)) if u.array_length > 1 else _U_THICK
        self._write(prog, "u_view_proj", view_proj.T.reshape(1, 16))
        self._write(prog, "u_view", view.T.reshape(1, 16))
        self._set(prog, "u_eye", tuple(float(x) for x in self.camera.eye()))
        self._set(prog, "u_normal_strength", float(s.normal_strength))
        self._set(prog, "u_skin_roughness", float(s.skin_roughness))
        self._set(prog, "u_skin_f0", float(s.skin_f0))
        self._set(prog, "u_spec_intensity", float(s.spec_intensity))
        self._set(prog, "u_makeup_on", 1.0 if s.makeup and n > 0 else 0.0)
        gh = self.gpu_head
        self._set(prog, "u_has_maps", (int(gh.has_specular_map), int(gh.has_roughness_map),
                                       int(self.head.skin_mask is not None)))
        self._set(prog, "u_debug", DEBUG_VIEWS[s.debug_view])
        self._set(prog, "u_debug_layer", int(s.debug_layer))
        self._write(prog, "u_layer_spec", self.km.layer_spec)
        self._write(prog, "u_layer_inv_m2", 1.0 / np.maximum(self.km.layer_spec[:, 0], 0.05) ** 2)
        self._write(prog, "u_lut_max", self._lut_max)
        opac = np.zeros(MAX_LAYERS, np.float32)
        for slot, i in enumerate(self.km.active):
            opac[slot] = self.km.layers[i].opacity
        self._write(prog, "u_opacity", opac)
        self._upload_lights(prog)
        self.gpu_head.draw(prog)
        ctx.disable(ctx.DEPTH_TEST)
        self._cull(False)

        # 3-6. SSS, composite, display
        tonemap = {"raw": -1, "none": 0, "aces": 1}[s.tonemap]
        px_per_mm = h / (2.0 * math.tan(math.radians(self.camera.fov_y) / 2.0)) / self.gpu_head.mm_per_unit
        t = self._targets
        rx, ry, rw, rh = rect
        debug = DEBUG_VIEWS[s.debug_view]
        mode = 0
        w0: tuple[float, ...] = (1.0, 1.0, 1.0)
        if debug == 0 and s.mode == "fast":
            # wide lobes on the half-resolution grid, the kernel's centre (c²·E) at full resolution
            mode = 2
            # the kernel's core: taps within 1.5 full-resolution pixels at the head's distance
            mm_per_px = (self.camera.distance * 2.0 * math.tan(math.radians(self.camera.fov_y) / 2.0) / h
                         * self.gpu_head.mm_per_unit)
            k = fast_kernel(s.taps, s.sss_width, core_mm=1.5 * mm_per_px)
            w0 = tuple(float(c * c) for c in k[0, :3])
            hw, hh = t["half_a"].size
            hrect = (rx // 2, ry // 2, (rw + 3) // 2, (rh + 3) // 2)
            hp = self._fast_program(s.taps)
            t["diffuse"].filter = (ctx.NEAREST, ctx.NEAREST)
            self._half_mask(hrect)
            for name in ("half_a_fbo", "half_b_fbo"):  # what the skipped pixels output (background: 0)
                t[name].use()
                t[name].viewport = (0, 0, hw, hh)
                ctx.scissor = None
                t[name].clear(0.0, 0.0, 0.0, 0.0)
            self._blur_common(hp, px_per_mm, t["diffuse"], (1.0, 0.0))
            self._write(hp, "u_kernel", k)
            self._set(hp, "u_final", 0)
            self._sss_pass(hp, t["half_a_zfbo"], (hw, hh), hrect, _Z_HEAD)
            self._half_mask(hrect, vertical=True)
            self._blur_common(hp, px_per_mm * 0.5, t["half_a"], (0.0, 1.0))
            t["diffuse"].use(1)
            self._set(hp, "u_centre", 1)
            self._set(hp, "u_final", 1)
            self._sss_pass(hp, t["half_b_zfbo"], (hw, hh), hrect, _Z_SKIN)
            self._end_sss()
            accum = t["half_b"]
        elif debug == 0 and s.mode == "reference":
            mode = 1
            w0 = tuple(float(x) for x in SKIN_GAUSSIANS[0][1:])
            hw, hh = t["half_a"].size
            hrect = (rx // 2, ry // 2, (rw + 3) // 2, (rh + 3) // 2)
            mm_per_px = (self.camera.distance * 2.0 * math.tan(math.radians(self.camera.fov_y) / 2.0) / h
                         * self.gpu_head.mm_per_unit)
            gaussians = [(math.sqrt(var) * s.sss_width, wt) for var, *wt in SKIN_GAUSSIANS[1:]]
            half = [g for g in gaussians if not s.reference_full_resolution and g[0] / mm_per_px >= 3.0]
            full = [g for g in gaussians if g not in half]
            whalf = np.sum([g[1] for g in half], axis=0) if half else np.zeros(3)
            # the passes skip the pixels whose output nothing reads (depth-tested against a mask); their
            # targets are cleared to what those pixels would hold (background: 0)
            for fbo_name, size in (("accum_fbo", (w, h)), ("half_b_fbo", (hw, hh)), ("tmp_fbo", (w, h)),
                                   ("half_a_fbo", (hw, hh))):
                t[fbo_name].use()
                t[fbo_name].viewport = (0, 0, *size)
                ctx.scissor = None
                t[fbo_name].clear(0.0, 0.0, 0.0, 0.0)
            if half:
                t["diffuse"].filter = (ctx.NEAREST, ctx.NEAREST)
                self._half_mask(hrect)
            # full resolution: the G-buffer's depth marks the head (fragment depth 1 passes where < 1)
            for group, tmp_fbo, acc, size, rect_, scale, z_h, z_v in (
                    (full, t["tmp_zfbo"], t["accum_zfbo"], (w, h), (rx, ry, rw, rh), 1.0, 1.0, 1.0),
                    (half, t["half_a_zfbo"], t["half_b_zfbo"], (hw, hh), hrect, 0.5, _Z_HEAD, _Z_SKIN)):
                t["diffuse"].filter = (ctx.LINEAR, ctx.LINEAR) if scale == 1.0 else (ctx.NEAREST, ctx.NEAREST)
                for sigma, wt in group:
                    # the horizontal pass reads the full-resolution diffuse, the vertical one its result
                    gp = self._gauss_program(reference_taps(sigma / mm_per_px))
                    self._blur_common(gp, px_per_mm, t["diffuse"], (1.0, 0.0))
                    self._set(gp, "u_sigma_mm", sigma)
                    self._set(gp, "u_weight", (1.0, 1.0, 1.0))
                    self._set(gp, "u_premultiplied", 0)
                    ctx.disable(ctx.BLEND)
                    self._sss_pass(gp, tmp_fbo, size, rect_, z_h)
                    if scale != 1.0 and (sigma, wt) == group[0]:  # the same alpha after every Gaussian
                        self._half_mask(hrect, vertical=True)
                    src_tex = t["tmp"] if scale == 1.0 else t["half_a"]
                    gp = self._gauss_program(reference_taps(sigma / mm_per_px * scale))
                    self._blur_common(gp, px_per_mm * scale, src_tex, (0.0, 1.0))
                    self._set(gp, "u_sigma_mm", sigma)
                    self._set(gp, "u_weight", tuple(float(x) for x in wt))
                    self._set(gp, "u_premultiplied", 0 if scale == 1.0 else 1)
                    self._set(gp, "u_cov", 1.0 / max(len(group), 1))
                    ctx.enable(ctx.BLEND)
                    ctx.blend_func = ctx.ONE, ctx.ONE
                    self._sss_pass(gp, acc, size, rect_, z_v)
            ctx.disable(ctx.BLEND)
            self._end_sss()
            t["half_b"].use(4)
            cp = self._composite_program(mode, debug != 0)
            self._set(cp, "u_accum_half", 4)
            self._set(cp, "u_whalf", tuple(float(x) for x in whalf))
            accum = t["accum"]
        else:
            accum = t["accum"]
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
        self._to_target(fbo, (vx, vy, w, h), rect, cp)
        ctx.scissor = None
        fbo.scissor = None
        return self.last

    def _half_mask(self, hrect: tuple[int, int, int, int], vertical: bool = False) -> None:
        """The half-resolution pixel classes of the SSS passes (see sss_mask.frag) into a half depth:
        of the diffuse for the horizontal passes, of the horizontal result (``vertical``) for the others.
        """
        ctx, t = self.ctx, self._targets
        hw, hh = t["half_a"].size
        t["half_a" if vertical else "diffuse"].use(0)
        self._set(self._sss_mask, "u_src", 0)
        self._set(self._sss_mask, "u_z", 0.0)
        fbo = t["half_mask_v_fbo" if vertical else "half_mask_fbo"]
        fbo.depth_mask = True
        fbo.use()
        fbo.viewport = (0, 0, hw, hh)
        ctx.scissor = hrect
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "1"  # always: the mask writes every pixel of the rectangle
        ctx.disable(ctx.BLEND)
        self._quad(self._sss_mask).render(vertices=3)

    def _sss_pass(self, prog: Any, fbo: Any, size: tuple[int, int], rect: tuple[int, int, int, int],
                  z: float) -> None:
        """One full-screen SSS pass over ``rect`` of ``fbo``, only where the mask's depth is below the
        triangle's (``z``: NDC depth, see _Z_HEAD / _Z_SKIN).
        """
        ctx = self.ctx
        self._set(prog, "u_z", float(z))
        fbo.use()
        fbo.viewport = (0, 0, *size)
        ctx.scissor = rect
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = ">"
        self._quad(prog).render(vertices=3)

    def _end_sss(self) -> None:
        self.ctx.depth_func = "<"
        self.ctx.disable(self.ctx.DEPTH_TEST)

    def _blur_common(self, prog: Any, px_per_mm: float, src: Any, direction: tuple[float, float]) -> None:
        src.use(0)
        self._targets["factor"].use(1)
        self._set(prog, "u_src", 0)
        self._set(prog, "u_factor", 1)
        self._set(prog, "u_dir", direction)
        self._set(prog, "u_px_per_mm_at_1", float(px_per_mm))
        self._set(prog, "u_mm_per_unit", float(self.gpu_head.mm_per_unit))
        self._set(prog, "u_follow", float(self.settings.follow_surface))
        self._set(prog, "u_width", float(self.settings.sss_width))

    def _display_common(self, prog: Any, tonemap: int, debug: int) -> None:
        self._targets["outer"].use(2)
        self._set(prog, "u_outer", 2)
        self._set(prog, "u_background", tuple(float(x) for x in self.settings.background))
        self._set(prog, "u_exposure", float(self.settings.exposure))
        self._set(prog, "u_tonemap", tonemap)
        self._set(prog, "u_debug", debug)

    def _to_target(self, fbo: Any, viewport: tuple[int, int, int, int], rect: tuple[int, int, int, int],
                   prog: Any) -> None:
        """Clear ``fbo``'s viewport to the background, then run ``prog`` over the head's screen rectangle."""
        ctx = self.ctx
        vx, vy, w, h = viewport
        fbo.use()
        fbo.viewport = viewport
        bg = self.settings.background
        enc = [float(c * 12.92 if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055) for c in bg]
        if self.settings.tonemap == "raw":
            enc = [float(c) for c in bg]
        ctx.scissor = viewport
        fbo.clear(enc[0], enc[1], enc[2], 1.0, viewport=viewport)
        rx, ry, rw, rh = rect
        ctx.scissor = (vx + rx, vy + ry, rw, rh)
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST)
        if rw > 0 and rh > 0:  # the head's pixels: the lit pass's geometry, transform and culling
            self._write(prog, "u_view_proj", self.last.view_proj.T.reshape(1, 16))
            self._write(prog, "u_view", self.last.view.T.reshape(1, 16))
            self._cull(True)
            self.gpu_head.draw(prog)
            self._cull(False)
        ctx.scissor = None

    def _cull(self, on: bool) -> None:
        """Back-face culling for closed heads (``settings.cull_back_faces``; the mesh winds counter-clockwise
        like its normals): about halves the fragments shaded. Open meshes seen from behind need it off.
        """
        if on and self.settings.cull_back_faces:
            self.ctx.front_face = "ccw"
            self.ctx.cull_face = "back"
            self.ctx.enable(self.ctx.CULL_FACE)
        else:
            self.ctx.disable(self.ctx.CULL_FACE)

    def _upload_lights(self, prog: Any) -> None:
        upload_lights(prog, self.lights, self.shadows, self.settings.pcf_radius, self.environment)

    # -- baseline (benchmark) ---------------------------------------------------------------------
    def render_baseline(self, fbo: Any, viewport: tuple[int, int, int, int] | None = None) -> None:
        """The benchmark baseline: same mesh and albedo, one Lambert light, no post-processing
        (``fbo`` needs a depth attachment).
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
        w, h = self.last.size
        if not (0 <= x < w and 0 <= y < h) or "gbuffer" not in self._targets:
            return None
        raw = self._targets["gbuffer"].read(viewport=(int(x), int(h - 1 - y), 1, 1), attachment=-1, dtype="f4")
        z = float(np.frombuffer(raw, np.float32)[0])
        return None if z >= 1.0 else z

    def inverse_view_projection(self) -> np.ndarray:
        """Inverse of the last frame's view-projection matrix (4×4 float64, column vectors)."""
        return np.linalg.inv(self.last.view_proj)

    def unproject(self, x: float, y: float, depth: float) -> np.ndarray:
        """World point (mesh units) of pixel (x, y) (origin top-left, pixel centres at +0.5) at window depth."""
        w, h = self.last.size
        ndc = np.array([2.0 * (x + 0.5) / w - 1.0, 1.0 - 2.0 * (y + 0.5) / h, 2.0 * depth - 1.0, 1.0])
        p = self.inverse_view_projection() @ ndc
        return p[:3] / p[3]

    def pick(self, x: int, y: int) -> np.ndarray | None:
        """The surface point (mesh units) under pixel (x, y) of the last frame, or None."""
        z = self.depth_at(x, y)
        return None if z is None else self.unproject(x, y, z)

    # -- convenience ------------------------------------------------------------------------------
    def render_image(self, size: tuple[int, int], linear: bool = False) -> np.ndarray:
        """Render to an offscreen target and return the image, top row first: uint8 (H, W, 3), or
        float32 (H, W, 3) linear values if ``linear`` (sets ``tonemap='raw'`` for this frame).
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
        objs: list[Any] = [*self._quads.values(), *self._frame_programs.values(), *self._fast_programs.values(),
                           *self._gauss_programs.values(), self._sss_mask, *self._composites.values(),
                           *self._targets.values()]
        if self._baseline is not None:
            objs.append(self._baseline)
        from render.glutil import release_all

        release_all(self.ctx, objs)
        self._quads, self._frame_programs, self._fast_programs, self._targets = {}, {}, {}, {}
        self._gauss_programs = {}
        self._composites = {}
        self.km.release()
        self.irradiance.release()
        self.shadows.release()
        self.gpu_head.release()
