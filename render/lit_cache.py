"""The texture-space cache of view-independent lighting: what the lit pass fetches instead of recomputing.

With the lights fixed to the head, the light that reaches the skin through the makeup, the makeup's own
diffuse reflection and the out-scatter factor do not depend on the camera (Huang et al. 2013, Sec. 3:
only the specular lobes and the screen-space SSS blur do). :class:`TextureLighting` keeps them per
texel (``lit_cache.frag``; at the KM maps' or the albedo's resolution, whichever is larger):

- ``diffuse`` = E·T·√albedo (the SSS input), alpha = the skin mask;
- ``outer`` = R_top·E (the makeup's diffuse reflection), alpha = the smoothing coverage;
- ``factor`` = √albedo·T / (1 − R_bottom·albedo) (out-scatter through the makeup), alpha = light 0's
  shadow visibility;

where E is the texture-space irradiance (:class:`render.irradiance.TextureIrradiance`: lights with PCF
shadows and the SH environment). It is recomputed whole when the irradiance changes (a light, the
environment, the normal strength, the shadow settings) or the KM maps are evaluated whole (layers, a
material edit), and only over the dirty tiles after a dab (the tiles the KM pass re-evaluated). The
lit pass then takes three fetches where it took the albedo, R_top, R_bottom and E, and none of their
maths; the screen-space SSS stays screen-space, its input comes from here.

It applies when the paint maps are in the mesh's own UVs (one texel addresses both; the sample head
and every head painted in its own UVs) and there are visible layers; otherwise the lit pass computes the
same terms per pixel (the direct path, which the tests hold the cache to: within 0.5 ΔE2000 on skin).

Units: display units as the irradiance (a white Lambert surface facing a light of intensity 1 shows 1).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from painting.tiles import tile_rects
from render.glutil import rect_vertices

if TYPE_CHECKING:
    import moderngl

    from render.gpu_head import GpuHead
    from render.irradiance import TextureIrradiance
    from render.km_pass import KMTextureSpace
    from render.shaders import ShaderLibrary

#: dirty tiles beyond which one draw of the whole map is cheaper than the rectangles
_FULL_AFTER_TILES = 2048


class TextureLighting:
    """The cache's three RGBA16F targets, kept in step with the KM pass and E.

    Attributes:
        size: (width, height) in texels (:meth:`target_size`).
        version: counts updates (whole or partial) since creation.
        full_updates: whole-map recomputations; tiles_updated: tiles recomputed after dabs (for tests).
    """

    def __init__(self, ctx: moderngl.Context, shaders: ShaderLibrary) -> None:
        self.ctx = ctx
        self.program = shaders.program(ctx, "km_tiles.vert", "lit_cache.frag")
        self.vbo = ctx.buffer(reserve=_FULL_AFTER_TILES * 6 * 8)
        self.vao = ctx.vertex_array(self.program, [(self.vbo, "2f", "in_pos")])
        self.size: tuple[int, int] = (0, 0)
        self.textures: list[moderngl.Texture] = []
        self.fbo: moderngl.Framebuffer | None = None
        self._key: tuple[int, int, tuple[int, int]] | None = None  # (irradiance version, KM full version, size)
        self.version = 0
        self.full_updates = 0
        self.tiles_updated = 0

    def _alloc(self, size: tuple[int, int]) -> None:
        if size == self.size and self.fbo is not None:
            return
        old = [self.fbo, *self.textures]
        self.textures = []
        for _ in range(3):
            tex = self.ctx.texture(size, 4, dtype="f2")
            tex.repeat_x = tex.repeat_y = False
            tex.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
            self.textures.append(tex)
        self.fbo = self.ctx.framebuffer(self.textures)
        self.fbo.use()  # moderngl re-binds its current framebuffer: never a released one
        for obj in old:
            if obj is not None:
                obj.release()
        self.size = size

    def needs_whole(self, irradiance: TextureIrradiance, km: KMTextureSpace) -> bool:
        """Whether the next :meth:`update` recomputes the whole cache (it is out of date as a whole)."""
        return (irradiance.version, km.full_version, km.size) != self._key

    @staticmethod
    def target_size(km: KMTextureSpace, gpu_head: GpuHead) -> tuple[int, int]:
        """The cache's size: the KM maps' or the albedo's, whichever is larger per axis.

        Below the albedo's resolution the cache would lose the skin's detail (√albedo is in it); below
        the maps', the makeup's edges.
        """
        (kw, kh), (aw, ah) = km.size, gpu_head.albedo.size
        return max(kw, aw), max(kh, ah)

    def _rects(self, tiles: list[tuple[int, int]], km_size: tuple[int, int]) -> list[tuple[int, int, int, int]]:
        """The cache texels that depend on KM tiles (row, col).

        Each tile scaled to the cache, widened by the bilinear footprint (one KM texel each way), clipped.
        """
        cw, ch = self.size
        sx, sy = cw / km_size[0], ch / km_size[1]
        mx, my = math.ceil(sx), math.ceil(sy)
        out = []
        for x, y, w, h in tile_rects(tiles, km_size):
            x0, y0 = max(int(math.floor(x * sx)) - mx, 0), max(int(math.floor(y * sy)) - my, 0)
            x1, y1 = min(int(math.ceil((x + w) * sx)) + mx, cw), min(int(math.ceil((y + h) * sy)) + my, ch)
            out.append((x0, y0, x1 - x0, y1 - y0))
        return out

    def update(self, km: KMTextureSpace, irradiance: TextureIrradiance, gpu_head: GpuHead) -> bool:
        """Bring the cache up to date with ``km`` and ``irradiance``; takes ``km.dirty_tiles``.

        Returns:
            True if anything was recomputed.
        """
        tiles, km.dirty_tiles = km.dirty_tiles, []
        key = (irradiance.version, km.full_version, km.size)
        whole = key != self._key
        if not whole and not tiles:
            return False
        self._alloc(self.target_size(km, gpu_head))
        assert self.fbo is not None
        ctx = self.ctx
        self.fbo.use()
        self.fbo.viewport = (0, 0, *self.size)
        ctx.scissor = None
        ctx.disable(ctx.DEPTH_TEST | ctx.BLEND | ctx.CULL_FACE)
        gpu_head.albedo.use(0)
        irradiance.textures[0].use(1)  # E (rgb) and light 0's visibility (a)
        km.bind(2)
        for name, unit in (("u_albedo", 0), ("u_irr", 1), ("u_rtop", 2), ("u_trans", 3), ("u_rbottom", 4)):
            self.program[name].value = unit
        self.program["u_size"].value = (float(self.size[0]), float(self.size[1]))
        rects = None if whole or len(tiles) > _FULL_AFTER_TILES else self._rects(tiles, km.size)
        verts = rect_vertices(rects, self.size)
        self.vbo.write(verts.tobytes())
        self.vao.render(mode=ctx.TRIANGLES, vertices=len(verts))
        if rects is None:
            self.full_updates += 1
        else:
            self.tiles_updated += len(rects)
        self._key = key
        self.version += 1
        return True

    def invalidate(self) -> None:
        """Recompute the whole cache at the next :meth:`update`."""
        self._key = None

    def bind(self, unit: int) -> None:
        """Bind diffuse, outer and factor to three consecutive texture units from ``unit``."""
        for i, tex in enumerate(self.textures):
            tex.use(unit + i)

    def release(self) -> None:
        """Free every GPU object (call with the context current)."""
        from render.glutil import release_all

        release_all(self.ctx, [self.fbo, *self.textures, self.vao, self.vbo, self.program])
        self.textures, self.fbo = [], None
