"""``sheer capture``: a relightable face from a flash photograph of a face and its 3D head (Paris et al. 2003).

    sheer capture --photo PATH --out FACE_DIR [--head PATH] [--allow-closed-eyes] [--probe PATH
                  [--probe-without-flash PATH]]   (automatic)
    sheer capture --head PATH --photo PATH (--camera FILE | --points FILE) [--probe PATH
                  [--probe-without-flash PATH]] [--mask PATH] --out FACE_DIR

**Automatic** (no ``--camera``/``--points``): MediaPipe finds the face's 478 landmarks, the quality gate
refuses a photo with no face or several, a turned or tilted head, a small face, closed eyes (unless
``--allow-closed-eyes``), blur, clipped or dark skin (each with its reason, in one line); the person's
own head is built from the face mesh (canonical topology, metric from the iris) and written into
FACE_DIR (head.obj, its sidecar, albedo.png, regions) with photo.png; the camera comes from the
landmarks. ``--head PATH`` fits that head instead of building one (its sidecar's standard landmarks);
``--full-head`` puts her face on a full head instead of the face mesh alone (the sample head's skull, ears
and neck warped onto her landmarks: :mod:`capture.full_head`).
face.json then also holds the detected landmarks (named, pixels) and the quality report; report.png
draws the landmarks. Photos over 1600 px on the longer side are downscaled (said).

- ``--camera FILE``: JSON ``{"P": [[…4], […4], […4]]}``, the 3×4 projection matrix (pixels ← mesh units).
- ``--points FILE``: JSON ``{"points": [{"name": …, "image": [x, y], "mesh": [x, y, z]}, …]}`` (≥ 6);
  image pixels x right, y down, top-left pixel centre at (0.5, 0.5).
- ``--probe PATH``: a photograph of a mirror ball cropped to the ball (same camera, flash and exposure;
  see docs/CAPTURE.md); without it, a white flash on the camera axis and no ambient light are assumed.
  ``--probe-reflectance R`` (0 < R ≤ 1, default 1: a perfect mirror) is the ball's reflectance: a chrome
  ball reflects about 0.5–0.7, and the ambient light is the ball's mean divided by it.
  ``--probe-without-flash PATH``: the same ball photographed right after, *without* the flash, at the same
  exposure and crop: the flash's colour is then read from the difference of the two, free of the room's
  texture under the flash's reflection (2–4 % per channel from one probe, within 0.2 % from two).
- ``--focal-mm F35``: with ``--points`` or automatic, the lens's 35 mm-equivalent focal length (mm,
  4–2000; over the diagonal, as EXIF's FocalLengthIn35mmFilm). Without it, the photograph's own EXIF focal
  length is used when its file has one (FocalLengthIn35mmFilm, or FocalLength with the sensor's
  resolution; an unusable tag is ignored with a warning), else a portrait-lens prior (2 × the longer side
  in pixels, about 61–72 mm). A known focal length fixes the camera's distance, so the landmarks' noise
  moves the rotation about half as much; the automatic capture also un-projects the person's head through
  it (a phone's wide lens close to the face no longer leaves its perspective in the head's shape).
  Not with ``--camera`` (a projection matrix holds its own focal length).
- ``--vignetting K1[,K2,K3]``: with ``--camera``/``--points``, the lens's light falloff towards the corners as a
  lens profile gives it (lensfun's ``pa`` model, v(r) = 1 + k1·r² + k2·r⁴ + k3·r⁶, r = 1 in the corners; e.g.
  ``-0.4`` for 40 % lost in the corners); the photograph is divided by it before the capture
  (:mod:`capture.vignetting`). Without it none is assumed: a falloff of 40 % in the corners reads i_s
  1.5–4 % low (the lobe's amplitude times the falloff where it lies).
- ``--mask PATH``: a painted skin mask (white = skin) of the photograph's size; without it, the mask is
  computed from the head's landmarks and a skin-colour model.

Units: the photograph's linear sRGB values (the sensor saturating at 1). The flash's colour has
luminance 1 and its intensity is folded into the diffuse colour D and the specular intensity i_s, so
``sheer render --face FACE_DIR --light from-capture`` (intensity 1, exposure 1) reproduces the photograph.

Writes FACE_DIR/face.json (parameters, light, camera, residuals), detail.exr (float32 detail texture in the
head's UV space), report.png (photo | fitted render | difference | detail texture with the texels the
photograph never saw in magenta, with a caption strip) and skin_mask.png. FACE_DIR's folder is checked
first: a folder that cannot be written fails in one line before the capture's work.

Prints what matters on stderr (the face found, or the camera's reprojection error from ``--points``, the
reproduction's ΔE2000, warnings and notes, what was written); ``--verbose`` prints every step (the head,
the camera, the fit's numbers, the detail texture…).
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable

    from app.commands import Subcommands
    from capture.probe import ProbeAnalysis


def register(sub: Subcommands) -> None:
    """Add ``sheer capture`` and its options to the sub-command parsers ``sub``."""
    p = sub.add_parser("capture", help="capture a relightable face from a photograph and a head",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--head", metavar="PATH", help="head mesh (glTF/GLB, OBJ, PLY); with --camera/--points default "
                   "the sample head; automatic: fit this head instead of building the person's own")
    p.add_argument("--photo", required=True, metavar="PATH", help="the flash photograph (PNG/JPEG, sRGB)")
    cam = p.add_mutually_exclusive_group()
    cam.add_argument("--camera", metavar="FILE", help="projection matrix JSON (else: automatic)")
    cam.add_argument("--points", metavar="FILE", help="2D-3D correspondences JSON (at least 6; else: automatic)")
    p.add_argument("--full-head", action="store_true",
                   help="automatic capture: her face on a full head (the sample head's skull, ears and neck warped "
                        "onto her landmarks) instead of the face mesh alone")
    p.add_argument("--allow-closed-eyes", action="store_true",
                   help="automatic capture: let closed eyes through the quality gate (e.g. the sample head's scan)")
    p.add_argument("--probe", metavar="PATH", help="mirror-ball photograph, cropped to the ball")
    p.add_argument("--probe-without-flash", metavar="PATH",
                   help="with --probe: the same ball photographed without the flash at the same exposure and crop "
                        "(the flash's colour is read from the difference)")
    p.add_argument("--probe-reflectance", type=float, default=1.0, metavar="R",
                   help="the ball's reflectance, 0 < R ≤ 1 (default 1, a perfect mirror; chrome ≈ 0.5–0.7)")
    p.add_argument("--focal-mm", type=float, default=None, metavar="F35",
                   help="with --points or automatic: the 35 mm-equivalent focal length in mm (4–2000, over the "
                        "diagonal; default: the photo's EXIF if it has one, else a portrait-lens prior)")
    p.add_argument("--vignetting", metavar="K1[,K2,K3]", default=None,
                   help="with --camera/--points: the lens's light falloff, lensfun's pa model v(r) = 1 + k1·r² + "
                        "k2·r⁴ + k3·r⁶ (r = 1 in the corners); the photo is divided by it first (default: none)")
    p.add_argument("--ambient", choices=("mean", "directional"), default="mean",
                   help="the ambient light the fit uses with --camera/--points and --probe: the probe's mean "
                        "(default) or its irradiance for each pixel's normal, E(n)/pi; directional is better "
                        "where the probe's sky does not clip and worse where lamps clip (docs/CAPTURE.md)")
    p.add_argument("--mask", metavar="PATH", help="painted skin mask (white = skin)")
    p.add_argument("--texture-size", type=int, default=None, metavar="N",
                   help="detail texture side (texels; default 1024, automatic 512: its face is at most 280 px tall)")
    p.add_argument("--starts", type=int, default=0, metavar="N",
                   help="also run the Phong fit from N random starts and report the spread (paper: 200)")
    p.add_argument("--out", required=True, metavar="FACE_DIR", help="output folder")
    p.add_argument("-v", "--verbose", action="store_true",
                   help="print every step of the capture (default: the face found or the points' reprojection "
                        "error, the reproduction, warnings, notes and what was written)")
    p.set_defaults(func=run)


#: The progress lines printed without ``--verbose``: what the capture found, the focal length and where it came
#: from (the photo's EXIF, --focal-mm or a prior: it decides the camera), the lens's falloff divided out when
#: --vignetting asks for it, how well it reproduces the photograph, and what the user should know (the capture's
#: own warnings and notes).
SUMMARY_PREFIXES = ("face found:", "focal length", "photo divided by the lens's falloff",
                    "camera from correspondences:", "reproduction:", "warning:", "note:")


def _printer(verbose: bool) -> Callable[[str], None]:
    """The capture's ``progress``: every line with ``verbose``, else the lines of :data:`SUMMARY_PREFIXES`."""

    def say(msg: str) -> None:
        if verbose or msg.startswith(SUMMARY_PREFIXES):
            print(f"capture: {msg}", file=sys.stderr, flush=True)

    return say


def run(args: argparse.Namespace) -> int:
    """Run ``sheer capture`` with the parsed ``args``; returns the exit status (0, or 2 for bad input)."""
    from capture.auto import AUTO_TEXTURE_SIZE
    from capture.camera import load_camera, load_points
    from capture.errors import CaptureError
    from capture.face import write_face
    from capture.mask import load_mask
    from capture.pipeline import capture, read_photo
    from capture.vignetting import LensFalloff, flat_field
    from core.atomicio import check_can_create
    from painting.head import load_head

    if args.texture_size is None:
        args.texture_size = 1024 if (args.camera or args.points) else AUTO_TEXTURE_SIZE
    if not 16 <= args.texture_size <= 8192:
        raise CaptureError(f"--texture-size must be between 16 and 8192, got {args.texture_size}")
    if args.starts < 0:
        raise CaptureError(f"--starts must be ≥ 0, got {args.starts}")
    if not 0.0 < args.probe_reflectance <= 1.0:  # NaN fails too
        raise CaptureError(f"--probe-reflectance must be in (0, 1], got {args.probe_reflectance}")
    if args.focal_mm is not None and args.camera:
        raise CaptureError("--focal-mm is for a capture with --points or the automatic one (a projection matrix "
                           "holds its own focal length)")
    if args.probe_reflectance != 1.0 and not args.probe:
        raise CaptureError("--probe-reflectance needs --probe (the mirror ball it describes)")
    if args.probe_without_flash and not args.probe:
        raise CaptureError("--probe-without-flash needs --probe (the same ball photographed with the flash)")
    falloff = None if args.vignetting is None else LensFalloff.parse(args.vignetting)
    check_can_create(args.out, CaptureError)  # a folder that cannot be written fails now, not after the fit
    say = _printer(args.verbose)

    if args.ambient == "directional" and not args.probe:
        raise CaptureError("--ambient directional needs --probe (the mirror ball whose sky it reads)")
    if not args.camera and not args.points:
        if falloff is not None:
            raise CaptureError("--vignetting is for a capture with --camera or --points")
        if args.ambient != "mean":
            raise CaptureError("--ambient directional is for a capture with --camera or --points")
        return run_auto(args, say)
    if args.allow_closed_eyes:
        raise CaptureError("--allow-closed-eyes is for the automatic capture (without --camera/--points)")
    if args.full_head:
        raise CaptureError("--full-head is for the automatic capture (without --camera/--points)")
    head = load_head(args.head)
    say(f"head {head.name}: {len(head.faces)} triangles, {head.mm_per_unit:g} mm per unit")
    photo = read_photo(args.photo)
    h, w = photo.shape[:2]
    say(f"photo {args.photo}: {w}×{h}")
    if falloff is not None:
        photo = flat_field(photo, falloff)
        say(f"photo divided by the lens's falloff (k1 {falloff.k1:g}, k2 {falloff.k2:g}, k3 {falloff.k3:g}: "
            f"{falloff.at(1.0):.2f} of the centre's light in the corners)")
    if args.camera:
        camera = load_camera(args.camera, w, h)
        say("camera from the projection matrix")
    else:
        from capture.exif import exif_focal_px, focal_35mm_from_px, focal_px_from_35mm

        if args.focal_mm is not None:
            focal_px, origin = focal_px_from_35mm(args.focal_mm, w, h), "--focal-mm"
        else:
            focal_px, origin = exif_focal_px(args.photo, warn=say), "the photo's EXIF"
        if focal_px is not None:
            say(f"focal length from {origin}: {focal_35mm_from_px(focal_px, w, h):.1f} mm (35 mm equivalent), "
                f"{focal_px:.0f} px")
        camera = load_points(args.points, w, h, focal_px=focal_px)
        say(f"camera from correspondences: RMS reprojection error {camera.reprojection_error_px:.2f} px, "
            f"focal length {camera.K[0, 0]:.0f} px")
    probe = read_probe(args)
    mask = load_mask(args.mask, (h, w)) if args.mask else None
    result = capture(head, photo, camera, probe=probe, mask=mask, texture_size=args.texture_size,
                     progress=say, robustness_starts=args.starts,
                     directional_ambient=args.ambient == "directional")
    # The detail texture is of the photograph divided by the falloff: face.json says so (its units: FACE_JSON_UNITS),
    # and which ambient D was fitted with.
    extra: dict[str, object] = {"fit_ambient": args.ambient}
    if falloff is not None:
        extra["vignetting"] = {"k1": falloff.k1, "k2": falloff.k2, "k3": falloff.k3}
    out = write_face(result, args.out, head_path=head.path, extra=extra)
    print(f"capture: wrote {out}/: face.json, detail.exr, report.png, skin_mask.png", file=sys.stderr)
    return 0


def read_probe(args: argparse.Namespace) -> ProbeAnalysis | None:
    """``--probe``'s mirror ball analysed (with ``--probe-without-flash``'s, if given), or None without ``--probe``.

    Both photographs are read as the face's is (EXIF orientation applied, sRGB decoded); a missing,
    unreadable or mismatched one is a one-line error naming its file.
    """
    from capture.pipeline import read_photo
    from capture.probe import analyse_probe

    if not args.probe:
        return None
    ball = read_photo(args.probe)
    without = None if not args.probe_without_flash else read_photo(args.probe_without_flash)
    return analyse_probe(ball, source=args.probe, reflectance=args.probe_reflectance, without_flash=without,
                         without_flash_source=args.probe_without_flash or "")


def run_auto(args: argparse.Namespace, say: Callable[[str], None]) -> int:
    """The automatic capture (:func:`capture.auto.capture_auto`) for ``args``; returns 0."""
    from capture.auto import capture_auto
    from capture.errors import CaptureError

    if args.mask:
        raise CaptureError("--mask is for a capture with --camera or --points (the automatic one computes it)")
    if args.starts:
        raise CaptureError("--starts is for a capture with --camera or --points")
    probe = read_probe(args)
    from capture.quality import QualityError

    try:
        face = capture_auto(args.photo, args.out, head=args.head, probe=probe,
                            allow_closed_eyes=args.allow_closed_eyes, progress=say, texture_size=args.texture_size,
                            focal_mm=args.focal_mm, full_head=args.full_head)
    except QualityError as exc:
        codes = ", ".join(i.code for i in exc.issues)
        raise CaptureError(f"{args.photo}: refused by the quality gate ({codes}): {exc}") from None
    files = "face.json, detail.exr, report.png, skin_mask.png, photo.png"
    if face.data.get("head_kind") in ("person", "full"):
        files += ", head.obj (+ sidecar, albedo.png, regions)"
    print(f"capture: wrote {args.out}/: {files}", file=sys.stderr)
    return 0
