"""``sheer render``: render a head wearing a look or a project to a PNG, headless (standalone EGL).

Without ``--head`` the sample head from the assets is used; without ``--look``/``--project`` the face is
bare. Lights: ``--light AZ,EL[,INTENSITY[,#RRGGBB]]`` (degrees; azimuth 0 = from the front, positive from
the subject's left; elevation positive from above; the colour as sRGB hex, made luminance 1 so the
intensity keeps its meaning), repeatable, up to 8; ``--light-color #RRGGBB`` colours the lights that
give none; default a three-light portrait rig. Values may start with a minus sign (``--light -12,5,1``).

A captured face (``--face FACE_DIR``, a folder written by ``sheer capture``) is drawn by the lightweight
engine by default, from the capture's own camera (the photograph's framing and size), in the
photograph's units: a light of intensity 1 is the captured flash, exposure 1 shows the photograph's
values. ``--light from-capture`` is the captured flash itself (its direction, colour and intensity 1);
the ambient light the capture measured is always part of the face. ``--camera FILE`` takes any 3×4
projection matrix (JSON ``{"P": …}``, pixels ← mesh units, as ``sheer capture --camera``) and
``--yaw``/``--pitch`` an orbit camera instead.

Two views of a captured shopper (issue 15), ``--view`` with ``--face``:

- ``--view mirror``: her photograph (``--photo PATH``, else the original a reduced capture was made from,
  else face.json's ``photo`` in the face folder) at its own size and pose, the makeup composited on the face (the photograph ÷ the capture's fitted shading, the
  layers over it, shaded again: where there is no makeup the photograph comes back unchanged).
  Takes no camera, size, light or environment options: the photograph fixes them.
- ``--view relight``: the lightweight engine from the capture's camera, turned by ``--yaw``/``--pitch``
  (degrees, each within ±25) about the neck, under ``--light`` (photograph units), a kiosk light preset
  (``--light-preset NAME``, scaled to the photograph's exposure) or, by default, the captured flash.

Defaults: intensity 1.2 and exposure 0.85 for the physical modes (display units: a white Lambert surface
facing a light of intensity 1 shows 1.0 before exposure); intensity 1 and exposure 1 for the lightweight
engine (photograph units).
"""

from __future__ import annotations

import argparse
import re
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from pathlib import Path

    import moderngl
    import numpy as np

    from app.commands import Subcommands
    from capture.camera import Camera
    from capture.face import Face
    from km.library import Library
    from painting import Document
    from painting.head import Head
    from render import Light, Renderer
    from render.camera import OrbitCamera

MAX_SIZE = 8192


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must look like 1280x720, got {text!r}") from None
    if not (1 <= w <= MAX_SIZE and 1 <= h <= MAX_SIZE):
        raise argparse.ArgumentTypeError(f"size must be between 1x1 and {MAX_SIZE}x{MAX_SIZE}, got {text!r}")
    return w, h


#: ``--light``'s value that reuses the captured flash (needs ``--face``).
FROM_CAPTURE = "from-capture"


def _colour(text: str) -> tuple[float, float, float]:
    """An sRGB hex colour ``#RRGGBB`` → linear RGB (3,) of luminance 1 (Rec. 709 weights)."""
    import re

    from km.srgb import srgb_decode

    if not re.fullmatch(r"#?[0-9a-fA-F]{6}", text):
        raise argparse.ArgumentTypeError(f"a colour must look like #RRGGBB (sRGB hex), got {text!r}")
    h = text.lstrip("#")
    lin = [float(srgb_decode(int(h[i:i + 2], 16) / 255.0)) for i in (0, 2, 4)]
    lum = 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2]
    if lum <= 0:
        raise argparse.ArgumentTypeError(f"a light's colour must not be black, got {text!r}")
    return (lin[0] / lum, lin[1] / lum, lin[2] / lum)


def _light(text: str) -> tuple[float, float, float | None, tuple[float, float, float] | None] | str:
    """``AZ,EL[,INTENSITY[,#RRGGBB]]`` → (az, el, intensity or None, colour or None), or ``from-capture``."""
    import math

    if text == FROM_CAPTURE:
        return text
    parts = text.split(",")
    colour = None
    if len(parts) == 4:
        colour = _colour(parts.pop())
    try:
        vals = [float(v) for v in parts]
    except ValueError:
        vals = []
    if len(vals) not in (2, 3) or not all(math.isfinite(v) for v in vals):
        raise argparse.ArgumentTypeError(
            f"light must be AZ,EL[,INTENSITY[,#RRGGBB]] in degrees, or {FROM_CAPTURE}, got {text!r}")
    if len(vals) == 3 and vals[2] < 0:
        raise argparse.ArgumentTypeError(f"light intensity must be ≥ 0, got {text!r}")
    return (vals[0], vals[1], vals[2] if len(vals) == 3 else None, colour)


def _builtin_looks() -> tuple[str, ...]:
    """The built-in looks (:data:`painting.looks.BUILTIN_LOOKS`; imported when the help is shown)."""
    from painting.looks import BUILTIN_LOOKS

    return BUILTIN_LOOKS


def register(sub: Subcommands) -> None:
    """Add the ``render`` command to ``sheer``'s sub-commands."""
    from app.commands import LazyHelp
    from app.settings import ENVIRONMENTS, LIGHT_PRESETS  # plain Python: no Qt, no numpy

    p = sub.add_parser("render", help="render a made-up face to a PNG (no display needed)", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    # Option values may start with a minus sign: "--light -12,5,1" (argparse takes only plain negative
    # numbers as values, and this command has no option that looks like one).
    p._negative_number_matcher = re.compile(r"^-\.?\d")  # type: ignore[attr-defined]
    p.add_argument("--head", metavar="PATH", help="head mesh (glTF/GLB, OBJ, PLY); default: the sample head, or "
                                                 "the head a --face was captured on")
    src = p.add_mutually_exclusive_group()
    src.add_argument("--project", metavar="FILE", help="a .sheer project to render")
    src.add_argument("--look", metavar="NAME", help=LazyHelp("a built-in look (%(looks)s) or a look JSON",
                                                             looks=_builtin_looks))
    p.add_argument("--size", type=_size, metavar="WxH",
                   help="image size in pixels (default 1280x720; with the capture's camera or --camera, the "
                        "photograph's size — another size must keep its aspect ratio)")
    p.add_argument("--mode", choices=("fast", "reference", "off", "lightweight"),
                   help="subsurface scattering, or the lightweight engine for a captured face (needs --face; the "
                        "default with --face, else fast)")
    p.add_argument("--face", metavar="FACE_DIR",
                   help="a face folder written by 'sheer capture': drawn by the lightweight engine from the "
                        "capture's camera, or its captured albedo (detail × fitted diffuse) used by the other modes")
    p.add_argument("--light", type=_light, action="append", metavar="AZ,EL[,INTENSITY[,#RRGGBB]]",
                   help="a directional light (degrees; intensity default 1.2 in display units, 1 = the captured "
                        f"flash with --mode lightweight); '{FROM_CAPTURE}': the captured flash (direction, colour, "
                        "intensity 1)")
    p.add_argument("--light-color", "--light-colour", type=_colour, metavar="#RRGGBB",
                   help="the colour (sRGB hex) of every --light that gives none (default white)")
    p.add_argument("--camera", metavar="FILE",
                   help="a 3×4 projection matrix JSON {\"P\": [[…], […], […]]} (pixels ← mesh units, as 'sheer "
                        "capture --camera'); the image is the size it was made for, or --size")
    p.add_argument("--env", metavar="NAME",
                   help=f"HDR environment ({', '.join(e for e in ENVIRONMENTS if e != 'none')}) or an EXR path")
    p.add_argument("--env-intensity", type=float, default=0.3, metavar="E", help="mean irradiance of --env")
    p.add_argument("--yaw", type=float, metavar="DEG",
                   help="orbit camera yaw in degrees (positive: subject's left; default 0) instead of the capture's camera; "
                        "with --view relight, the turn from the photograph's view (at most ±25)")
    p.add_argument("--pitch", type=float, metavar="DEG",
                   help="orbit camera pitch in degrees (default 0); with --view relight, the turn (at most ±25)")
    p.add_argument("--exposure", type=float,
                   help="exposure multiplier (default 0.85; 1 with --mode lightweight: the photograph's units)")
    p.add_argument("--debug-view", default="none",
                   choices=("none", "albedo", "thickness", "r_top", "transmittance", "irradiance", "unlit"))
    p.add_argument("--debug-layer", type=int, default=0, help="layer index for --debug-view thickness")
    p.add_argument("--resolution", type=int, default=1024, help="thickness-map resolution for --look")
    p.add_argument("--view", choices=("mirror", "relight"),
                   help="with --face: 'mirror' (the photograph with the makeup composited on the face, at its own "
                        "size) or 'relight' (the lightweight engine, --yaw/--pitch turn it up to ±25°)")
    p.add_argument("--photo", metavar="PATH",
                   help="--view mirror: the photograph the face was captured from, drawn at its own size (default: "
                        "the original a reduced capture was made from while it exists, else the face folder's)")
    p.add_argument("--light-preset", metavar="NAME",
                   help=f"--view relight: a kiosk light preset ({', '.join(LIGHT_PRESETS)})")
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
    import sys

    from core.errors import SheerError

    out = _check_output(args.out)
    mode = _checked_mode(args)
    face = None
    if args.face:  # issue 7: a captured face (lightweight engine, or its albedo in the physical one)
        from capture.face import load_face

        face = load_face(args.face)
    elif args.view:
        raise SheerError(f"--view {args.view} needs --face FACE_DIR (a folder written by 'sheer capture')")
    head_path = args.head if args.head or face is None else _captured_head_path(face)
    if args.view:
        return _run_view(args, out, face, head_path)
    lightweight = mode == "lightweight"
    exposure = args.exposure if args.exposure is not None else (1.0 if lightweight else 0.85)
    photo_camera = _photo_camera(args, face)
    size = _image_size(args.size, photo_camera)
    doc, head = load_document(args, head_path)

    if face is not None and not lightweight:
        import dataclasses

        from capture.face import face_albedo

        head = dataclasses.replace(head, albedo=face_albedo(face))  # skin albedo = detail × fitted diffuse
        if doc is not None:
            doc.head = head

    lights = _lights(args.light, args.light_color, face, 1.0 if lightweight else 1.2)
    image = _render(args, mode, head, doc, face, lights, exposure, photo_camera, size)
    _write_png(out, image)
    print(f"wrote {out} ({size[0]}×{size[1]}, {mode})", file=sys.stderr)
    return 0


def _checked_mode(args: argparse.Namespace) -> str:
    """The render mode ``args`` ask for, once their numbers and their combinations are checked."""
    import math

    from core.errors import SheerError

    for name in ("yaw", "pitch", "exposure", "env_intensity"):
        value = getattr(args, name)
        if value is not None and not math.isfinite(value):
            raise SheerError(f"--{name.replace('_', '-')} must be a finite number")
    if args.light and len(args.light) > 8:
        raise SheerError(f"at most 8 --light options, got {len(args.light)}")
    mode = args.mode or ("lightweight" if args.face else "fast")
    if mode == "lightweight" and not args.face:
        raise SheerError("--mode lightweight needs --face FACE_DIR (a folder written by 'sheer capture')")
    if args.light and FROM_CAPTURE in args.light and not args.face:
        raise SheerError(f"--light {FROM_CAPTURE} needs --face FACE_DIR (the capture whose flash to reuse)")
    if args.view is None and (args.photo or args.light_preset):
        raise SheerError("--photo and --light-preset need --view (mirror or relight) and --face")
    return mode


def _run_view(args: argparse.Namespace, out: Path, face: Face | None, head_path: str | None) -> int:
    """``--view mirror|relight``: the captured face's view (:mod:`app.commands.render_views`), written; 0."""
    import sys
    from types import SimpleNamespace

    from app.commands.render_views import check_view_args, run_view

    check_view_args(args)  # before the slow set-up
    doc, head = load_document(args, head_path)
    lights = _lights(args.light, args.light_color, face, 1.0)
    image = run_view(args, face, doc, head, lights,
                     lambda w, h: _image_size(args.size, SimpleNamespace(width=w, height=h)))  # type: ignore[arg-type]
    _write_png(out, image)
    print(f"wrote {out} ({image.shape[1]}×{image.shape[0]}, {args.view} view)", file=sys.stderr)
    return 0


def _render(args: argparse.Namespace, mode: str, head: Head, doc: Document | None, face: Face | None,
            lights: list[Light] | None, exposure: float, photo_camera: Camera | None,
            size: tuple[int, int]) -> np.ndarray:
    """The image, drawn in a headless context by the physical renderer or, in the lightweight mode, from the face."""
    from core.errors import SheerError
    from render import DocumentBinding, Renderer
    from render.context import standalone_context

    lightweight = mode == "lightweight"
    try:
        ctx = standalone_context()
    except Exception as exc:
        raise SheerError(f"cannot create an OpenGL 4.5 context (EGL): {exc}") from None
    try:
        renderer = Renderer(ctx, head, layout=None if doc is None else doc.layout)
        binding = None if doc is None else DocumentBinding(doc, renderer)
        try:
            if binding is not None:
                binding.flush()
            s = renderer.settings
            s.exposure, s.debug_view = exposure, args.debug_view
            if args.debug_view == "thickness":  # --debug-layer is a document layer; the renderer's is a slot
                s.debug_layer = _debug_slot(renderer, args.debug_layer)
            if not lightweight:
                s.mode = mode
            if photo_camera is not None:
                renderer.camera = _projection_camera(photo_camera, head.vertices, size)
            else:
                renderer.camera.yaw, renderer.camera.pitch = args.yaw or 0.0, args.pitch or 0.0
            if lights is not None:
                renderer.lights = lights
            if args.env:
                renderer.set_environment(args.env, args.env_intensity)
            if not lightweight:
                return renderer.render_image(size)
            assert face is not None
            return _render_lightweight(ctx, head, face, renderer, doc, exposure, size)
        finally:
            if binding is not None:
                binding.close()
            renderer.release()
    finally:
        ctx.release()


def _debug_slot(renderer: Renderer, layer: int) -> int:
    """The renderer's slot of document layer ``layer`` (``--debug-layer``), for the thickness view."""
    from core.errors import SheerError
    from render.view import debug_slot

    n = len(renderer.km.layers)
    if not 0 <= layer < max(n, 1):
        raise SheerError(f"--debug-layer {layer}: there are {n} layers (0 to {n - 1})"
                         if n else f"--debug-layer {layer}: there are no layers")
    slot = debug_slot(renderer.km.active, layer) if n else 0
    if slot is None:
        raise SheerError(f"--debug-layer {layer}: layer '{renderer.km.layers[layer].name}' is hidden or transparent")
    return slot


def _write_png(out: Path, image: np.ndarray) -> None:
    """Write ``image`` (uint8 (H, W, 3)) to ``out`` as a PNG through :func:`core.atomicio.atomic_write_with`.

    At any moment ``out`` is the complete old file or the complete new one; a failure is one
    ``SheerError`` line naming ``out``.
    """
    from PIL import Image

    from core.atomicio import atomic_write_with
    from core.errors import SheerError

    try:
        atomic_write_with(out, lambda fh: Image.fromarray(image).save(fh, format="PNG"))
    except OSError as exc:
        raise SheerError(f"{out}: cannot write the image: {exc.strerror or exc}") from None


def load_document(args: argparse.Namespace, head_path: str | None) -> tuple[Document | None, Head]:
    """The document ``--project``/``--look`` describe (None: bare) and its head, checked.

    Raises a ``core.errors.SheerError`` for an unknown look or material, a head without albedo or a
    non-manifold mesh.
    """
    from painting.head import load_head

    doc = None
    if args.project:
        from project.document import document_from_project
        from project.io import open_project

        doc = document_from_project(open_project(args.project, head_path=head_path), head_path=head_path)
        head = doc.head
    elif args.look and args.look != "bare":
        from painting import Document
        from painting.looks import apply_look, load_look

        look = load_look(args.look)  # unknown look: a clear error before the slow head set-up
        head = load_head(head_path)
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
        head = load_head(head_path)
        _check_head(head)
    return doc, head


def _captured_head_path(face: Face) -> str | None:
    """The head a face was captured on, when that file still exists, else None.

    face.json's ``head`` (:attr:`capture.face.Face.head_path`: a relative path is inside the face folder).
    """
    path = face.head_path
    return str(path) if path is not None and path.is_file() else None


def _photo_camera(args: argparse.Namespace, face: Face | None) -> Camera | None:
    """The pinhole camera to render from, or None for the orbit camera.

    ``--camera FILE``, else the capture's (``--face``, unless an orbit camera is asked for with
    ``--yaw``/``--pitch``), else None.
    """
    from capture.camera import load_camera
    from core.errors import SheerError

    if args.camera:
        if args.yaw is not None or args.pitch is not None:
            raise SheerError("--camera and --yaw/--pitch exclude each other (a projection matrix fixes the view)")
        data = _read_camera_size(args.camera)
        if data is None and args.size is None:
            raise SheerError(f"{args.camera}: give the image size with --size WxH (or 'width' and 'height' in "
                             f"the file): a projection matrix is in the pixels of one image size")
        w, h = data or args.size
        return load_camera(args.camera, w, h)
    if face is None or args.yaw is not None or args.pitch is not None or not face.has_camera:
        return None  # no face, an orbit camera asked for, or a face folder without a camera (written by hand)
    return face.camera()


def _read_camera_size(path: str) -> tuple[int, int] | None:
    """The ``width`` and ``height`` (pixels) a projection-matrix JSON names, or None when it names none."""
    import json
    from pathlib import Path

    from capture.camera import CameraError

    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise CameraError(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise CameraError(f"{path}: cannot read JSON: {exc}") from None
    if not isinstance(data, dict) or "width" not in data or "height" not in data:
        return None
    w, h = data["width"], data["height"]
    if not (isinstance(w, int) and isinstance(h, int) and 1 <= w <= MAX_SIZE and 1 <= h <= MAX_SIZE):
        raise CameraError(f"{path}: 'width' and 'height' must be whole numbers of pixels from 1 to {MAX_SIZE}")
    return w, h


def _image_size(size: tuple[int, int] | None, camera: Camera | None) -> tuple[int, int]:
    """The image size (pixels): ``--size``, else the camera's, else 1280×720.

    A size other than the camera's must keep its aspect ratio (within half a pixel).
    """
    from core.errors import SheerError

    if camera is None:
        return size or (1280, 720)
    if size is None:
        return camera.width, camera.height
    if abs(size[0] * camera.height / camera.width - size[1]) > 0.5:
        raise SheerError(f"--size {size[0]}x{size[1]}: the camera is for {camera.width}x{camera.height}; keep its "
                         f"aspect ratio (e.g. {size[0]}x{round(size[0] * camera.height / camera.width)})")
    return size


def _lights(specs: list[object] | None, colour: tuple[float, float, float] | None, face: Face | None,
            intensity: float) -> list[Light] | None:
    """The ``--light`` options as lights (None: the renderer's defaults); ``intensity`` where none is given."""
    from render import Light

    if not specs:
        return None
    out = []
    for spec in specs:
        if spec == FROM_CAPTURE:
            out.append(_captured_flash(face))
            continue
        az, el, inten, col = spec  # type: ignore[misc]
        out.append(Light.directional(az, el, intensity if inten is None else inten,
                                     col or colour or (1.0, 1.0, 1.0)))
    return out


def _captured_flash(face: Face | None) -> Light:
    """The captured flash as a light.

    face.json's ``light_dir_world`` (head space), ``phong.flash_rgb`` (luminance 1) and intensity 1 (the
    photograph's units).
    """
    from core.errors import SheerError
    from render import Light

    assert face is not None
    try:
        d = face.light_dir()
    except SheerError as exc:
        raise SheerError(f"--light {FROM_CAPTURE}: {exc}") from None
    return Light("directional", tuple(float(x) for x in d),  # type: ignore[arg-type]
                 tuple(float(x) for x in face.params.flash_rgb), 1.0, True)  # type: ignore[arg-type]


def _projection_camera(camera: Camera, vertices: np.ndarray, size: tuple[int, int]) -> OrbitCamera:
    """An orbit camera that renders exactly what the pinhole ``camera`` sees, at any ``size`` of its aspect.

    :func:`render.pinhole.pinhole_camera`; depth range from the head's vertices.
    """
    from render.pinhole import pinhole_camera

    return pinhole_camera(camera, vertices)


def _render_lightweight(ctx: moderngl.Context, head: Head, face: Face, renderer: Renderer,
                        doc: Document | None, exposure: float, size: tuple[int, int]) -> np.ndarray:
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
        lw.exposure = exposure
        lw.makeup = renderer.km if doc is not None else None
        return lw.render_image(size)
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
