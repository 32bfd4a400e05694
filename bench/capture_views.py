"""The mirror and relight views' frame times (issue 15), for ``sheer bench capture --json``.

:func:`measure` captures the synthetic ground-truth photograph of the sample head (bench/capture_synthetic.py,
512², the validation's camera), then times, at the photograph's size and interleaved with the physical
renderer's baseline (:meth:`render.renderer.Renderer.render_baseline`: same mesh and albedo, one Lambert
light, no post-processing) drawn at that size:

- ``mirror_frame_ms``: the mirror view with the red-lip look (its layers evaluated once, as a frame while
  the shopper looks);
- ``relight_frame_ms``: the relight view with the same look, turned 15°, under the kiosk's daylight preset
  (shadows on);
- ``views_swap_ms``: a product swap — the look's layers re-evaluated in texture space (``set_layers``) and one
  mirror frame and one relight frame drawn;

each with its 90th percentile and maximum (:func:`bench.stats.spread`), the baseline as ``views_baseline_ms``
and the ratios ``mirror_over_baseline``, ``relight_over_baseline`` (keys prefixed so that they sit beside the
other sections of ``sheer bench capture``).
Standalone: ``python -m bench.capture_views --json``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any


def measure(quick: bool = False, frames: int = 9) -> dict[str, Any]:
    """The views' figures (see the module docstring); ``quick``: 3 frames and a 512² detail texture."""
    from bench.capture_synthetic import make_scene, read_env
    from bench.timing import interleaved_ms
    from capture.face import Face
    from capture.pipeline import capture, linear_to_srgb8
    from capture.probe import analyse_probe
    from core.assets import find_asset
    from km import default_library
    from painting import Document
    from painting.head import load_head
    from painting.looks import apply_look, load_look
    from render.binding import layer_inputs
    from render.context import standalone_context
    from render.mirror import MirrorView, RelightView
    from render.renderer import Renderer

    frames = 3 if quick else frames
    head = load_head()
    scene = make_scene(head, read_env(str(find_asset("environments/warehouse.exr"))))
    result = capture(head, scene.photo_lin, scene.camera, probe=analyse_probe(scene.probe_lin),
                     texture_size=512 if quick else 1024)
    face = Face(params=result.params, detail=result.detail,
                data={"camera": result.camera.to_json(), "light_dir_world": result.light_dir_world.tolist()})
    photo = linear_to_srgb8(scene.photo_lin)
    doc = Document(head, resolution=1024, library=default_library())
    apply_look(doc, load_look("red-lip"))
    layers = layer_inputs(doc)
    h, w = photo.shape[:2]
    ctx = standalone_context()
    try:
        fbo = ctx.framebuffer(color_attachments=[ctx.renderbuffer((w, h), 4)],
                              depth_attachment=ctx.depth_renderbuffer((w, h)))
        base = Renderer(ctx, head)
        mirror = MirrorView(ctx, head, face, photo)
        relight = RelightView(ctx, head, face, km=mirror.km)
        try:
            mirror.set_layers(layers)
            relight.yaw = 15.0
            relight.set_preset(25.0, 35.0, (1.0, 0.98, 0.95), 2.4, (0.38, 0.40, 0.45))  # app.settings' daylight

            def swap() -> None:
                mirror.set_layers(layers)
                mirror.render(fbo)
                relight.render(fbo)

            t0 = time.perf_counter()
            out: dict[str, Any] = {"views_size": [w, h], "views_frames": frames, "views_look": "red-lip"}
            out.update(interleaved_ms(ctx, {"views_baseline_ms": lambda: base.render_baseline(fbo),
                                             "mirror_frame_ms": lambda: mirror.render(fbo),
                                             "relight_frame_ms": lambda: relight.render(fbo),
                                             "views_swap_ms": swap}, frames))
            out["mirror_over_baseline"] = out["mirror_frame_ms"] / out["views_baseline_ms"]
            out["relight_over_baseline"] = out["relight_frame_ms"] / out["views_baseline_ms"]
            out["views_seconds"] = time.perf_counter() - t0
        finally:
            relight.release()
            mirror.release()
            base.release()
            ctx.detect_framebuffer(0).use()
            fbo.release()
    finally:
        ctx.release()
    out["views_note"] = ("the synthetic ground-truth photograph of the sample head (512², validation camera), the red-lip "
                   "look; frames interleaved with the physical renderer's baseline at the same size; relight "
                   "turned 15° under the daylight preset with shadows; swap = set_layers + one frame of each view")
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m bench.capture_views [--quick] [--frames N] --json``: print :func:`measure`'s JSON; returns 0."""
    p = argparse.ArgumentParser(prog="bench.capture_views")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--frames", type=int, default=9)
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv if argv is not None else sys.argv[1:])
    print(json.dumps(measure(args.quick, args.frames), indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
