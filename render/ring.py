"""The brush ring: a small model (:class:`BrushRing`) and its GPU drawing (:class:`RingOverlay`).

The ring shows where a dab would land: a band at the brush radius around a surface point, drawn only on
the visible surface (tested against the depth of the same mesh drawn with the same matrix) over a kept
frame, so moving it costs one depth-tested pass of the mesh inside its box on screen, not a new frame.
Units: mesh units for the centre and the radius; pixels (GL's origin, bottom-left) for screen boxes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from render.glutil import release_all, set_uniform, write_uniform

if TYPE_CHECKING:
    import moderngl

    from render.gpu_head import GpuHead
    from render.shaders import ShaderLibrary


@dataclass(frozen=True)
class BrushRing:
    """Where the brush is: a surface point and the brush radius.

    Attributes:
        centre: the point under the cursor, mesh units (x, y, z).
        radius: the brush radius, mesh units (> 0).
    """

    centre: tuple[float, float, float]
    radius: float

    def screen_box(self, view_proj: np.ndarray, size: tuple[int, int]) -> tuple[int, int, int, int] | None:
        """The pixel box around the ring's sphere (1.2 × the radius) in a view of ``size`` (w, h) pixels.

        Args:
            view_proj: the view's 4×4 view-projection matrix (column vectors).
            size: the view's width and height in pixels.

        Returns:
            (x, y, width, height) with GL's origin (bottom-left), clipped to the view; the whole view when
            the sphere reaches behind the camera; None when the box is off screen.
        """
        w, h = size
        c, r = np.asarray(self.centre, float), float(self.radius) * 1.2
        corners = np.array([[c[0] + dx * r, c[1] + dy * r, c[2] + dz * r, 1.0]
                            for dx in (-1, 1) for dy in (-1, 1) for dz in (-1, 1)])
        clip = corners @ np.asarray(view_proj, float).T
        if np.any(clip[:, 3] <= 1e-6):
            return 0, 0, w, h
        ndc = clip[:, :2] / clip[:, 3:4]
        x0, y0 = ((ndc.min(axis=0) + 1.0) * 0.5 * (w, h)).astype(int) - 2
        x1, y1 = ((ndc.max(axis=0) + 1.0) * 0.5 * (w, h)).astype(int) + 3
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
        if x1 <= x0 or y1 <= y0:
            return None
        return int(x0), int(y0), int(x1 - x0), int(y1 - y0)


class RingOverlay:
    """Draws :class:`BrushRing` over a kept frame (``mesh.vert`` with ``depth_only.frag``/``brush_ring.frag``)."""

    def __init__(self, ctx: moderngl.Context, shaders: ShaderLibrary, gpu_head: GpuHead) -> None:
        """Build the two programs; ``gpu_head`` is the mesh the frame shows (its buffers are shared)."""
        self.ctx = ctx
        self.gpu_head = gpu_head
        self.depth_prog = shaders.program(ctx, "mesh.vert", "depth_only.frag")
        self.ring_prog = shaders.program(ctx, "mesh.vert", "brush_ring.frag")

    def _matrices(self, prog: moderngl.Program, view_proj: np.ndarray, view: np.ndarray) -> None:
        write_uniform(prog, "u_view_proj", np.asarray(view_proj).T.reshape(1, 16))
        write_uniform(prog, "u_view", np.asarray(view).T.reshape(1, 16))

    def draw_depth(self, frame: moderngl.Framebuffer, view_proj: np.ndarray, view: np.ndarray) -> None:
        """Replace ``frame``'s depth with the mesh's (colour untouched), for the ring's visibility test.

        ``frame`` needs a depth attachment; it is left bound, with depth testing off.
        """
        ctx = self.ctx
        frame.color_mask = (False, False, False, False)
        frame.use()
        ctx.viewport = (0, 0, *frame.size)
        ctx.scissor = None
        frame.clear(depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "<"
        self._matrices(self.depth_prog, view_proj, view)
        self.gpu_head.draw(self.depth_prog)
        ctx.disable(ctx.DEPTH_TEST)
        frame.color_mask = (True, True, True, True)

    def draw(self, fbo: moderngl.Framebuffer, depth: moderngl.Texture, ring: BrushRing, view_proj: np.ndarray,
             view: np.ndarray) -> None:
        """Blend the ring into ``fbo`` (bound, same size as ``depth``) where the mesh is visible.

        Args:
            fbo: the target; its colour is blended over, its alpha kept (Qt composes a widget with it).
            depth: the mesh's depth at the view's size (see :meth:`draw_depth`).
            ring: where and how large.
            view_proj: the frame's view-projection matrix (column vectors).
            view: the frame's view matrix.
        """
        ctx = self.ctx
        box = ring.screen_box(view_proj, depth.size)
        if box is None:
            return
        ctx.scissor = box
        ctx.enable(ctx.BLEND)
        ctx.blend_func = (ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA, ctx.ZERO, ctx.ONE)
        ctx.blend_equation = ctx.FUNC_ADD
        depth.use(0)
        set_uniform(self.ring_prog, "u_depth", 0)
        set_uniform(self.ring_prog, "u_brush", (*(float(x) for x in ring.centre), float(ring.radius)))
        self._matrices(self.ring_prog, view_proj, view)
        self.gpu_head.draw(self.ring_prog)
        ctx.disable(ctx.BLEND)
        ctx.scissor = None

    def release(self) -> None:
        """Free the programs (the mesh belongs to the renderer); call with the context current."""
        release_all(self.ctx, [self.depth_prog, self.ring_prog])
