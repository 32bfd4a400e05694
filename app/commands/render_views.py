"""``sheer render --face DIR --view mirror|relight``: the two views of a captured shopper (issue 15).

Called by :mod:`app.commands.render` (not a command of its own): see that module's help for the options.
The views themselves are :class:`render.mirror.MirrorView` and :class:`render.mirror.RelightView`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import argparse
    from collections.abc import Callable

    import numpy as np

    from capture.face import Face
    from painting import Document
    from painting.head import Head
    from render.lights import Light

#: Options the mirror view refuses: the photograph fixes its camera, size and light.
MIRROR_REFUSES = ("size", "camera", "yaw", "pitch", "light", "light_color", "light_preset", "env", "mode",
                  "exposure")
#: Options the relight view refuses (it has its own camera and lighting model).
RELIGHT_REFUSES = ("camera", "env", "mode", "photo")


def check_view_args(args: argparse.Namespace) -> None:
    """Refuse the options ``--view`` does not take, in one line (a ``core.errors.SheerError``)."""
    from core.errors import SheerError

    for name in MIRROR_REFUSES if args.view == "mirror" else RELIGHT_REFUSES:
        if getattr(args, name, None) is not None:
            raise SheerError(f"--{name.replace('_', '-')} does not apply to --view {args.view}")
    if args.debug_view != "none":
        raise SheerError(f"--debug-view does not apply to --view {args.view}")
    if args.light_preset is not None:
        from app.settings import LIGHT_PRESETS

        if args.light_preset not in LIGHT_PRESETS:
            raise SheerError(f"--light-preset {args.light_preset!r}: one of {', '.join(LIGHT_PRESETS)}")
        if args.light:
            raise SheerError("--light and --light-preset exclude each other")


def photo_path(args: argparse.Namespace, face: Face) -> str:
    """The photograph the face was captured from, at the largest size there is.

    ``--photo``, else the original a reduced copy was made from (face.json ``source_photo`` when
    ``downscale`` says the capture reduced it, while the file exists), else face.json's ``photo`` (in the
    folder). The original draws the mirror at its own resolution.
    """
    from core.errors import SheerError

    if args.photo:
        return str(args.photo)
    original = face.original_photo_path
    if original is not None:
        return str(original)
    path = face.photo_path  # face.json's photo, relative to its folder
    if path is None:
        raise SheerError(f"{args.face}: the face folder names no photograph (face.json 'photo'): give --photo PATH")
    if not path.is_file():
        raise SheerError(f"{path}: the face's photograph is missing: give --photo PATH")
    return str(path)


def read_photo_srgb8(path: str) -> np.ndarray:
    """A photograph as uint8 sRGB (H, W, 3), upright (its EXIF orientation applied, as the capture reads it).

    A clear one-line error when it cannot be read.
    """
    import numpy as np
    from PIL import Image, UnidentifiedImageError

    from core.errors import SheerError
    from core.photos import upright

    try:
        with Image.open(path) as im:
            return np.asarray(upright(im).convert("RGB"), dtype=np.uint8)
    except FileNotFoundError:
        raise SheerError(f"{path}: photo not found") from None
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError, Image.DecompressionBombError) as exc:
        raise SheerError(f"{path}: cannot read the image: {exc}") from None


def run_view(args: argparse.Namespace, face: Face, doc: Document | None, head: Head, lights: list[Light] | None,
             size_for: Callable[[int, int], tuple[int, int]]) -> np.ndarray:
    """Render ``--view`` mirror or relight of ``face``; uint8 (H, W, 3).

    Args:
        args: the command's options (checked by :func:`check_view_args`).
        face: the captured face.
        doc: the look or project on ``head`` (None: bare).
        head: the head the face was captured on.
        lights: ``--light`` as lights (photograph units), or None.
        size_for: the relight image's size for a photograph of (width, height) pixels (``--size``, checked).
    """
    from core.errors import SheerError
    from render.binding import layer_inputs
    from render.context import standalone_context
    from render.mirror import MirrorView, RelightView

    path = photo_path(args, face) if args.view == "mirror" else None
    photo = read_photo_srgb8(path) if path is not None else None
    if photo is not None:
        from render.errors import RenderError
        from render.mirror import photo_camera_at

        try:  # her photograph at its own resolution: the capture's size, or the original it was reduced from
            photo_camera_at(face, photo.shape[1], photo.shape[0])
        except RenderError as exc:
            raise SheerError(f"{path}: {exc}") from None
    try:
        ctx = standalone_context()
    except Exception as exc:
        raise SheerError(f"cannot create an OpenGL 4.5 context (EGL): {exc}") from None
    try:
        view: MirrorView | RelightView = MirrorView(ctx, head, face, photo) if photo is not None \
            else RelightView(ctx, head, face)
        try:
            if doc is not None:
                view.set_layers(layer_inputs(doc))
            if isinstance(view, MirrorView):
                return view.render_image()
            view.yaw, view.pitch = args.yaw or 0.0, args.pitch or 0.0
            view.camera()  # a turn beyond the limit: the error before any drawing
            if args.light_preset is not None:
                from app.settings import LIGHT_PRESETS

                view.set_preset(**LIGHT_PRESETS[args.light_preset])
            if lights is not None:
                view.lights = lights
            if args.exposure is not None:
                view.exposure = args.exposure
            return view.render_image(size_for(*view.size))
        finally:
            view.release()
    finally:
        ctx.release()
