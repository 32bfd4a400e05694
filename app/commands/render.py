"""``sheer render``: render a head wearing a look or a project to a PNG, headless (standalone EGL).

Without ``--head`` the sample head from the assets is used; without ``--look``/``--project`` the face is
bare. Lights: ``--light AZ,EL[,INTENSITY]`` (degrees; azimuth 0 = from the front, positive from the
subject's left; elevation positive from above), repeatable, up to 8; default a three-light portrait rig.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from pathlib import Path

    import moderngl
    import numpy as np

    from km.library import Library
    from painting import Document
    from painting.head import Head
    from render import Renderer

MAX_SIZE = 8192


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must look like 1280x720, got {text!r}") from None
    if not (1 <= w <= MAX_SIZE and 1 <= h <= MAX_SIZE):
        raise argparse.ArgumentTypeError(f"size must be between 1x1 and {MAX_SIZE}x{MAX_SIZE}, got {text!r}")
    return w, h


def _light(text: str) -> tuple[float, float, float]:
    import math

    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) not in (2, 3) or not all(math.isfinite(v) for v in vals):
        raise argparse.ArgumentTypeError(f"light must be AZ,EL[,INTENSITY] in degrees, got {text!r}")
    if len(vals) == 3 and vals[2] < 0:
        raise argparse.ArgumentTypeError(f"light intensity must be ≥ 0, got {text!r}")
    return (vals[0], vals[1], vals[2] if len(vals) == 3 else 1.2)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``render`` command to ``sheer``'s sub-commands."""
    p = sub.add_parser("render", help="render a made-up face to a PNG (no display needed)", description=__doc__)
    p.add_argument("--head", metavar="PATH", help="head mesh (glTF/GLB, OBJ, PLY); default: the sample head")
    src = p.add_mutually_exclusive_group()
    src.add_argument("--project", metavar="FILE", help="a .sheer project to render")
    src.add_argument("--look", metavar="NAME", help="a built-in look (bare, natural, evening, red-lip) or a look JSON")
    p.add_argument("--size", type=_size, default=(1280, 720), metavar="WxH", help="image size (default 1280x720)")
    p.add_argument("--mode", choices=("fast", "reference", "off", "lightweight"), default="fast",
                   help="subsurface scattering, or the lightweight engine for a captured face (needs --face)")
    p.add_argument("--face", metavar="FACE_DIR",
                   help="a face folder written by 'sheer capture': rendered by --mode lightweight, or its "
                        "captured albedo (detail × fitted diffuse) used by the other modes")
    p.add_argument("--light", type=_light, action="append", metavar="AZ,EL[,INTENSITY]", help="a directional light")
    p.add_argument("--env", metavar="NAME", help="HDR environment (e.g. studio, city) or an EXR path")
    p.add_argument("--env-intensity", type=float, default=0.3, metavar="E", help="mean irradiance of --env")
    p.add_argument("--yaw", type=float, default=0.0, metavar="DEG", help="camera yaw (positive: subject's left)")
    p.add_argument("--pitch", type=float, default=0.0, metavar="DEG", help="camera pitch")
    p.add_argument("--exposure", type=float, default=0.85, help="exposure multiplier")
    p.add_argument("--debug-view", default="none",
                   choices=("none", "albedo", "thickness", "r_top", "transmittance", "irradiance", "unlit"))
    p.add_argument("--debug-layer", type=int, default=0, help="layer index for --debug-view thickness")
    p.add_argument("--resolution", type=int, default=1024, help="thickness-map resolution for --look")
    p.add_argument("--out", required=True, metavar="FILE.png", help="output PNG")
    p.set_defaults(func=run)


def _check_output(path: str) -> Path:
    import os
    from pathlib import Path

    from core.errors import SheerError

    out = Path(path)
    if out.suffix.lower() != ".png":
        raise SheerError(f"{out}: the output must be a .png file")
    parent = out.absolute().parent
    if not parent.is_dir():
        raise SheerError(f"{out}: the folder {parent} does not exist")
    if out.is_dir() or not os.access(parent, os.W_OK) or (out.exists() and not os.access(out, os.W_OK)):
        raise SheerError(f"{out}: cannot write the output (permission denied or not a file)")
    return out


def run(args: argparse.Namespace) -> int:
    """Render the image ``args`` describe and write it (see the module docstring).

    Returns:
        0 (bad input raises a ``core.errors.SheerError``, which the CLI prints with exit code 2).
    """
    import math
    import sys

    from core.errors import SheerError

    out = _check_output(args.out)
    for name in ("yaw", "pitch", "exposure", "env_intensity"):
        if not math.isfinite(getattr(args, name)):
            raise SheerError(f"--{name.replace('_', '-')} must be a finite number")
    if args.light and len(args.light) > 8:
        raise SheerError(f"at most 8 --light options, got {len(args.light)}")
    face = None
    if args.mode == "lightweight" and not args.face:
        raise SheerError("--mode lightweight needs --face FACE_DIR (a folder written by 'sheer capture')")
    if args.face:  # issue 7: a captured face (lightweight engine, or its albedo in the physical one)
        from capture.face import load_face

        face = load_face(args.face)

    from painting.head import load_head

    doc = None
    if args.project:
        from project.document import document_from_project
        from project.io import open_project

        doc = document_from_project(open_project(args.project, head_path=args.head), head_path=args.head)
        head = doc.head
    elif args.look and args.look != "bare":
        from painting import Document
        from painting.looks import apply_look, load_look

        look = load_look(args.look)  # unknown look: a clear error before the slow head set-up
        head = load_head(args.head)
        _check_head(head)
        lib = _library()
        for lay in look.layers:
            lib.get(lay.material)  # unknown material: a clear error now
        doc = Document(head, resolution=args.resolution, library=lib)
        apply_look(doc, look)
    else:
        if args.look == "bare":
            from painting.looks import load_look

            load_look("bare")
        head = load_head(args.head)
        _check_head(head)

    if face is not None and args.mode != "lightweight":
        import dataclasses

        from capture.face import face_albedo

        head = dataclasses.replace(head, albedo=face_albedo(face))  # skin albedo = detail × fitted diffuse
        if doc is not None:
            doc.head = head
        face = None

    import moderngl
    from PIL import Image

    from render import DocumentBinding, Light, Renderer

    try:
        ctx = moderngl.create_context(standalone=True, backend="egl", require=450)
    except Exception as exc:
        raise SheerError(f"cannot create an OpenGL 4.5 context (EGL): {exc}") from None
    try:
        renderer = Renderer(ctx, head, layout=None if doc is None else doc.layout)
        binding = None if doc is None else DocumentBinding(doc, renderer)
        try:
            if binding is not None:
                binding.flush()
            s = renderer.settings
            s.exposure, s.debug_view = args.exposure, args.debug_view
            if args.debug_view == "thickness":  # --debug-layer is a document layer; the renderer's is a slot
                from render.view import debug_slot

                n = len(renderer.km.layers)
                if not 0 <= args.debug_layer < max(n, 1):
                    raise SheerError(f"--debug-layer {args.debug_layer}: there are {n} layers (0 to {n - 1})"
                                     if n else f"--debug-layer {args.debug_layer}: there are no layers")
                slot = debug_slot(renderer.km.active, args.debug_layer) if n else 0
                if slot is None:
                    raise SheerError(f"--debug-layer {args.debug_layer}: layer "
                                     f"'{renderer.km.layers[args.debug_layer].name}' is hidden or transparent")
                s.debug_layer = slot
            if face is None:
                s.mode = args.mode
            renderer.camera.yaw, renderer.camera.pitch = args.yaw, args.pitch
            if args.light:
                renderer.lights = [Light.directional(az, el, inten) for az, el, inten in args.light]
            if args.env:
                renderer.set_environment(args.env, args.env_intensity)
            if face is None:
                image = renderer.render_image(args.size)
            else:
                image = _render_lightweight(ctx, head, face, renderer, doc, args)
        finally:
            if binding is not None:
                binding.close()
            renderer.release()
    finally:
        ctx.release()
    tmp = out.with_name(out.name + ".tmp.png")
    try:
        Image.fromarray(image).save(tmp, format="PNG")
        tmp.replace(out)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise SheerError(f"{out}: cannot write the image: {exc.strerror or exc}") from None
    print(f"wrote {out} ({args.size[0]}×{args.size[1]}, {args.mode})", file=sys.stderr)
    return 0


def _render_lightweight(ctx: moderngl.Context, head: Head, face: object, renderer: Renderer,
                        doc: Document | None, args: argparse.Namespace) -> np.ndarray:
    """The captured ``face`` drawn by the lightweight engine (render/lightweight.py), uint8 (H, W, 3).

    Same camera, lights and environment as ``renderer``, and its texture-space KM outputs as the makeup
    (issue 7).
    """
    from render.lightweight import LightweightRenderer

    lw = LightweightRenderer(ctx, head, face)
    try:
        lw.camera = renderer.camera
        lw.lights = list(renderer.lights)
        lw.environment = renderer.environment
        lw.exposure = args.exposure
        lw.makeup = renderer.km if doc is not None else None
        return lw.render_image(args.size)
    finally:
        lw.release()


def _library() -> Library:
    import km

    return km.default_library()


def _check_head(head: Head) -> None:
    """Refuse heads the renderer cannot show sensibly: missing albedo, non-manifold meshes."""
    from core.errors import SheerError

    if head.albedo is None:
        raise SheerError(f"{head.path}: the head has no albedo texture (set 'albedo' in its metadata sidecar)")
    import numpy as np

    faces = np.asarray(head.faces)
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    if np.any(counts > 2):
        n = int(np.sum(counts > 2))
        raise SheerError(f"{head.path}: the mesh is non-manifold ({n} edges shared by more than two triangles)")
