"""The Regions overlay: facial regions' outlines drawn on the visible surface over a frame (issue #16).

:class:`RegionOverlay` draws, for each shown region (:mod:`painting.regions`: soft masks in the paint
atlas's UV space), its outline — the mask's 0.5 level, about two pixels wide at any zoom — and a faint
tint of its inside, in the region's colour (:func:`region_colour`), on the surface the frame shows: the
mesh is drawn with ``mesh.vert`` + ``region_outline.frag`` (``resources/shaders``), tested against the
depth of the same mesh drawn with the same matrix (as the brush ring, :mod:`render.ring`), and blended
over the target. Nothing is drawn when no region is shown. Sizes are in pixels; masks are float [0, 1].
"""

from __future__ import annotations

import colorsys
from typing import TYPE_CHECKING

import numpy as np

from painting.regions import REGION_NAMES
from render.errors import RenderError
from render.glutil import release_all, set_uniform, write_uniform

if TYPE_CHECKING:
    from collections.abc import Mapping

    import moderngl

    from render.gpu_head import GpuHead
    from render.shaders import ShaderLibrary

#: The most regions shown at once (the shader's colour table).
MAX_SHOWN = 16
#: The inside's tint (alpha) under an outline.
TINT_ALPHA = 0.12


def region_colour(name: str) -> tuple[float, float, float]:
    """The overlay colour of region ``name`` (RGB in [0, 1]).

    Hues are spread around the wheel by the region's place in :data:`painting.regions.REGION_NAMES` (the
    golden angle apart, so neighbours differ), bright and saturated so they read over skin.
    """
    order = list(REGION_NAMES).index(name) if name in REGION_NAMES else len(REGION_NAMES)
    hue = (order * 0.381966) % 1.0
    return colorsys.hsv_to_rgb(hue, 0.85, 1.0)


class RegionOverlay:
    """Outlines of the shown regions over a frame (see the module docstring).

    Args:
        ctx: the GL context (the renderer's).
        shaders: where ``mesh.vert``, ``depth_only.frag`` and ``region_outline.frag`` come from.
        gpu_head: the mesh the frame shows (its buffers are shared; its ``in_uv_paint`` addresses the masks).
    """

    def __init__(self, ctx: moderngl.Context, shaders: ShaderLibrary, gpu_head: GpuHead) -> None:
        self.ctx = ctx
        self.gpu_head = gpu_head
        self.depth_prog = shaders.program(ctx, "mesh.vert", "depth_only.frag")
        self.prog = shaders.program(ctx, "mesh.vert", "region_outline.frag")
        self.names: list[str] = []
        self._masks: moderngl.TextureArray | None = None
        self._depth: moderngl.Texture | None = None
        self._depth_fbo: moderngl.Framebuffer | None = None
        self._depth_key: tuple[object, ...] | None = None

    def set_regions(self, masks: Mapping[str, np.ndarray]) -> None:
        """Show these regions (name → mask, float (R, R) in [0, 1], paint UV space, all the same size).

        An empty mapping shows none. Raises :class:`render.errors.RenderError` for more than
        :data:`MAX_SHOWN` regions or masks of different or non-square sizes.
        """
        names = list(masks)
        if len(names) > MAX_SHOWN:
            raise RenderError(f"at most {MAX_SHOWN} regions can be outlined at once, got {len(names)}")
        shapes = {np.shape(masks[n]) for n in names}
        if len(shapes) > 1 or any(len(s) != 2 or s[0] != s[1] for s in shapes):
            raise RenderError(f"region masks must be square and of one size, got {sorted(shapes)}")
        if self._masks is not None:
            self._masks.release()
            self._masks = None
        self.names = names
        if not names:
            return
        size = int(np.shape(masks[names[0]])[0])
        data = np.stack([np.clip(np.asarray(masks[n], np.float32), 0.0, 1.0) for n in names])
        # 8 bits are what the region files store (painting.regions.encode_regions)
        texels = np.round(data * 255.0).astype(np.uint8)
        self._masks = self.ctx.texture_array((size, size, len(names)), 1, texels.tobytes(), dtype="f1")
        self._masks.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
        self._masks.repeat_x = self._masks.repeat_y = False

    def draw(self, fbo: moderngl.Framebuffer, size: tuple[int, int], view_proj: np.ndarray,
             view: np.ndarray) -> None:
        """Blend the shown regions' outlines into ``fbo`` (a ``size`` (w, h) view of the frame's camera).

        Args:
            fbo: the target; its colour is blended over, its alpha kept. Left bound.
            size: the view's width and height in pixels.
            view_proj: the frame's view-projection matrix (column vectors).
            view: the frame's view matrix.
        """
        if not self.names or self._masks is None:
            return
        ctx = self.ctx
        key = (tuple(size), np.asarray(view_proj, np.float64).tobytes())
        if key != self._depth_key:
            self._draw_depth(size, view_proj, view)
            self._depth_key = key
        assert self._depth is not None
        fbo.use()
        ctx.viewport = (0, 0, *size)
        ctx.scissor = None
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = (ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA, ctx.ZERO, ctx.ONE)
        ctx.blend_equation = ctx.FUNC_ADD
        self._masks.use(0)
        self._depth.use(1)
        set_uniform(self.prog, "u_masks", 0)
        set_uniform(self.prog, "u_depth", 1)
        set_uniform(self.prog, "u_count", len(self.names))
        colours = np.zeros((MAX_SHOWN, 4), np.float32)
        for i, name in enumerate(self.names):
            colours[i] = (*region_colour(name), TINT_ALPHA)
        write_uniform(self.prog, "u_colours", colours)
        write_uniform(self.prog, "u_view_proj", np.asarray(view_proj).T.reshape(1, 16))
        write_uniform(self.prog, "u_view", np.asarray(view).T.reshape(1, 16))
        self.gpu_head.draw(self.prog)
        ctx.disable(ctx.BLEND)

    def _draw_depth(self, size: tuple[int, int], view_proj: np.ndarray, view: np.ndarray) -> None:
        """The mesh's depth at ``size`` with the frame's matrix (for the visibility test)."""
        ctx = self.ctx
        if self._depth is None or self._depth.size != tuple(size):
            release_all(ctx, [self._depth_fbo, self._depth])
            self._depth = ctx.depth_texture(tuple(size))
            self._depth_fbo = ctx.framebuffer(depth_attachment=self._depth)
        assert self._depth_fbo is not None
        self._depth_fbo.use()
        ctx.viewport = (0, 0, *size)
        ctx.scissor = None
        self._depth_fbo.clear(depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "<"
        write_uniform(self.depth_prog, "u_view_proj", np.asarray(view_proj).T.reshape(1, 16))
        write_uniform(self.depth_prog, "u_view", np.asarray(view).T.reshape(1, 16))
        self.gpu_head.draw(self.depth_prog)
        ctx.disable(ctx.DEPTH_TEST)

    def release(self) -> None:
        """Free the programs, masks and depth target (the mesh is the renderer's); context current."""
        release_all(self.ctx, [self.depth_prog, self.prog, self._masks, self._depth_fbo, self._depth])
        self._masks = self._depth = self._depth_fbo = None
        self.names = []
