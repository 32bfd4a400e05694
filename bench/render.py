"""``sheer bench render [--size 1280x720] [--frames N] --json``: frame times and texture-space KM times.

Prints one JSON object: median frame times (``ctx.finish()`` after each frame, after warm-up frames; the
modes are interleaved round-robin so that other work on a shared CPU weighs on each alike) of
the baseline (same mesh and albedo texture, one Lambert light, no post-processing), the fast and the
reference modes, their ratios, the mean ΔE2000 between fast and reference on skin pixels, and the KM
update times for full 2048² four-layer maps (the ``evening`` look painted at 2048², a realistic map:
foundation over the face, blush, eyeshadow, lipstick) and for one 64² dirty tile. Extra keys:
``km_full_2048_dense_ms`` (worst case: all four layers non-zero on every texel), ``km_tile_64_dense_ms``
(one tile of those dense maps: all four layers in it), per-tap fast timings,
``size``, ``frames`` and the GL renderer string. Lights stay fixed, so shadow maps are cached after the
first frame (as when orbiting in the studio), and so is the texture-space irradiance (see
:class:`render.irradiance.TextureIrradiance`); ``fast_relight_ms`` is a fast frame that recomputes both
(a light being dragged). Every mode uses the same single key light as the baseline (no environment).

``fast_ms`` is the studio's fast frame: the texture-space lighting cache (:mod:`render.lit_cache`) warm
(it is recomputed only when a light, the environment or a material changes); ``fast_cached_ms`` repeats
it under the issue's name, ``fast_direct_ms`` is the same frame computing every term per pixel,
``cached_over_direct`` their ratio and ``cached_vs_direct_de2000`` their mean ΔE2000 on skin;
``reference_over_fast`` the reference frame's cost in fast frames.

Where a fast frame's time goes: ``fast_lit_pass_ms`` (the lit G-buffer pass), ``fast_sss_ms`` (the SSS
passes and their masks) and ``fast_composite_ms`` (the composite and display pass), each timed with
``ctx.finish()`` on both sides in separate frames; ``reference_lit_pass_ms``, ``reference_sss_ms`` and
``reference_composite_ms`` the same for the reference frame. ``fast_floor_ms`` is the same frame with the lit pass
and the composite reduced to constant writes (the pass structure, rasterisation, targets and SSS left):
what no shading work can go below on this machine; ``fast_floor_over_baseline`` its ratio.

The frame's fixed cost, apart from pixel work: ``baseline_64x64_ms``, ``fast_64x64_ms`` and
``reference_64x64_ms``, the same frames drawn at 64×64 (driver calls, state changes, Python, the passes'
fixed overhead): on a GPU these are most of a small frame; ``fast_ms - fast_64x64_ms`` is its pixel work.

Every time reported as a median (``K``, in ms) has its 90th percentile (``K_p90``) and maximum (``K_max``)
beside it, over the same frames: a median alone hides hitches.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from bench.stats import de2000_srgb8, spread
from bench.timing import interleaved_times_ms
from painting.tiles import TILE

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

    import moderngl

    from painting import Document
    from render.km_pass import LayerInput
    from render.renderer import Renderer
    from render.shaders import ShaderLibrary


#: decimals of the milliseconds reported
DIGITS = 3


def _times_ms(ctx: moderngl.Context, fn: Callable[[], object], frames: int, warmup: int = 2) -> list[float]:
    """Milliseconds of ``frames`` calls of ``fn``, each finished on the GPU, after ``warmup`` calls."""
    for _ in range(warmup):
        fn()
    ctx.finish()
    times = []
    for _ in range(frames):
        t = time.perf_counter()
        fn()
        ctx.finish()
        times.append((time.perf_counter() - t) * 1000.0)
    return times


def pass_times(ctx: moderngl.Context, r: Renderer, fbo: moderngl.Framebuffer, frames: int,
               prefix: str = "fast") -> dict[str, float]:
    """Times (ms: median, p90, max) of the passes of ``r``'s frames into ``fbo`` (keys ``{prefix}_…``).

    The lit pass, the SSS passes (with their masks) and the composite, each bracketed by ``ctx.finish()``
    (so their sum exceeds a frame's time).
    """
    got: dict[str, list[float]] = {}

    def timed(fn: Callable[..., Any], label: str | Callable[[], str]) -> Callable[..., Any]:
        def run(*a: Any, **k: Any) -> Any:
            ctx.finish()
            t = time.perf_counter()
            out = fn(*a, **k)
            ctx.finish()
            key = label() if callable(label) else label
            got.setdefault(key, []).append((time.perf_counter() - t) * 1000.0)
            return out
        return run

    in_composite = [False]

    def composite(*a: Any, **k: Any) -> Any:
        in_composite[0] = True
        try:
            return saved[3](*a, **k)
        finally:
            in_composite[0] = False

    saved = r.gpu_head.draw, r.sss.draw_pass, r.sss.draw_mask, r.draw_composite
    # the lit pass is the mesh draw outside the composite (which draws the mesh again, inside draw_composite)
    r.gpu_head.draw = timed(saved[0], lambda: "composite_draw" if in_composite[0] else "lit")  # type: ignore[method-assign]
    r.sss.draw_pass = timed(saved[1], "sss")  # type: ignore[method-assign]
    r.sss.draw_mask = timed(saved[2], "sss")  # type: ignore[method-assign]
    r.draw_composite = timed(composite, "composite")  # type: ignore[method-assign]
    try:
        r.render(fbo)
        per_frame: dict[str, list[float]] = {"lit": [], "sss": [], "composite": []}
        for _ in range(frames):
            got.clear()
            r.render(fbo)
            for key in per_frame:
                per_frame[key].append(sum(got.get(key, [0.0])))
    finally:
        r.gpu_head.draw, r.sss.draw_pass, r.sss.draw_mask, r.draw_composite = saved  # type: ignore[method-assign]
    out: dict[str, float] = {}
    for k, v in per_frame.items():
        out.update(spread(f"{prefix}_{k}{'_pass' if k == 'lit' else ''}_ms", v, DIGITS))
    return out


def floor_shaders(folder: str | Path) -> ShaderLibrary:
    """A shader library whose lit pass and composite write constants (same outputs, same passes).

    The two shaders are written into ``folder``, which is searched before the shipped shaders.
    """
    from pathlib import Path

    from render.shaders import ShaderLibrary, default_shader_dir

    folder = Path(folder)
    for name, body in (("frame.frag", "o_diffuse = vec4(0.3, 0.25, 0.2, v_depth); o_outer = vec4(0.05); "
                                      "o_factor = vec4(0.6, 0.6, 0.6, v_depth);"),
                       ("composite.frag", "o_colour = vec4(texelFetch(u_src, ivec2(gl_FragCoord.xy) - u_origin, 0)"
                                          ".rgb, 1.0);")):
        src = (default_shader_dir() / f"{name}.glsl").read_text()
        head = src[:src.index("void main()")]
        (folder / f"{name}.glsl").write_text(f"{head}void main() {{ {body} }}\n")
    return ShaderLibrary([folder, default_shader_dir()])


def mean_de2000(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> float:
    """Mean ΔE2000 between two uint8 sRGB images over ``mask`` (km's colour maths)."""
    return float(np.mean(de2000_srgb8(a, b, mask)))


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must look like 1280x720, got {text!r}") from None
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise argparse.ArgumentTypeError(f"size must be between 16x16 and 8192x8192, got {text!r}")
    return w, h


def main(argv: list[str] | None = None) -> int:
    """Run ``sheer bench render`` with the options ``argv`` and print its JSON object; returns 0."""
    p = argparse.ArgumentParser(prog="sheer bench render", description=__doc__)
    p.add_argument("--size", type=_size, default=(1280, 720), metavar="WxH")
    p.add_argument("--frames", type=int, default=15, help="timed frames per mode (median)")
    p.add_argument("--km-resolution", type=int, default=2048)
    p.add_argument("--json", action="store_true", help="print JSON (the only output format)")
    args = p.parse_args(argv)
    from core.errors import SheerError

    if args.frames < 1:
        raise SheerError("--frames must be ≥ 1")

    from painting import Document
    from painting.looks import apply_look
    from render.context import standalone_context
    from render.km_pass import LayerInput
    from render.renderer import Renderer

    ctx = standalone_context()
    w, h = args.size
    doc = Document.from_head(resolution=args.km_resolution)
    apply_look(doc, "evening")
    r = Renderer(ctx, doc.head, layout=doc.layout)
    from render.lights import Light

    r.lights = [Light.directional(35.0, 25.0, 1.5)]
    colour = ctx.texture((w, h), 4)
    depth = ctx.depth_renderbuffer((w, h))
    fbo = ctx.framebuffer([colour], depth)
    colour_small = ctx.texture((64, 64), 4)
    depth_small = ctx.depth_renderbuffer((64, 64))
    fbo_small = ctx.framebuffer([colour_small], depth_small)
    out: dict[str, Any] = {"size": f"{w}x{h}", "frames": args.frames, "gl_renderer": ctx.info["GL_RENDERER"]}
    try:
        layers = [LayerInput(lay.material_object, np.array(lay.thickness), lay.opacity, lay.visible, lay.name)
                  for lay in doc.layers]
        out.update(_km_times(ctx, r, layers, args.frames))
        r.set_layers(layers)
        out.update(_frame_times(ctx, r, fbo, fbo_small, args.frames))
        r.settings.mode, r.settings.taps = "reference", 17
        out.update(pass_times(ctx, r, fbo, max(5, args.frames // 2), "reference"))
        r.settings.mode = "fast"
        out.update(pass_times(ctx, r, fbo, max(5, args.frames // 2)))
        out.update(_floor_times(ctx, r, doc, layers, fbo, args.frames))
        out.update({k.replace("fast_ms", "fast_cached_ms"): v for k, v in spread("fast_ms", out.pop("_fast_ms_series"),
                                                                                  DIGITS).items()})
        out["fast_over_baseline"] = out["fast_ms"] / out["baseline_ms"]
        out["reference_over_fast"] = out["reference_ms"] / out["fast_ms"]
        out["cached_over_direct"] = out["fast_ms"] / out["fast_direct_ms"]
        out["reference_over_baseline"] = out["reference_ms"] / out["baseline_ms"]
        quality, skin_pixels = _fast_vs_reference(r, (w, h))
        out.update(quality)
        out["load_average_1min"] = round(os.getloadavg()[0], 2)
        out["skin_pixels"] = skin_pixels
    finally:
        r.release()
        for obj in (fbo, colour, depth, fbo_small, colour_small, depth_small):
            obj.release()
        ctx.release()
    json.dump(_ordered(out), sys.stdout, indent=2)
    print()
    return 0


def _km_times(ctx: moderngl.Context, r: Renderer, layers: list[LayerInput], frames: int) -> dict[str, Any]:
    """Texture-space KM: all the layers evaluated, one 64² tile, the same with dense layers (every texel)."""
    from render.km_pass import LayerInput

    out: dict[str, Any] = {"km_layers": len(layers)}
    out.update(spread("km_full_2048_ms", _times_ms(ctx, lambda: r.set_layers(layers), max(5, frames // 2), 1),
                      DIGITS))
    ys, xs = np.nonzero(layers[0].thickness > 0)
    tile = (int(ys[len(ys) // 2]) // TILE, int(xs[len(xs) // 2]) // TILE)  # (row, col)
    out.update(spread("km_tile_64_ms", _times_ms(ctx, lambda: r.km.update_tiles(0, None, [tile]), frames, 2),
                      DIGITS))
    rng = np.random.default_rng(0)
    dense = [LayerInput(lay.material, (1.0 + rng.random(lay.thickness.shape, np.float32) * 20.0))
             for lay in layers]
    out.update(spread("km_full_2048_dense_ms", _times_ms(ctx, lambda: r.set_layers(dense), 2, 1), DIGITS))
    # worst-case tile: all four layers non-zero in it
    out.update(spread("km_tile_64_dense_ms",
                      _times_ms(ctx, lambda: r.km.update_tiles(0, None, [tile]), frames, 2), DIGITS))
    return out


def _frame_times(ctx: moderngl.Context, r: Renderer, fbo: moderngl.Framebuffer, fbo_small: moderngl.Framebuffer,
                 frames: int) -> dict[str, Any]:
    """Each mode's frame, interleaved round-robin (a CPU shared with other work weighs on all alike), and a relit one.

    The fast frames' series is kept under ``_fast_ms_series`` (for ``fast_cached_ms``).
    """
    def frame(mode: str, taps: int = 17, relight: bool = False, cache: bool = True) -> Callable[[], None]:
        def run() -> None:
            r.settings.mode, r.settings.taps = mode, taps
            r.settings.lighting_cache = cache
            if relight:
                r.shadows.invalidate()
                r.irradiance.invalidate()
            r.render(fbo)
        return run

    def small(mode: str) -> Callable[[], None]:  # the same frame at 64×64: what is not pixel work
        def run() -> None:
            r.settings.mode, r.settings.taps, r.settings.lighting_cache = mode, 17, True
            r.render(fbo_small)
        return run

    cases: dict[str, Callable[[], None]] = {
        "baseline_ms": lambda: r.render_baseline(fbo),
        "baseline_64x64_ms": lambda: r.render_baseline(fbo_small),
        "fast_64x64_ms": small("fast"),
        "reference_64x64_ms": small("reference"),
        "fast_ms": frame("fast"),
        "fast_direct_ms": frame("fast", cache=False),
        "reference_ms": frame("reference"),
        "no_sss_ms": frame("off"),
        "fast_11_taps_ms": frame("fast", 11),
        "fast_25_taps_ms": frame("fast", 25),
    }
    times = interleaved_times_ms(ctx, cases, frames)  # the two warm-up frames compile and fill the caches
    out: dict[str, Any] = {}
    for key, ts in times.items():
        out.update(spread(key, ts, DIGITS))
    out.update(spread("fast_relight_ms", _times_ms(ctx, frame("fast", relight=True), max(3, frames // 3), 1),
                      DIGITS))
    out["_fast_ms_series"] = times["fast_ms"]
    return out


def _floor_times(ctx: moderngl.Context, r: Renderer, doc: Document, layers: list[LayerInput],
                 fbo: moderngl.Framebuffer, frames: int) -> dict[str, Any]:
    """The fast frame with the lit pass and the composite reduced to constant writes (:func:`floor_shaders`).

    Interleaved with the baseline, like the modes; ``fast_floor_over_baseline`` their medians' ratio.
    """
    import tempfile

    from render.renderer import Renderer

    with tempfile.TemporaryDirectory() as tmp:
        floor = Renderer(ctx, doc.head, layout=doc.layout, shaders=floor_shaders(tmp))
        try:
            floor.lights = list(r.lights)
            floor.set_layers(layers)
            fl: list[float] = []
            base: list[float] = []
            for _ in range(2):
                floor.render(fbo)
            for _ in range(frames):  # interleaved with the baseline, like the modes above
                fl += _times_ms(ctx, lambda: floor.render(fbo), 1, 0)
                base += _times_ms(ctx, lambda: r.render_baseline(fbo), 1, 0)
            return {**spread("fast_floor_ms", fl, DIGITS),
                    "fast_floor_over_baseline": float(np.median(fl)) / float(np.median(base))}
        finally:
            floor.release()


def _fast_vs_reference(r: Renderer, size: tuple[int, int]) -> tuple[dict[str, Any], int]:
    """Mean ΔE2000 on skin pixels: fast against reference, and the lighting cache against the direct path.

    Returns the two figures and the number of skin pixels.
    """
    r.settings.mode = "fast"
    img_fast = r.render_image(size)
    mask = r.skin_pixel_mask()
    r.settings.mode = "reference"
    img_ref = r.render_image(size)
    out: dict[str, Any] = {"fast_vs_reference_de2000": mean_de2000(img_fast, img_ref, mask)}
    r.settings.mode, r.settings.lighting_cache = "fast", False
    img_direct = r.render_image(size)
    r.settings.lighting_cache = True
    out["cached_vs_direct_de2000"] = mean_de2000(img_fast, img_direct, mask)
    return out, int(mask.sum())


def _ordered(out: dict[str, Any]) -> dict[str, Any]:
    """The figures with the headline keys (and their spreads) first, floats to 3 decimals."""
    keys = ["baseline_ms", "fast_ms", "reference_ms", "fast_64x64_ms", "reference_64x64_ms",
            "fast_over_baseline", "reference_over_baseline",
            "fast_vs_reference_de2000", "km_full_2048_ms", "km_tile_64_ms"]
    keys = [k for key in keys for k in (key, f"{key}_p90", f"{key}_max") if k in out]  # spreads beside medians
    ordered = {k: round(out[k], 3) if isinstance(out[k], float) else out[k] for k in keys}
    ordered.update({k: (round(v, 3) if isinstance(v, float) else v) for k, v in out.items() if k not in keys})
    return ordered

if __name__ == "__main__":
    sys.exit(main())
