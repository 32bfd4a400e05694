"""The screen-space subsurface-scattering passes of a frame, between the lit pass and the composite.

- fast (Jimenez 2015): one horizontal and one vertical pass of :func:`render.sss.fast_kernel` on the
  half-resolution grid; the kernel's core (taps within 1.5 pixels) is applied at full resolution by the
  composite (``w0``).
- reference (Jimenez 2009): one separable blur per Gaussian of :data:`render.sss.SKIN_GAUSSIANS` after the
  first (which the composite applies as ``w0``), summed with their weights; Gaussians at least 3 pixels
  wide run on the half-resolution grid unless ``settings.reference_full_resolution``. The full-resolution
  ones run up to three to a pass pair (``sss_gauss3.frag``), on whole-texel taps weighted by the Gaussian
  convolved with the bilinear tent (:func:`render.sss.tent_gaussian_weights`: exactly the Gaussian of the
  interpolated image, one fetch per texel for all three in the horizontal pass) where
  :func:`render.sss.integer_radius` allows, else (zoomed in) on sub-texel taps.

Each pass is a full-screen triangle depth-tested against a mask it never writes (the G-buffer's depth at
full resolution, ``sss_mask.frag``'s pixel classes at half resolution), so the pixels whose output nothing
reads are skipped. Units: ``px_per_mm`` pixels per mm at distance 1 (mesh units), ``mm_per_px`` mm per
pixel at the camera's target distance.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from render.glutil import set_uniform, write_uniform
from render.sss import SKIN_GAUSSIANS, fast_kernel, integer_radius, reference_taps

if TYPE_CHECKING:
    import moderngl

    from render.settings import RenderSettings
    from render.shaders import ShaderLibrary

#: NDC depth of an SSS pass's triangle against sss_mask.frag's classes (skin 0.25, head 0.5, background 1
#: as window depth): Z_HEAD (window 0.75) passes on the head, Z_SKIN (0.375) on skin only
Z_HEAD, Z_SKIN = 0.5, -0.25

Rect = tuple[int, int, int, int]

#: the fewest taps of the fast kernel, and the widest kernel (its ±3σ range, full-resolution pixels at the
#: head's distance) they serve: their outer taps are then at most 4 half-resolution pixels apart. Measured
#: at the studio's framing (1280×720, a 20-pixel range), 11 and 17 taps differ by 0.025 ΔE2000 on skin and
#: are equally far from the reference (0.142); at twice the zoom 11 taps would be 0.25 from it, 17 taps 0.16.
FEW_TAPS, FEW_TAPS_MAX_RANGE_PX = 11, 22.0


def fast_taps(taps: int, width: float, mm_per_px: float) -> int:
    """The fast kernel's tap count for a frame.

    ``taps`` (the setting, a maximum), or :data:`FEW_TAPS` when the kernel spans at most
    :data:`FEW_TAPS_MAX_RANGE_PX` pixels (``width``: the profile's scale; ``mm_per_px``: mm per
    full-resolution pixel at the head's distance).
    """
    sigma_max = math.sqrt(max(var for var, *_ in SKIN_GAUSSIANS)) * width
    range_px = 3.0 * sigma_max / max(mm_per_px, 1e-9)
    return min(taps, FEW_TAPS) if range_px <= FEW_TAPS_MAX_RANGE_PX else taps


def split_gaussians(width: float, mm_per_px: float, full_resolution: bool
                    ) -> tuple[list[tuple[float, Any]], list[tuple[float, Any]]]:
    """The skin profile's Gaussians past the first as (σ mm, RGB weight): (half, full) resolution.

    Those of σ ≥ 3 full-resolution pixels are blurred at half resolution unless ``full_resolution``.
    ``width``: the profile's scale; ``mm_per_px``: mm per full-resolution pixel at the head's distance.
    """
    gaussians = [(math.sqrt(var) * width, wt) for var, *wt in SKIN_GAUSSIANS[1:]]
    half = [g for g in gaussians if not full_resolution and g[0] / mm_per_px >= 3.0]
    return half, [g for g in gaussians if g not in half]


def gauss3_defines(sigmas_px: list[float], integer_taps: bool, subtexel_taps: int | None) -> dict[str, int]:
    """The defines of ``sss_gauss3.frag`` (without ``VERT``) for a group of one to three Gaussians.

    Args:
        sigmas_px: the group's standard deviations in full-resolution pixels, growing.
        integer_taps: whole-texel taps where :func:`render.sss.integer_radius` allows (a prefix of the
            group), sub-texel taps for the rest.
        subtexel_taps: a fixed sub-texel tap count instead of :func:`render.sss.reference_taps`, or None.
    """
    radii = [integer_radius(s) if integer_taps else None for s in sigmas_px]
    ni = next((j for j, r in enumerate(radii) if r is None), len(radii))
    taps = [subtexel_taps or reference_taps(s) for s in sigmas_px]
    return {"NG": len(sigmas_px), "NI": ni, "RI": max((r for r in radii[:ni] if r), default=1),
            **{f"NT{j}": taps[j] if ni <= j < len(taps) else 1 for j in range(3)},
            **{f"RI{j}": radii[j] if j < ni else 1 for j in range(3)}}


class SSSPasses:
    """The SSS programs of one renderer and the passes that use them (targets: :func:`render.targets.frame_targets`)."""

    def __init__(self, ctx: moderngl.Context, shaders: ShaderLibrary, mm_per_unit: float) -> None:
        """Build the mask program; the blur programs are compiled per tap count on first use.

        Args:
            ctx: the renderer's GL context.
            shaders: where the GLSL files come from.
            mm_per_unit: millimetres per mesh unit of the head (> 0).
        """
        self.ctx = ctx
        self.shaders = shaders
        self.mm_per_unit = float(mm_per_unit)
        self._fast: dict[int, moderngl.Program] = {}
        self._gauss: dict[int, moderngl.Program] = {}
        self._gauss3: dict[tuple[Any, ...], moderngl.Program] = {}
        #: full-resolution reference Gaussians per pass pair (1..3; 3 saves four of six scenes at the studio's framing)
        self.full_per_pass = 3
        #: full-resolution Gaussians on whole-texel taps where :func:`render.sss.integer_radius` allows
        #: (sss_gauss3.frag); False: sub-texel taps for all (the quadrature of the same integral)
        self.integer_taps = True
        #: a fixed tap count for the full-resolution sub-texel Gaussians instead of
        #: :func:`render.sss.reference_taps` (None); e.g. 201 with ``integer_taps`` False: a brute-force frame
        self.subtexel_taps: int | None = None
        self._mask = shaders.program(ctx, "fullscreen_z.vert", "sss_mask.frag")
        self._quads: dict[int, moderngl.VertexArray] = {}

    def _program(self, cache: dict[int, moderngl.Program], frag: str, taps: int) -> moderngl.Program:
        if taps not in cache:
            cache[taps] = self.shaders.program(self.ctx, "fullscreen_z.vert", frag, {"NTAPS": taps})
        return cache[taps]

    def _quad(self, program: moderngl.Program) -> moderngl.VertexArray:
        q = self._quads.get(program.glo)
        if q is None:
            q = self._quads[program.glo] = self.ctx.vertex_array(program, [])
        return q

    def _clear(self, t: dict[str, Any], targets: tuple[tuple[str, tuple[int, int]], ...]) -> None:
        """Clear framebuffers (name, size) to 0: what the pixels a pass skips output (background)."""
        for name, size in targets:
            t[name].use()
            t[name].viewport = (0, 0, *size)
            self.ctx.scissor = None
            t[name].clear(0.0, 0.0, 0.0, 0.0)

    def fast(self, t: dict[str, Any], s: RenderSettings, rect: Rect, px_per_mm: float,
             mm_per_px: float) -> tuple[moderngl.Texture, tuple[float, ...]]:
        """The fast mode's two half-resolution passes over the head's screen rectangle ``rect``.

        Returns:
            The blurred (half-resolution) texture and the kernel centre's RGB weight ``w0`` (c², in [0, 1]).
        """
        ctx = self.ctx
        rx, ry, rw, rh = rect
        # the kernel's core: taps within 1.5 full-resolution pixels at the head's distance; fewer taps when it is narrow
        k = fast_kernel(fast_taps(s.taps, s.sss_width, mm_per_px), s.sss_width, core_mm=1.5 * mm_per_px)
        w0 = tuple(float(c * c) for c in k[0, :3])
        hw, hh = t["half_a"].size
        hrect = (rx // 2, ry // 2, (rw + 3) // 2, (rh + 3) // 2)
        hp = self._program(self._fast, "sss_fast.frag", len(k))
        t["diffuse"].filter = (ctx.NEAREST, ctx.NEAREST)
        self.draw_mask(t, hrect)
        self._blur_common(t, s, hp, px_per_mm, t["diffuse"], (1.0, 0.0))
        write_uniform(hp, "u_kernel", k)
        set_uniform(hp, "u_final", 0)
        # each pass clears its target to 0 (what the pixels it skips must read) in the same draw target
        # as it draws: one llvmpipe scene each instead of two
        self.draw_pass(hp, t["half_a_zfbo"], (hw, hh), hrect, Z_HEAD, clear=True)
        self._blur_common(t, s, hp, px_per_mm * 0.5, t["half_a"], (0.0, 1.0))
        t["diffuse"].use(1)
        set_uniform(hp, "u_centre", 1)
        set_uniform(hp, "u_final", 1)
        self.draw_pass(hp, t["half_b_zfbo"], (hw, hh), hrect, Z_SKIN, clear=True)
        self._end()
        return t["half_b"], w0

    def reference(self, t: dict[str, Any], s: RenderSettings, rect: Rect, px_per_mm: float,
                  mm_per_px: float) -> tuple[moderngl.Texture, tuple[float, ...], np.ndarray]:
        """The reference mode's Gaussians over the head's screen rectangle ``rect``.

        Returns:
            The full-resolution sum, the first Gaussian's RGB weight ``w0`` and the summed RGB weight of the
            half-resolution Gaussians (their sum is ``t["half_b"]``; zeros when all ran at full resolution).
        """
        ctx = self.ctx
        rx, ry, rw, rh = rect
        w, h = t["accum"].size
        hw, hh = t["half_a"].size
        w0 = tuple(float(x) for x in SKIN_GAUSSIANS[0][1:])
        hrect = (rx // 2, ry // 2, (rw + 3) // 2, (rh + 3) // 2)
        half, full = split_gaussians(s.sss_width, mm_per_px, s.reference_full_resolution)
        whalf = np.sum([g[1] for g in half], axis=0) if half else np.zeros(3)
        # a group's targets are cleared by its first passes (one llvmpipe scene with the draw); the sum of
        # a group with no Gaussian is read by the composite all the same
        self._clear(t, tuple((name, size) for name, size, group in (("accum_fbo", (w, h), full),
                                                                    ("half_b_fbo", (hw, hh), half)) if not group))
        if half:
            t["diffuse"].filter = (ctx.NEAREST, ctx.NEAREST)
            self.draw_mask(t, hrect)
        # full resolution, up to three Gaussians a pass: the G-buffer's depth marks the head (fragment depth
        # 1 passes where < 1)
        t["diffuse"].filter = (ctx.LINEAR, ctx.LINEAR)
        n = self.full_per_pass
        for i in range(0, len(full), n):
            self._full_gaussians(t, s, full[i:i + n], (rx, ry, rw, rh), px_per_mm, mm_per_px, clear=i == 0)
        for group, tmp_fbo, acc, size, rect_, scale, z_h, z_v in (
                (half, t["half_a_zfbo"], t["half_b_zfbo"], (hw, hh), hrect, 0.5, Z_HEAD, Z_SKIN),):  # half resolution
            t["diffuse"].filter = (ctx.NEAREST, ctx.NEAREST)
            for i, (sigma, wt) in enumerate(group):
                # the horizontal pass reads the full-resolution diffuse, the vertical one its result
                gp = self._program(self._gauss, "sss_gauss.frag", reference_taps(sigma / mm_per_px))
                self._blur_common(t, s, gp, px_per_mm, t["diffuse"], (1.0, 0.0))
                set_uniform(gp, "u_sigma_mm", sigma)
                set_uniform(gp, "u_weight", (1.0, 1.0, 1.0))
                set_uniform(gp, "u_premultiplied", 0)
                ctx.disable(ctx.BLEND)
                self.draw_pass(gp, tmp_fbo, size, rect_, z_h, clear=i == 0)
                src_tex = t["tmp"] if scale == 1.0 else t["half_a"]
                gp = self._program(self._gauss, "sss_gauss.frag", reference_taps(sigma / mm_per_px * scale))
                self._blur_common(t, s, gp, px_per_mm * scale, src_tex, (0.0, 1.0))
                set_uniform(gp, "u_sigma_mm", sigma)
                set_uniform(gp, "u_weight", tuple(float(x) for x in wt))
                set_uniform(gp, "u_premultiplied", 0 if scale == 1.0 else 1)
                set_uniform(gp, "u_cov", 1.0 / max(len(group), 1))
                ctx.enable(ctx.BLEND)
                ctx.blend_func = ctx.ONE, ctx.ONE
                self.draw_pass(gp, acc, size, rect_, z_v, clear=i == 0)
        ctx.disable(ctx.BLEND)
        self._end()
        return t["accum"], w0, whalf

    def _full_gaussians(self, t: dict[str, Any], s: RenderSettings, group: list[tuple[float, Any]], rect: Rect,
                        px_per_mm: float, mm_per_px: float, clear: bool) -> None:
        """Add up to three full-resolution Gaussians (σ mm, RGB weight) into ``t["accum"]`` in two passes.

        One horizontal pass into ``tmp``, ``tmp2``, ``tmp3`` and one vertical pass summing them
        (sss_gauss3.frag): whole-texel taps for the Gaussians :func:`render.sss.integer_radius` allows (the
        narrowest, a prefix of the group: σ grows along :data:`render.sss.SKIN_GAUSSIANS`), sub-texel taps
        for the others. ``clear``: the first group of the frame, which clears ``accum`` (else its sum is added by blending).
        """
        ctx = self.ctx
        w, h = t["accum"].size
        defines = gauss3_defines([sigma / mm_per_px for sigma, _ in group], self.integer_taps, self.subtexel_taps)
        progs = []
        for vert in (0, 1):
            key = ("gauss3", vert, *defines.values())
            if key not in self._gauss3:
                self._gauss3[key] = self.shaders.program(ctx, "fullscreen_z.vert", "sss_gauss3.frag",
                                                         {**defines, "VERT": vert})
            progs.append(self._gauss3[key])
        gp = progs[0]
        sigmas = [sigma for sigma, _ in group] + [1.0] * (3 - len(group))
        wts = np.zeros((3, 3), np.float32)
        wts[:len(group)] = [g[1] for g in group]
        self._blur_common(t, s, gp, px_per_mm, t["diffuse"], (1.0, 0.0))
        set_uniform(gp, "u_src0", 0)
        set_uniform(gp, "u_src1", 0)  # the targets are bound for the vertical pass only (no feedback loop)
        set_uniform(gp, "u_src2", 0)
        set_uniform(gp, "u_sigma_mm", tuple(sigmas))
        write_uniform(gp, "u_wt", wts)
        ctx.disable(ctx.BLEND)
        self.draw_pass(gp, t["tmp3_zfbo"] if len(group) > 1 else t["tmp_zfbo"], (w, h), rect, 1.0, clear=clear)
        t["tmp"].use(0)
        gp = progs[1]
        self._blur_common(t, s, gp, px_per_mm, t["tmp"], (0.0, 1.0))
        set_uniform(gp, "u_src0", 0)
        set_uniform(gp, "u_sigma_mm", tuple(sigmas))
        write_uniform(gp, "u_wt", wts)
        t["tmp2"].use(2)
        t["tmp3"].use(3)
        set_uniform(gp, "u_src1", 2)
        set_uniform(gp, "u_src2", 3)
        set_uniform(gp, "u_dir", (0.0, 1.0))
        if not clear:
            ctx.enable(ctx.BLEND)
            ctx.blend_func = ctx.ONE, ctx.ONE
        self.draw_pass(gp, t["accum_zfbo"], (w, h), rect, 1.0, clear=clear)
        ctx.disable(ctx.BLEND)

    def draw_mask(self, t: dict[str, Any], hrect: Rect) -> None:
        """The half-resolution pixel classes of the SSS passes (see sss_mask.frag) into the half depth.

        Read from the diffuse (nearest, as the horizontal passes read their centres); the vertical passes
        test the same mask (see :func:`render.targets.frame_targets`).
        """
        ctx = self.ctx
        hw, hh = t["half_a"].size
        t["diffuse"].use(0)
        set_uniform(self._mask, "u_src", 0)
        set_uniform(self._mask, "u_z", 0.0)
        fbo = t["half_mask_fbo"]
        fbo.depth_mask = True
        fbo.use()
        fbo.viewport = (0, 0, hw, hh)
        ctx.scissor = hrect
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "1"  # always: the mask writes every pixel of the rectangle
        ctx.disable(ctx.BLEND)
        self._quad(self._mask).render(vertices=3)

    def draw_pass(self, prog: moderngl.Program, fbo: moderngl.Framebuffer, size: tuple[int, int],
                  rect: Rect, z: float, clear: bool = False) -> None:
        """One full-screen SSS pass over ``rect`` of ``fbo`` (``size`` pixels).

        Only where the mask's depth is below the triangle's (``z``: NDC depth, see Z_HEAD / Z_SKIN); with
        ``clear``, the colour (not the mask: the ``*_zfbo`` targets never write depth) is cleared to 0 first.
        """
        ctx = self.ctx
        set_uniform(prog, "u_z", float(z))
        fbo.use()
        fbo.viewport = (0, 0, *size)
        if clear:
            ctx.scissor = None
            fbo.clear(0.0, 0.0, 0.0, 0.0)
        ctx.scissor = rect
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = ">"
        self._quad(prog).render(vertices=3)

    def _end(self) -> None:
        self.ctx.depth_func = "<"
        self.ctx.disable(self.ctx.DEPTH_TEST)

    def _blur_common(self, t: dict[str, Any], s: RenderSettings, prog: moderngl.Program, px_per_mm: float,
                     src: moderngl.Texture, direction: tuple[float, float]) -> None:
        src.use(0)
        t["factor"].use(1)
        set_uniform(prog, "u_src", 0)
        set_uniform(prog, "u_factor", 1)
        set_uniform(prog, "u_dir", direction)
        set_uniform(prog, "u_px_per_mm_at_1", float(px_per_mm))
        set_uniform(prog, "u_mm_per_unit", self.mm_per_unit)
        set_uniform(prog, "u_follow", float(s.follow_surface))
        set_uniform(prog, "u_width", float(s.sss_width))

    def release(self) -> None:
        """Free every GPU object (call with the context current)."""
        from render.glutil import release_all

        release_all(self.ctx, [*self._quads.values(), *self._fast.values(), *self._gauss.values(),
                                  *self._gauss3.values(), self._mask])
        self._quads, self._fast, self._gauss, self._gauss3 = {}, {}, {}, {}
