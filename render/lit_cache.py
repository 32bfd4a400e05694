"""The texture-space cache of view-independent lighting: what the lit pass fetches instead of recomputing.

With the lights fixed to the head, the light that reaches the skin through the makeup, the makeup's own
diffuse reflection and the out-scatter factor do not depend on the camera (Huang et al. 2013, Sec. 3:
only the specular lobes and the screen-space SSS blur do). :class:`TextureLighting` keeps them per
texel (``lit_cache.frag``; at the KM maps' or the albedo's resolution, whichever is larger):

- ``diffuse`` = E·T·√albedo (the SSS input), alpha = the skin mask;
- ``outer`` = R_top·E (the makeup's diffuse reflection), alpha = the smoothing coverage;
- ``factor`` = √albedo·T / (1 − R_bottom·albedo) (out-scatter through the makeup), alpha = light 0's
  shadow visibility;
- ``trans`` = T (the makeup's transmittance, for the skin's highlight under it), alpha = the smoothing
  layers' roughness (a copy of the KM pass's transmittance map, linear instead of sRGB-encoded);
- ``spec`` = the layers' highlights as one Beckmann lobe: their summed specular weight, the roughness of
  the weight-averaged m² and the weight-averaged F0 (exact wherever one layer has a highlight; where
  layers overlap the lit pass evaluates one lobe instead of one per layer, which cost 0.13 baseline
  frames each on llvmpipe);

where E is the texture-space irradiance (:class:`render.irradiance.TextureIrradiance`: lights with PCF
shadows and the SH environment). It is recomputed whole when the irradiance changes (a light, the
environment, the normal strength, the shadow settings) or the KM maps are evaluated whole (layers, a
material edit), and only over the dirty tiles after a dab (the tiles the KM pass re-evaluated). The
lit pass then fetches these five where it fetched the albedo, R_top, T, R_bottom, E and the specular
weights, and does none of their maths; the screen-space SSS stays screen-space, its input comes from here.

Levels (a two-level mip chain built on demand): level ``l`` holds the same terms at ``1/2^l`` of the side,
each of its texels computed from the inputs sampled bilinearly at its centre (for the KM maps, the mean of
the 2×2 texels below it at level 1). A frame fetches the level that matches its texel density
(:func:`level_for`: at the studio's framing, 1280×720, a 2048² map is minified 2× — the level-1 fetch
is better filtered and, on llvmpipe, cheaper: its texels stay in the cache). Each level is brought up to
date only when a frame uses it, so a relight at the studio's framing recomputes a quarter of the texels.

It applies when the paint maps are in the mesh's own UVs (one texel addresses both; the sample head
and every head painted in its own UVs) and there are visible layers; otherwise the lit pass computes the
same terms per pixel (the direct path, which the tests hold the cache to: within 0.5 ΔE2000 on skin).

Storage: five 32-bit textures per level (RGB10_A2 for the diffuse, RGBA8 for the others). On llvmpipe a
bilinear fetch costs about what the texel's bytes cost: the first cache (RGBA16F, 8 bytes a texel, plus the KM pass's sRGB transmittance, which llvmpipe decodes
slowly) made the lit pass's fetches 2.6× the baseline frame; 8-bit linear fetches cost half of that.
The colours are stored square-root encoded (``v = sqrt(x / scale)``, decoded ``x = v²·scale``), which
gives dark values the precision 8 bits lack in linear. ``scale`` (RGB) is a bound of E
(:func:`irradiance_bound`: every light facing the surface unshadowed, plus the environment's largest
irradiance), which bounds E·T·√albedo and R_top·E; the out-scatter factor is at most 1 (R_bottom + T ≤
1 for a layer stack that creates no light, so √albedo·T / (1 − R_bottom·albedo) ≤ √albedo) and is
stored with scale 1.

A point light close to the surface (inside the head, or next to the skin) makes the bound huge where the
skin at large gets ordinary light: with the light 1.5 units from the sample head's centre, 0.26 from a
surface inside the head, the bound was 3·10⁶ (the true largest E 1111, on surfaces facing the light) against ~1 on
the skin, and 8 bits square-root encoded hold nothing below scale / 255² — the head came out nearly black
(mean 42 against the direct path's 91). No bound can fix that (even the true 1111 leaves the skin ~8 of
255 codes). So the colours that carry E (diffuse, outer) are stored RGBA16F, the same square-root
encoding with a float's relative precision at every level, when the rig's range (:func:`irradiance_range`:
the bound over what each light gives the head at its median distance) exceeds :data:`MAX_8BIT_RANGE`.
Ordinary rigs (every directional rig, point lights an arm's length away) keep the 32-bit targets.

Units: display units as the irradiance (a white Lambert surface facing a light of intensity 1 shows 1).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from painting.tiles import tile_rects
from render.glutil import rect_vertices, set_uniform, write_uniform

if TYPE_CHECKING:
    from collections.abc import Callable

    import moderngl

    from render.gpu_head import GpuHead
    from render.irradiance import TextureIrradiance
    from render.km_pass import KMTextureSpace
    from render.lights import Environment, Light
    from render.shaders import ShaderLibrary

#: dirty tiles beyond which one draw of the whole map is cheaper than the rectangles
_FULL_AFTER_TILES = 2048
_GL_RGB10_A2 = 0x8059
#: the cache's textures (diffuse, outer, factor, trans, spec), in the order of :meth:`TextureLighting.bind`
CACHE_TEXTURES = 5
#: the coarsest level kept (half the side). A coarser one would be cheaper still where a frame minifies the
#: maps more than 2.8× (small windows), but there the direct path's unfiltered fetches alias so much that
#: the two paths differ by more than the 0.5 ΔE2000 the cache is held to (0.53 measured at 480×360 with
#: 2048² maps), and such frames are cheap anyway.
MAX_LEVEL = 1
#: directions sampled for the environment's largest irradiance (its SH is of order 2: smooth)
_ENV_SAMPLES = 4096
#: margin on the sampled environment maximum (order-2 SH between samples ~2° apart varies far less)
_ENV_MARGIN = 1.02
#: the largest :func:`irradiance_range` stored in 8/10 bits. The square-root code's step is 2/(255·v) of the
#: value at code v = sqrt(x / scale); skin lit at 1/16 of the bound (v = 1/4) is quantised in steps of 3 %
#: (8 bits, outer) and 0.8 % (10 bits, diffuse) — at most 1.5 % off, below a third of a ΔL* of 1 on skin
#: (L* ∝ Y^⅓). Beyond it the E-carrying colours go to RGBA16F (see the module doc).
MAX_8BIT_RANGE = 16.0


def irradiance_bound(lights: list[Light], environment: Environment | None, vertices: np.ndarray) -> np.ndarray:
    """An upper bound of the texture-space irradiance E on the head, per channel (display units).

    Each light counts as if it faced every texel unshadowed (its colour × intensity; a point light at the
    smallest distance any surface point can have, the nearest vertex's less the longest edge bound
    ``vertices``' spread), plus the environment's largest SH irradiance over the sphere.

    Args:
        lights: the rig (validated).
        environment: the SH environment, or None.
        vertices: the head's vertices (N, 3), mesh units.

    Returns:
        float32 (3,), each > 0 (at least 1e-3 so that a black rig still encodes).
    """
    v = np.asarray(vertices, float)
    edge = _longest_edge(v)
    # any surface point lies within the mesh's longest edge of a vertex; no finer bound is needed
    bound = _rig_irradiance(lights, environment, v, lambda d: float(d.min()) - edge)
    return np.maximum(bound, 1e-3).astype(np.float32)


def _rig_irradiance(lights: list[Light], environment: Environment | None, vertices: np.ndarray,
                    distance: Callable[[np.ndarray], float]) -> np.ndarray:
    """The rig's irradiance on a texel facing every light unshadowed (RGB, display units).

    A point light counts at ``distance`` (mesh units, at least 10⁻³) of its distances to the vertices
    (N,); the environment at its largest SH irradiance over the sphere.
    """
    total = np.zeros(3)
    for lt in lights:
        col = np.asarray(lt.colour, float) * float(lt.intensity)
        if lt.kind != "directional":
            d = max(distance(np.linalg.norm(vertices - np.asarray(lt.vector, float), axis=1)), 1e-3)
            col = col * (float(lt.reference_distance) / d) ** 2
        total += col
    if environment is not None:
        total += _environment_max(environment)
    return total


def _environment_max(environment: Environment) -> np.ndarray:
    """The environment's largest SH irradiance over the sphere (RGB, display units, with a margin)."""
    i = np.arange(_ENV_SAMPLES) + 0.5
    z = 1.0 - 2.0 * i / _ENV_SAMPLES
    phi = i * math.pi * (3.0 - math.sqrt(5.0))  # a Fibonacci sphere
    rho = np.sqrt(1.0 - z * z)
    dirs = np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=1)
    return np.asarray(environment.irradiance(dirs).max(axis=0) * _ENV_MARGIN, float)


def irradiance_range(lights: list[Light], environment: Environment | None, vertices: np.ndarray,
                     bound: np.ndarray | None = None) -> float:
    """How far :func:`irradiance_bound` lies above the light the head gets at large (a ratio ≥ 1).

    The reference is the bound with each point light taken at its median distance from the vertices
    instead of its nearest (directional lights and the environment count the same in both): 1 for a rig
    without point lights; large when a point light is much nearer some surface than the head at large
    (inside the head, next to the skin), the hot spot that the bound must hold but the skin does not see.

    Args:
        lights: the rig (validated).
        environment: the SH environment, or None.
        vertices: the head's vertices (N, 3), mesh units.
        bound: :func:`irradiance_bound` of the same, if already at hand.

    Returns:
        the largest per-channel ratio of the bound to that reference (1 for a black rig).
    """
    v = np.asarray(vertices, float)
    far = np.maximum(_rig_irradiance(lights, environment, v, lambda d: float(np.median(d))), 1e-3)
    if bound is None:
        bound = irradiance_bound(lights, environment, v)
    return float(max(np.max(bound / far), 1.0))


def irradiance_encoding(lights: list[Light], environment: Environment | None,
                        vertices: np.ndarray) -> tuple[np.ndarray, bool]:
    """The cache's colour encoding for a rig.

    Returns:
        (the scale, :func:`irradiance_bound`; whether the E-carrying colours must be half floats,
        :func:`irradiance_range` above :data:`MAX_8BIT_RANGE`).
    """
    bound = irradiance_bound(lights, environment, vertices)
    return bound, irradiance_range(lights, environment, vertices, bound) > MAX_8BIT_RANGE


def _longest_edge(vertices: np.ndarray) -> float:
    """A bound of the mesh's longest edge from its vertices alone: the bounding box's diagonal / 50.

    Only used to keep a point light's bound conservative, and the head's triangles are far smaller.
    """
    return float(np.linalg.norm(vertices.max(0) - vertices.min(0))) / 50.0


#: triangles sampled for a frame's texel density (the median is stable well below the head's 17.7k)
_DENSITY_SAMPLES = 1024


def lit_cache_defines(n_layers: int) -> dict[str, int]:
    """The defines of ``lit_cache.frag``: layers 4-7's specular weights are read with more than four layers."""
    return {"SPEC1": int(n_layers > 4)}


class TexelDensity:
    """How many UV units a screen pixel spans on a head's surface in a given view (for the cache's level).

    Per sampled front-facing triangle: the affine map from screen pixels to UV, and GL's level-of-detail
    measure of it, max(|∂uv/∂x|, |∂uv/∂y|) (OpenGL 4.5 §8.14.1, without the log2); the frame's figure is
    the median over the triangles weighted by their screen area (occlusion ignored).
    """

    def __init__(self, uv: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> None:
        """Keep an even sample of ``faces`` (F, 3) over ``vertices`` (N, 3, mesh units) and ``uv`` (N, 2)."""
        f = np.asarray(faces)
        f = f[::max(len(f) // _DENSITY_SAMPLES, 1)]
        self._uv = np.asarray(uv, float)[f]  # (n, 3, 2)
        self._pos = np.c_[np.asarray(vertices, float)[f.reshape(-1)], np.ones(f.size)]  # (3n, 4)
        self._key: tuple[bytes, tuple[int, int]] | None = None
        self._value = 0.0

    def median(self, view_proj: np.ndarray, size: tuple[int, int]) -> float:
        """UV units per pixel at the area-weighted median triangle of a frame of ``size`` (w, h) pixels.

        0 when no sampled triangle faces the camera.
        """
        key = (np.asarray(view_proj, np.float64).tobytes(), tuple(size))
        if key == self._key:
            return self._value
        c = self._pos @ np.asarray(view_proj, float).T
        n = len(self._uv)
        ok = (c[:, 3] > 1e-9).reshape(n, 3).all(axis=1)
        p = (c[:, :2] / np.where(c[:, 3:4] > 1e-9, c[:, 3:4], 1.0) * (0.5 * size[0], 0.5 * size[1])).reshape(n, 3, 2)
        e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
        det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]  # twice the screen area, > 0 facing the camera
        front = ok & (det > 1e-9)
        value = 0.0
        if front.any():
            e1, e2, det = e1[front], e2[front], det[front]
            d1, d2 = (self._uv[front, 1] - self._uv[front, 0]), (self._uv[front, 2] - self._uv[front, 0])
            # ∂uv/∂x and ∂uv/∂y: [d1 d2] times the inverse of [e1 e2]
            du_dx = (d1 * e2[:, 1:2] - d2 * e1[:, 1:2]) / det[:, None]
            du_dy = (d2 * e1[:, 0:1] - d1 * e2[:, 0:1]) / det[:, None]
            rho = np.maximum(np.linalg.norm(du_dx, axis=1), np.linalg.norm(du_dy, axis=1))
            order = np.argsort(rho)
            cum = np.cumsum(det[order])
            value = float(rho[order][np.searchsorted(cum, cum[-1] / 2.0)])
        self._key, self._value = key, value
        return value


def level_for(texels: int, uv_per_pixel: float, max_level: int = MAX_LEVEL) -> int:
    """The cache level a frame should fetch: GL's nearest mip level for its median texel density.

    Args:
        texels: the cache's side at level 0 (texels).
        uv_per_pixel: :meth:`TexelDensity.median` of the frame.
        max_level: the coarsest level allowed (:meth:`TextureLighting.max_level`).

    Returns:
        round(log2(texels per pixel)) clamped to [0, ``max_level``] (level 0 up to √2 texels a pixel).
    """
    rho = texels * uv_per_pixel
    if rho <= 0:
        return 0
    return int(min(max(math.floor(math.log2(rho) + 0.5), 0), max_level))


class _Level:
    """One level of the cache: its targets, the state it was computed for and the tiles it still lacks."""

    def __init__(self) -> None:
        self.size: tuple[int, int] = (0, 0)
        self.textures: list[moderngl.Texture] = []
        self.fbo: moderngl.Framebuffer | None = None
        self.scale = np.ones(3, np.float32)
        self.wide = False  # the E-carrying colours (diffuse, outer) are RGBA16F (see the module doc)
        #: (irradiance side, its version, KM full version, KM size): the renderer keeps an irradiance per side,
        #: each counting its own versions, so the side tells a 512² relight from the 1024² one of the same count
        self.key: tuple[int, int, int, tuple[int, int]] | None = None
        self.pending: set[tuple[int, int]] = set()  # KM tiles (row, col) changed since its last update

    def alloc(self, ctx: moderngl.Context, size: tuple[int, int], wide: bool) -> None:
        if size == self.size and wide == self.wide and self.fbo is not None:
            return
        old = [self.fbo, *self.textures]
        self.textures = []
        for i in range(CACHE_TEXTURES):
            if wide and i < 2:  # diffuse and outer carry E: half floats for a rig of a wide range
                tex = ctx.texture(size, 4, dtype="f2")
            else:
                # the diffuse shows at full resolution through the SSS kernel's core: 10 bits (its alpha is
                # the binary skin mask, 2 bits are enough); the others 8
                tex = ctx.texture(size, 4, internal_format=_GL_RGB10_A2 if i == 0 else None)
            tex.repeat_x = tex.repeat_y = False
            tex.filter = (ctx.LINEAR, ctx.LINEAR)
            self.textures.append(tex)
        self.fbo = ctx.framebuffer(self.textures)
        self.fbo.use()  # moderngl re-binds its current framebuffer: never a released one
        for obj in old:
            if obj is not None:
                obj.release()
        self.size, self.wide = size, wide
        self.key = None

    def release(self) -> list[object]:
        objs: list[object] = [self.fbo, *self.textures]
        self.textures, self.fbo, self.size, self.key = [], None, (0, 0), None
        return objs


class TextureLighting:
    """The cache's levels of five 32-bit targets, kept in step with the KM pass and E (see the module doc).

    Attributes:
        version: counts updates (whole or partial, any level) since creation.
        full_updates: whole-level recomputations; tiles_updated: tile rectangles recomputed after dabs (for
            tests).
        level: the level of the last :meth:`update` (what :attr:`size`, :attr:`scale` and :meth:`bind` use).
    """

    def __init__(self, ctx: moderngl.Context, shaders: ShaderLibrary) -> None:
        self.ctx = ctx
        self.vbo = ctx.buffer(reserve=_FULL_AFTER_TILES * 6 * 8)
        self.shaders = shaders
        # the program with and without layers 4-7's specular weights (one fetch of 2048² maps fewer), each
        # compiled when first used (not on the start-up's path: the first frame draws on the direct path)
        self._programs: dict[int, tuple[moderngl.Program, moderngl.VertexArray]] = {}
        self.levels = [_Level() for _ in range(MAX_LEVEL + 1)]
        self.level = 0
        self.version = 0
        self.full_updates = 0
        self.tiles_updated = 0

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in texels of the current level."""
        return self.levels[self.level].size

    @property
    def scale(self) -> np.ndarray:
        """The colour encoding's scale (RGB, display units) of the current level: :func:`irradiance_bound`."""
        return self.levels[self.level].scale

    @property
    def wide(self) -> bool:
        """Whether the current level stores the E-carrying colours as half floats (see the module doc)."""
        return self.levels[self.level].wide

    @property
    def textures(self) -> list[moderngl.Texture]:
        """The current level's textures (diffuse, outer, factor, trans, spec)."""
        return self.levels[self.level].textures

    def needs_whole(self, irradiance: TextureIrradiance, km: KMTextureSpace, level: int = 0) -> bool:
        """Whether the next :meth:`update` of ``level`` recomputes it whole (it is out of date as a whole)."""
        return (irradiance.size, irradiance.version, km.full_version, km.size) != self.levels[level].key

    @staticmethod
    def target_size(km: KMTextureSpace, gpu_head: GpuHead) -> tuple[int, int]:
        """The cache's size at level 0: the KM maps' or the albedo's, whichever is larger per axis.

        Below the albedo's resolution the cache would lose the skin's detail (√albedo is in it); below
        the maps', the makeup's edges.
        """
        (kw, kh), (aw, ah) = km.size, gpu_head.albedo.size
        return max(kw, aw), max(kh, ah)

    @classmethod
    def max_level(cls, km: KMTextureSpace, gpu_head: GpuHead) -> int:
        """The coarsest level that keeps the albedo's resolution (up to :data:`MAX_LEVEL`).

        √albedo is in the cache: a level below the albedo's texels would blur the skin's own detail,
        which the direct path shows (with KM maps finer than the albedo, level 1 loses only the makeup's
        texels that the frame cannot show anyway).
        """
        (w, h), (aw, ah) = cls.target_size(km, gpu_head), gpu_head.albedo.size
        level = 0
        while level < MAX_LEVEL and w >> (level + 1) >= aw and h >> (level + 1) >= ah:
            level += 1
        return level

    @staticmethod
    def _rects(size: tuple[int, int], tiles: list[tuple[int, int]],
               km_size: tuple[int, int]) -> list[tuple[int, int, int, int]]:
        """The texels of a level of ``size`` that depend on KM tiles (row, col).

        Each tile scaled to the level, widened by the bilinear footprint (one KM texel each way), clipped.
        """
        cw, ch = size
        sx, sy = cw / km_size[0], ch / km_size[1]
        mx, my = math.ceil(sx), math.ceil(sy)
        out = []
        for x, y, w, h in tile_rects(tiles, km_size):
            x0, y0 = max(int(math.floor(x * sx)) - mx, 0), max(int(math.floor(y * sy)) - my, 0)
            x1, y1 = min(int(math.ceil((x + w) * sx)) + mx, cw), min(int(math.ceil((y + h) * sy)) + my, ch)
            out.append((x0, y0, x1 - x0, y1 - y0))
        return out

    def update(self, km: KMTextureSpace, irradiance: TextureIrradiance, gpu_head: GpuHead,
               scale: np.ndarray, level: int = 0, wide: bool = False) -> bool:
        """Bring ``level`` up to date with ``km`` and ``irradiance``, and make it the current level.

        Takes ``km.dirty_tiles`` (every level keeps the tiles it has not recomputed yet).
        ``scale``: :func:`irradiance_bound` of the lights and environment ``irradiance`` was made with
        (used when the level is recomputed whole; dirty tiles keep the level's scale). ``wide``: store the
        E-carrying colours as half floats (:func:`irradiance_range` above :data:`MAX_8BIT_RANGE`); a
        change of it reallocates the level, which is then recomputed whole.

        Returns:
            True if anything was recomputed.
        """
        if not 0 <= level <= MAX_LEVEL:
            raise ValueError(f"lighting cache level must be in 0..{MAX_LEVEL}, got {level}")
        tiles, km.dirty_tiles = km.dirty_tiles, []
        for lv in self.levels:
            if lv.key is not None:
                lv.pending.update(tiles)
                if len(lv.pending) > _FULL_AFTER_TILES:  # long unused: recomputed whole when used again
                    lv.key, lv.pending = None, set()
        self.level = level
        lv = self.levels[level]
        key = (irradiance.size, irradiance.version, km.full_version, km.size)
        w0, h0 = self.target_size(km, gpu_head)
        lv.alloc(self.ctx, (max(w0 >> level, 1), max(h0 >> level, 1)), wide)
        whole = key != lv.key
        pending = sorted(lv.pending)
        lv.pending = set()
        if not whole and not pending:
            return False
        assert lv.fbo is not None
        ctx = self.ctx
        lv.fbo.use()
        lv.fbo.viewport = (0, 0, *lv.size)
        ctx.scissor = None
        ctx.disable(ctx.DEPTH_TEST | ctx.BLEND | ctx.CULL_FACE)
        gpu_head.albedo.use(0)
        irradiance.textures[0].use(1)  # E (rgb) and light 0's visibility (a)
        km.bind(2)
        defines = lit_cache_defines(len(km.active))
        spec1 = defines["SPEC1"]
        if spec1 not in self._programs:
            prog = self.shaders.program(ctx, "km_tiles.vert", "lit_cache.frag", defines)
            self._programs[spec1] = (prog, ctx.vertex_array(prog, [(self.vbo, "2f", "in_pos")]))
        program, vao = self._programs[spec1]
        km.bind_spec(5, 6)
        for name, unit in (("u_albedo", 0), ("u_irr", 1), ("u_rtop", 2), ("u_trans", 3), ("u_rbottom", 4),
                           ("u_spec0", 5), ("u_spec1", 6)):
            set_uniform(program, name, unit)
        write_uniform(program, "u_layer_spec", km.layer_spec)
        program["u_size"].value = (float(lv.size[0]), float(lv.size[1]))
        if whole:
            lv.scale = np.asarray(scale, np.float32).reshape(3)
        program["u_inv_scale"].value = tuple(float(x) for x in 1.0 / lv.scale)
        rects = None if whole or len(pending) > _FULL_AFTER_TILES else self._rects(lv.size, pending, km.size)
        verts = rect_vertices(rects, lv.size)
        self.vbo.write(verts.tobytes())
        vao.render(mode=ctx.TRIANGLES, vertices=len(verts))
        if rects is None:
            self.full_updates += 1
        else:
            self.tiles_updated += len(rects)
        lv.key = key
        self.version += 1
        return True

    def invalidate(self) -> None:
        """Recompute every level whole at its next :meth:`update`."""
        for lv in self.levels:
            lv.key = None
            lv.pending = set()

    def bind(self, unit: int) -> None:
        """Bind the current level's diffuse, outer, factor, trans and spec to consecutive units from ``unit``."""
        for i, tex in enumerate(self.textures):
            tex.use(unit + i)

    def release(self) -> None:
        """Free every GPU object (call with the context current)."""
        from render.glutil import release_all

        objs: list[object] = [o for pv in self._programs.values() for o in pv[::-1]] + [self.vbo]
        self._programs = {}
        for lv in self.levels:
            objs += lv.release()
        release_all(self.ctx, objs)
