"""The frame's offscreen targets: the G-buffer of the lit pass and the SSS passes' buffers and masks.

One set per viewport size, made by :func:`frame_targets` and owned by the :class:`render.renderer.Renderer`
that releases them. Colour targets are RGBA16F (linear HDR, bilinear, clamped); the half-resolution ones
are ``((w + 1) // 2, (h + 1) // 2)`` pixels.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from render.errors import RenderError

if TYPE_CHECKING:
    import moderngl

#: the largest side of a frame, pixels
MAX_SIDE = 16384


def _colour(ctx: moderngl.Context, size: tuple[int, int]) -> moderngl.Texture:
    tex = ctx.texture(size, 4, dtype="f2")
    tex.repeat_x = tex.repeat_y = False
    tex.filter = (ctx.LINEAR, ctx.LINEAR)
    return tex


def frame_targets(ctx: moderngl.Context, size: tuple[int, int]) -> dict[str, Any]:
    """Every target of a frame of ``size`` (width, height in pixels, 1..:data:`MAX_SIDE`), by name.

    Textures: ``diffuse``, ``outer``, ``factor`` (the G-buffer's colours), ``tmp``, ``tmp2``, ``tmp3``,
    ``accum`` (the full-resolution SSS buffers), ``depth``; ``half_a``, ``half_b``, ``half_depth`` (half resolution).
    Framebuffers: ``gbuffer`` (bound on return), ``tmp_fbo``, ``accum_fbo``, ``half_a_fbo``,
    ``half_b_fbo``, ``half_mask_fbo``, ``tmp3_zfbo`` (``tmp``, ``tmp2``, ``tmp3``), and the ``*_zfbo`` twins of ``tmp``, ``accum``, ``half_a``,
    ``half_b`` that depth-test against a mask they never write.

    Raises:
        RenderError: a side outside 1..:data:`MAX_SIDE`.
    """
    w, h = size
    if w < 1 or h < 1 or w > MAX_SIDE or h > MAX_SIDE:
        raise RenderError(f"viewport size {w}×{h} is out of range (1..{MAX_SIDE})")
    t: dict[str, Any] = {name: _colour(ctx, size) for name in ("diffuse", "outer", "factor", "tmp", "tmp2", "tmp3",
                                                           "accum")}
    t["depth"] = ctx.depth_texture(size)
    t["gbuffer"] = ctx.framebuffer([t["diffuse"], t["outer"], t["factor"]], t["depth"])
    t["tmp_fbo"] = ctx.framebuffer([t["tmp"]])
    t["accum_fbo"] = ctx.framebuffer([t["accum"]])
    half = ((w + 1) // 2, (h + 1) // 2)
    # SSS pass targets with a depth mask (never written): the G-buffer's depth at full resolution,
    # sss_mask.frag's classes at half resolution; a depth test skips the pixels a pass leaves alone.
    # One half-resolution mask serves the horizontal and the vertical passes: a horizontal pass writes
    # its centre's class (the diffuse's alpha, nearest, at the same texel the mask read) as its alpha,
    # and leaves the pixels it skips at the cleared 0 (background), so the vertical passes' centres have
    # the mask's classes.
    t["half_depth"] = ctx.depth_texture(half)
    t["half_mask_fbo"] = ctx.framebuffer(depth_attachment=t["half_depth"])
    for name in ("tmp", "accum"):
        t[name + "_zfbo"] = ctx.framebuffer([t[name]], t["depth"])
    # the reference mode's horizontal pass of up to three full-resolution Gaussians at once (sss_gauss3.frag)
    t["tmp3_zfbo"] = ctx.framebuffer([t["tmp"], t["tmp2"], t["tmp3"]], t["depth"])
    for name in ("half_a", "half_b"):
        tex = t[name] = _colour(ctx, half)
        t[name + "_fbo"] = ctx.framebuffer([tex])
        t[name + "_zfbo"] = ctx.framebuffer([tex], t["half_depth"])
    for name in ("tmp_zfbo", "tmp3_zfbo", "accum_zfbo", "half_a_zfbo", "half_b_zfbo"):
        t[name].depth_mask = False
    t["gbuffer"].use()
    return t
