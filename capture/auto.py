"""Automatic capture: one photograph in, a face folder with the person's own head out (issue #15).

:func:`capture_auto` reads the photograph (:func:`read_photo_srgb8`: any Pillow image; EXIF rotation
applied; CMYK converted; grey-scale, truncated and unreadable files refused in one line; more than
:data:`MAX_PHOTO_SIDE` pixels on the long side downscaled, and said; then, once the face is found, a
face taller than :data:`MAX_FACE_PX` too), finds the face
(:func:`capture.landmarks.detect_faces`), passes it through the quality gate
(:func:`capture.quality.assess`; refusals raise :class:`capture.quality.QualityError` before anything is
written), builds the person's head (:func:`capture.person.person_head`) — or takes the head it is given
—, fits the photograph's camera to the 2D–3D correspondences (:func:`capture.camera.calibrate`: the DLT
and its refinement; all 468 face-mesh points for the person's own head, the named standard landmarks
for a given head), computes the skin mask (the person's head: the canonical topology's ``skin`` region
seen by the camera, refined by the skin-hue model of :func:`capture.mask.refine_by_skin_colour`; a given
head: :func:`capture.pipeline.compute_skin_mask`), runs the Paris pipeline (:func:`capture.pipeline.capture`)
and writes the face folder (:func:`capture.face.write_face` plus the head's files and ``photo.png``).

**The focal length** (:func:`photo_focal`): ``focal_mm`` (the 35 mm equivalent, ``sheer capture
--focal-mm``) if given, else the photograph file's EXIF (:func:`capture.exif.exif_focal_px`; an unusable
tag is ignored with a warning), else none (an array, such as the kiosk's camera frame, has no EXIF). A
known focal length is used three times: the quality gate reads the head's pose through it
(:func:`capture.quality.assess`), and, like the capture from points uses it, the person's head is
un-projected through it (:func:`capture.person.person_head`: the perspective of a wide lens close to the
face is undone, not left in the head's shape) and :func:`capture.camera.calibrate` holds the camera to
it (the distance then follows from the face's size). Without one, both use the portrait-lens prior
(:data:`capture.person.PORTRAIT_FOCAL`) as before. Taken in 35 mm terms, the focal length survives the
downscales; face.json's ``focal`` records the value, in mm and pixels, and where it came from.

Nothing half-written: the folder is assembled in a hidden sibling folder and renamed into place at the
end (an existing face folder at ``out_dir`` is replaced only then); any error removes the partial folder.
"""

from __future__ import annotations

import os
import shutil
import time
import uuid
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from capture.errors import CaptureError

if TYPE_CHECKING:
    from collections.abc import Callable

    from capture.camera import Camera
    from capture.face import Face
    from capture.landmarks import FaceLandmarks
    from capture.pipeline import CaptureResult, PixelData
    from capture.probe import ProbeAnalysis
    from capture.quality import QualityReport
    from painting.head import Head

#: Photographs with a longer side than this (pixels) are downscaled to it before the capture (the face
#: needs ≥ 30 % of the frame's height, so ≥ 480 px of face at this size; more costs time, not accuracy).
MAX_PHOTO_SIDE = 1600
#: Photographs whose face (the face mesh's height) is taller than this (pixels) are downscaled so it is not.
MAX_FACE_PX = 280
#: The detail texture's default side (texels): the face spans about 70 % of the canonical UV atlas, so
#: 512 texels give at least one per photograph pixel of a face :data:`MAX_FACE_PX` tall (1024 cost 25 % more
#: CPU for detail the photograph does not have).
AUTO_TEXTURE_SIZE = 512
#: The photograph, as captured (after any downscale), in the face folder.
PHOTO_FILE = "photo.png"
#: Standard landmarks needed to fit a given head's camera.
MIN_CORRESPONDENCES = 6
#: A specular intensity i_s below this (photograph units) is "no lobe found": the lobe's peak would not
#: move one code of an 8-bit sRGB photograph even at black (one code there is 1 / (255 × 12.92) ≈ 3·10⁻⁴
#: in linear units), so nothing was measured. The fit's floor (1e-6) is what it returns then.
NO_SPECULAR = 3e-4
#: Why the person's own head finds no lobe (measured, tests/capture/test_auto_intensity.py): its normals,
#: from MediaPipe's 468 points, lie ~10° (median) from the true surface's, more than the lobe's 2 px
#: high-pass tolerates.
NO_SPECULAR_PERSON = ("the head built from the landmarks is too coarse at the lobe's scale (its normals ~10° off "
                      "the face's)")


def _say(progress: Callable[[str], None] | None, msg: str) -> None:
    if progress is not None:
        progress(msg)


def read_photo_srgb8(path: str | Path) -> tuple[np.ndarray, list[str]]:
    """A photograph file as uint8 sRGB (H, W, 3), with notes on what was done to it.

    EXIF orientation is applied; CMYK is converted to RGB by Pillow (no colour management: a note says
    so); 16-bit images are scaled to 8 bits. Raises :class:`CaptureError` (one line, naming the file) for a
    missing, unreadable or truncated file, a decompression bomb, or a grey-scale photograph (the capture
    measures the skin's colour).
    """
    from PIL import Image, UnidentifiedImageError

    from core.photos import upright

    notes: list[str] = []
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(path) as im:
                im.load()  # decode now: a truncated file fails here
                mode = im.mode
                turned = upright(im)
                if mode in ("1", "L", "LA", "I", "I;16", "I;16B", "I;16L", "F"):
                    raise CaptureError(f"{path}: a grey-scale photo ({mode}); the capture measures the skin's "
                                       f"colour: use a colour photograph")
                if mode == "CMYK":
                    notes.append("CMYK photo converted to RGB without colour management (colours approximate)")
                rgb = turned.convert("RGB")
                arr = np.array(rgb, dtype=np.uint8)
    except CaptureError:
        raise
    except FileNotFoundError:
        raise CaptureError(f"{path}: photo not found") from None
    except (Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
        raise CaptureError(f"{path}: the image is too large to decode safely ({exc})") from None
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        raise CaptureError(f"{path}: cannot read the image (truncated or not an image): {exc}") from None
    return arr, notes


def prepare_photo(photo_srgb8: np.ndarray, source: str = "photo") -> tuple[np.ndarray, dict[str, Any] | None]:
    """Check a uint8 (H, W, 3) sRGB photograph, downscale it to :data:`MAX_PHOTO_SIDE` if larger.

    Returns the image and the downscale record for face.json (None when kept as it is). Grey content in an
    RGB array (every pixel R = G = B) is refused like a grey-scale file.
    """
    from capture.landmarks import check_photo_array

    arr = check_photo_array(photo_srgb8)
    step = max(1, arr.shape[0] // 256)
    sample = arr[::step, ::step].astype(np.int16)
    if np.all(sample[..., 0] == sample[..., 1]) and np.all(sample[..., 1] == sample[..., 2]):
        raise CaptureError(f"{source}: a grey-scale photo (R = G = B); the capture measures the skin's colour: "
                           f"use a colour photograph")
    h, w = arr.shape[:2]
    if max(h, w) <= MAX_PHOTO_SIDE:
        return arr, None
    k = MAX_PHOTO_SIDE / max(h, w)
    small = _resized(arr, k)
    return small, {"from": [w, h], "to": [small.shape[1], small.shape[0]], "factor": round(k, 6),
                   "why": f"longer side over {MAX_PHOTO_SIDE} px"}


def _resized(arr: np.ndarray, k: float) -> np.ndarray:
    """``arr`` (uint8 (H, W, 3)) scaled by ``k`` < 1 (Lanczos), sizes rounded."""
    from PIL import Image

    h, w = arr.shape[:2]
    size = (max(1, round(w * k)), max(1, round(h * k)))
    return np.asarray(Image.fromarray(arr).resize(size, Image.Resampling.LANCZOS, reducing_gap=3.0))


def fit_face_size(photo_srgb8: np.ndarray, face: FaceLandmarks,
                  downscale: dict[str, Any] | None) -> tuple[np.ndarray, FaceLandmarks, dict[str, Any] | None]:
    """Downscale a photograph whose face is taller than :data:`MAX_FACE_PX`, with its landmarks.

    The capture's cost grows with the skin's pixels; beyond :data:`MAX_FACE_PX` of face the detail texture
    (the face spans ≈ 700 of its 1024 texels) gains nothing. Returns the image, the landmarks scaled with
    it, and the downscale record (the earlier one, ``downscale``, composed with this one).
    """
    from capture.landmarks import FaceLandmarks

    x0, y0, x1, y1 = face.box()
    if y1 - y0 <= MAX_FACE_PX:
        return photo_srgb8, face, downscale
    h, w = photo_srgb8.shape[:2]
    small = _resized(photo_srgb8, MAX_FACE_PX / (y1 - y0))
    kx, ky = small.shape[1] / w, small.shape[0] / h
    pts = face.points * np.array([kx, ky, kx])
    scaled = FaceLandmarks(points=pts, width=small.shape[1], height=small.shape[0])
    first = downscale["from"] if downscale else [w, h]
    record = {"from": first, "to": [small.shape[1], small.shape[0]], "factor": round(small.shape[1] / first[0], 6),
              "why": (downscale["why"] + "; " if downscale else "") + f"face taller than {MAX_FACE_PX} px"}
    return small, scaled, record


def correspondences(face: FaceLandmarks, head: Head, person: bool) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """2D (pixels) ↔ 3D (mesh units) points for the camera, and their names.

    The person's own head: face-mesh vertices ↔ their detected points (every third and the standard ones). A given head: the standard
    landmarks its sidecar names (:class:`CaptureError` with fewer than :data:`MIN_CORRESPONDENCES`).
    """
    from capture.landmarks import N_MESH, STANDARD_LANDMARKS

    if person:
        # every third vertex and the standard landmarks' (the fit's cost grows with the points; 3× fewer
        # change the camera by well under a pixel)
        idx = sorted(set(range(0, N_MESH, 3)) | {i for v in STANDARD_LANDMARKS.values() for i in v})
        return face.xy[idx].copy(), np.asarray(head.vertices, dtype=np.float64)[idx], [f"mesh {i}" for i in idx]
    names = [n for n in STANDARD_LANDMARKS if n in head.metadata.landmarks and n != "gnathion"]
    if len(names) < MIN_CORRESPONDENCES:
        raise CaptureError(f"head '{head.name}': its sidecar names {len(names)} of the standard landmarks "
                           f"({', '.join(STANDARD_LANDMARKS)}); the camera needs at least {MIN_CORRESPONDENCES}")
    x = np.stack([face.point(n) for n in names])
    X = np.stack([np.asarray(head.metadata.landmarks[n], dtype=np.float64) for n in names])
    return x, X, names


def region_skin_mask(head: Head, camera: Camera, photo_lin: np.ndarray, pix: PixelData) -> np.ndarray:
    """The person's skin pixels in the photograph, bool (H, W).

    The canonical topology's ``skin`` region (≥ 0.5) on the head's pixels facing the camera (n·v > 0.25),
    refined by the skin-hue model.
    """
    from capture.mask import refine_by_skin_colour
    from capture.pipeline import sample_texture
    from painting.regions import decode_regions, regions_file

    sidecar = head.path.with_name(head.path.name + ".sheer-head.json")
    blob = regions_file(sidecar).read_bytes() if regions_file(sidecar).is_file() else None
    if blob is None:
        from capture.person import CANONICAL_REGIONS
        from core.assets import resource_path

        blob = resource_path("heads", CANONICAL_REGIONS).read_bytes()
    skin = decode_regions(blob, "canonical face regions").get("skin").mask
    on_skin = sample_texture(skin[..., None], pix.uv)[:, 0] >= 0.5
    facing = np.einsum("pc,pc->p", pix.normals, pix.view) > 0.25
    cand = np.zeros(photo_lin.shape[:2], dtype=bool)
    cand[pix.rows[on_skin & facing], pix.cols[on_skin & facing]] = True
    if cand.sum() < 200:
        raise CaptureError("the face's skin region is too small in this photograph (under 200 pixels)")
    return refine_by_skin_colour(photo_lin, cand)


def photo_focal(photo: str | Path | np.ndarray, focal_mm: float | None, size: tuple[int, int],
                progress: Callable[[str], None] | None = None) -> tuple[float | None, str, list[str]]:
    """The photograph's 35 mm-equivalent focal length (mm) and where it came from, or (None, "prior").

    ``focal_mm`` (validated: 4–2000 mm) wins; else a file's EXIF (``size``: the image as stored, (width,
    height) in either order). Returns (F35 or None, "focal_mm" | "exif" | "prior", notes): an unusable
    EXIF tag gives a note (and a progress line) and the prior.
    """
    from capture.exif import exif_focal_px, focal_35mm_from_px, focal_px_from_35mm

    if focal_mm is not None:
        focal_px_from_35mm(focal_mm, 1, 1)  # the range check's one-line error
        return float(focal_mm), "focal_mm", []
    if not isinstance(photo, (str, Path)):
        return None, "prior", []
    notes: list[str] = []

    def warn(msg: str) -> None:
        notes.append(msg)
        _say(progress, f"warning: {msg}")

    f_px = exif_focal_px(photo, warn=warn)
    if f_px is None:
        return None, "prior", notes
    return focal_35mm_from_px(f_px, *size), "exif", notes


def _check_out_dir(out: Path) -> None:
    """``out`` must be absent, empty, or a face folder (it is then replaced); :class:`CaptureError` otherwise.

    And its folder one this process can write in: checked before the capture's work, not after it.
    """
    from core.atomicio import check_can_create

    if out.exists() and (not out.is_dir() or (any(out.iterdir()) and not (out / "face.json").is_file())):
        raise CaptureError(f"{out}: exists and is not a face folder; choose a new or empty folder")
    check_can_create(out, CaptureError)


def _move_into_place(tmp: Path, out: Path) -> None:
    """Rename the finished ``tmp`` folder to ``out``, replacing an existing (face) folder there."""
    old = None
    if out.exists():
        old = out.with_name(f".{out.name}.old-{uuid.uuid4().hex[:8]}")
        os.replace(out, old)
    os.replace(tmp, out)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def warm_up() -> None:
    """Load what the first capture would (MediaPipe's detector, the canonical topology, trimesh, OpenEXR…).

    For a kiosk to call at start-up, so a shopper's first capture is as fast as the next ones
    (``sheer bench capture``: ``capture_auto_first_s`` against ``capture_auto_s``).
    """
    import OpenEXR  # noqa: F401  (the face folder's detail texture)
    import scipy.optimize  # noqa: F401  (the camera's refinement, the Phong fit)

    from capture.landmarks import face_detector
    from capture.person import canonical_topology

    face_detector()
    canonical_topology()


def capture_auto(photo: str | Path | np.ndarray, out_dir: str | Path, *, head: str | Path | Head | None = None,
                 probe: ProbeAnalysis | str | Path | None = None, allow_closed_eyes: bool = False,
                 progress: Callable[[str], None] | None = None, texture_size: int = AUTO_TEXTURE_SIZE,
                 focal_mm: float | None = None, full_head: bool = False) -> Face:
    """Capture a face from one photograph, automatically (see the module docstring).

    Args:
        photo: a photograph file, or uint8 (H, W, 3) sRGB.
        out_dir: the face folder to write (absent, empty, or a face folder, which is replaced).
        head: None builds the person's own head; a head (or its mesh file) is fitted instead.
        probe: the light: None (a white flash on the camera's axis), a probe analysis, or a mirror-ball
            photograph's file (analysed with reflectance 1).
        allow_closed_eyes: let closed eyes through the quality gate.
        progress: called with one line per step.
        texture_size: the detail texture's side (texels, 16–8192; default :data:`AUTO_TEXTURE_SIZE`).
        focal_mm: the lens's 35 mm-equivalent focal length (mm, 4–2000, over the diagonal); None: the
            photograph file's EXIF if it has a usable one, else the portrait-lens prior (see
            :func:`photo_focal`).
        full_head: with ``head`` None, capture on a full head (:func:`capture.full_head.fit_full_head`: the
            sample head's skull, ears and neck warped onto her landmarks) instead of the face mesh alone: her
            photograph's detail on her face, her fitted skin tone elsewhere (:func:`capture.full_head.blend_detail`).

    Returns:
        The face folder read back (:func:`capture.face.load_face`).

    Raises:
        QualityError: the photograph fails the quality gate (nothing written).
        CaptureError: an unreadable photograph or probe, an unusable output folder, a head without
            enough landmarks, a capture that cannot proceed (nothing written).
    """
    from capture.camera import calibrate
    from capture.face import load_face
    from capture.pipeline import capture, pixel_data
    from km.srgb import srgb_decode

    if not 16 <= int(texture_size) <= 8192:
        raise CaptureError(f"texture_size must be between 16 and 8192, got {texture_size}")
    if full_head and head is not None:
        raise CaptureError("a full head is fitted to her own landmarks: it cannot be combined with a given head")
    timings: dict[str, float] = {}
    t_all = time.perf_counter()
    out = Path(out_dir)
    _check_out_dir(out)
    srgb8, source, notes, downscale = _input_photo(photo, progress)
    # The focal length before the work (a bad --focal-mm fails here): the quality gate reads the head's pose
    # through it, as the person's head is then built (capture.person.head_pose).
    h, w = srgb8.shape[:2]
    size = (downscale["from"][0], downscale["from"][1]) if downscale else (w, h)
    f35, focal_source, focal_notes = photo_focal(photo, focal_mm, size, progress)
    notes += focal_notes
    srgb8, face, downscale, report = _gated_face(srgb8, downscale, f35, allow_closed_eyes, timings, progress)
    probe_analysis = _probe_analysis(probe)
    h, w = srgb8.shape[:2]
    focal_px, focal_record = _focal_record(f35, focal_source, w, h, progress)
    person = head is None
    the_head = _auto_head(head, face, out, report, focal_px, timings, progress)
    t = time.perf_counter()
    x, X, _ = correspondences(face, the_head, person)
    camera = calibrate(x, X, w, h, source="the detected landmarks", good_enough_px=0.5 if person else None,
                       focal_px=focal_px)
    timings["camera"] = time.perf_counter() - t
    # the person's own head is built from these landmarks, so they reproject onto themselves: no error to report
    _say(progress, f"camera from {len(x)} detected landmarks" + ("" if person else
                   f": RMS reprojection error {camera.reprojection_error_px:.2f} px"))
    photo_lin = srgb_decode(srgb8 / 255.0)
    mask = region_skin_mask(the_head, camera, photo_lin, pixel_data(the_head, camera)) if person else None
    face_only = the_head
    fit_record: dict[str, Any] | None = None
    if full_head:
        the_head, fit_record = _full_head(the_head, out, timings, progress)
    result = capture(the_head, photo_lin, camera, probe=probe_analysis, mask=mask, texture_size=int(texture_size),
                     progress=progress)
    if full_head:
        from capture.full_head import blend_detail, face_weight

        t = time.perf_counter()
        result.detail = blend_detail(the_head, result.detail, face_weight(the_head, face_only, camera.centre))
        timings["full_head_blend"] = time.perf_counter() - t
    if result.params.specular < NO_SPECULAR:
        # Said, not silent: i_s 0 reads as a matte skin, while the photograph's shine went into the detail texture.
        msg = ("no specular lobe found: i_s (0) and s are not measured" + (f"; {NO_SPECULAR_PERSON}" if person else "")
               + "; the photograph's highlights are in the detail texture")
        notes.append(msg)
        _say(progress, f"note: {msg}")
    # the original's absolute path: a copy reduced for the fit is drawn from it at its own resolution
    original = str(Path(photo).resolve()) if isinstance(photo, (str, Path)) else source
    extra = {"photo": PHOTO_FILE, "source_photo": original, "downscale": downscale, "notes": notes,
             "landmarks": {**face.to_json(), "points_px": np.round(face.points, 2).tolist()},
             "quality": report.to_json(), "head_kind": "full" if full_head else "person" if person else "given",
             "focal": focal_record}
    if fit_record is not None:
        extra["full_head"] = fit_record
    _write_face_folder(out, result, the_head, person, srgb8, face, extra, timings, t_all, full_head)
    _say(progress, f"wrote {out} in {time.perf_counter() - t_all:.1f} s")
    return load_face(out)


def _input_photo(photo: str | Path | np.ndarray, progress: Callable[[str], None] | None
                 ) -> tuple[np.ndarray, str, list[str], dict[str, Any] | None]:
    """The photograph ready for the capture (:func:`prepare_photo`), read from its file if it is one.

    Returns uint8 sRGB (H, W, 3), the name of its source, the reading's notes and the downscale (or None).
    """
    notes: list[str] = []
    if isinstance(photo, (str, Path)):
        srgb8, notes = read_photo_srgb8(photo)
        source = str(photo)
    else:
        srgb8, source = np.asarray(photo), "photo"
    srgb8, downscale = prepare_photo(srgb8, source)
    for n in notes:
        _say(progress, f"note: {n}")
    if downscale is not None:
        _say(progress, f"note: photo {downscale['from'][0]}×{downscale['from'][1]} downscaled to "
                       f"{downscale['to'][0]}×{downscale['to'][1]} (longer side over {MAX_PHOTO_SIDE} px)")
    return srgb8, source, notes, downscale


def _gated_face(srgb8: np.ndarray, downscale: dict[str, Any] | None, f35: float | None, allow_closed_eyes: bool,
                timings: dict[str, float], progress: Callable[[str], None] | None
                ) -> tuple[np.ndarray, FaceLandmarks, dict[str, Any] | None, QualityReport]:
    """The photograph's face, through the quality gate (:class:`capture.quality.QualityError` if it fails).

    Returns the photograph (downscaled when the face is taller than :data:`MAX_FACE_PX`), its face, the
    downscale and the gate's report; the detection's seconds go in ``timings``.
    """
    from capture.exif import focal_px_from_35mm
    from capture.landmarks import detect_faces
    from capture.quality import QualityError, assess

    h, w = srgb8.shape[:2]
    t = time.perf_counter()
    faces = detect_faces(srgb8)
    timings["landmarks"] = time.perf_counter() - t
    report = assess(srgb8, faces, allow_closed_eyes=allow_closed_eyes,
                    focal_px=None if f35 is None else focal_px_from_35mm(f35, w, h))
    if not report.ok:
        raise QualityError(report.issues, report)
    face, before = faces[0], srgb8.shape[:2]
    srgb8, face, downscale = fit_face_size(srgb8, face, downscale)
    if srgb8.shape[:2] != before:
        _say(progress, f"note: photo downscaled to {srgb8.shape[1]}×{srgb8.shape[0]} (the face taller than {MAX_FACE_PX} px)")
    m = report.measured
    _say(progress, f"face found: yaw {m['yaw_deg']:+.1f}°, roll {m['roll_deg']:+.1f}°, "
                   f"{100 * m['face_height_ratio']:.0f} % of the frame's height; quality gate passed")
    return srgb8, face, downscale, report


def _probe_analysis(probe: ProbeAnalysis | str | Path | None) -> ProbeAnalysis | None:
    """The probe as given, or its mirror-ball photograph's file analysed (reflectance 1)."""
    if not isinstance(probe, (str, Path)):
        return probe
    from capture.probe import analyse_probe
    from km.srgb import srgb_decode

    return analyse_probe(srgb_decode(read_photo_srgb8(probe)[0] / 255.0), source=str(probe))


def _focal_record(f35: float | None, focal_source: str, w: int, h: int,
                  progress: Callable[[str], None] | None) -> tuple[float | None, dict[str, Any]]:
    """The focal length in pixels for a ``w`` × ``h`` photo (None: calibrate's prior), and face.json's record."""
    from capture.exif import focal_35mm_from_px, focal_px_from_35mm
    from capture.person import PORTRAIT_FOCAL

    focal_px = None if f35 is None else focal_px_from_35mm(f35, w, h)
    f_used = PORTRAIT_FOCAL * max(w, h) if focal_px is None else focal_px  # the prior = calibrate's
    focal_record = {"mm_35": round(focal_35mm_from_px(f_used, w, h), 2), "px": round(f_used, 2),
                    "source": focal_source}
    _say(progress, f"focal length {focal_record['mm_35']:.1f} mm (35 mm equivalent), {f_used:.0f} px: "
                   + {"focal_mm": "given (--focal-mm)", "exif": "from the photo's EXIF",
                      "prior": "assumed (a portrait lens; no EXIF focal length)"}[focal_source])
    return focal_px, focal_record


def _auto_head(head: str | Path | Head | None, face: FaceLandmarks, out: Path, report: QualityReport,
               focal_px: float | None, timings: dict[str, float], progress: Callable[[str], None] | None) -> Head:
    """The head to capture on: the person's own (None; built into ``out``), a mesh file's, or the head given."""
    from capture.person import person_head
    from capture.quality import eyes_open
    from painting.head import load_head

    t = time.perf_counter()
    the_head: Head
    if head is None:
        the_head = person_head(face, out, eyes_open(report), focal_px=focal_px)
        _say(progress, f"person's head: {len(the_head.vertices)} vertices; {the_head.metadata.scale_note.split('; ')[0]}")
    elif isinstance(head, (str, Path)):
        the_head = load_head(head)
    else:
        the_head = head
    timings["head"] = time.perf_counter() - t
    return the_head


def _full_head(person: Head, out: Path, timings: dict[str, float], progress: Callable[[str], None] | None
               ) -> tuple[Head, dict[str, Any]]:
    """The full head fitted to the person's face-mesh head (:func:`capture.full_head.fit_full_head`), in ``out``.

    Returns it and face.json's record of the fit (residual in mm over the fitted points, the sample head's scale).
    """
    import dataclasses

    from capture.full_head import WARP_POINTS, fit_full_head
    from capture.person import HEAD_FILE

    t = time.perf_counter()
    fit = fit_full_head(person.vertices)
    head = dataclasses.replace(fit.head, path=out / HEAD_FILE)
    r = fit.residual_mm[WARP_POINTS]
    residual = {"median": round(float(np.median(r)), 3), "p95": round(float(np.percentile(r, 95)), 3),
                "max": round(float(r.max()), 3)}
    record = {"residual_mm": residual, "mm_per_sample_unit": round(fit.scale * 10.0, 3), "vertices": len(head.vertices)}
    timings["full_head"] = time.perf_counter() - t
    _say(progress, f"full head: the sample head warped onto her landmarks ({len(head.vertices)} vertices; residual "
                   f"median {residual['median']:.2f} mm, max {residual['max']:.2f} mm)")
    return head, record


def _write_face_folder(out: Path, result: CaptureResult, the_head: Head, person: bool, srgb8: np.ndarray,
                       face: FaceLandmarks, extra: dict[str, Any], timings: dict[str, float], t_all: float,
                       full_head: bool = False) -> None:
    """Write the face folder beside ``out`` and move it into place (nothing is left when it fails).

    The person's head (with the albedo the capture found) and the photograph go with it; face.json gets
    ``extra`` and the timings, the total counted from ``t_all``.
    """
    from PIL import Image

    from capture.face import PNG_SAVE, face_albedo, write_face
    from capture.face import Face as FaceRecord
    from capture.person import HEAD_FILE, write_person_head

    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.partial-{uuid.uuid4().hex[:8]}")
    try:
        tmp.mkdir()
        if person:
            albedo = face_albedo(FaceRecord(params=result.params, detail=result.detail, data={}))
            if full_head:
                from capture.full_head import write_full_head

                write_full_head(the_head, tmp, albedo)
            else:
                write_person_head(the_head, tmp, albedo)
        Image.fromarray(srgb8).save(tmp / PHOTO_FILE, **PNG_SAVE)
        timings["total"] = time.perf_counter() - t_all
        extra["auto_timings_s"] = {k: round(v, 4) for k, v in timings.items()}
        write_face(result, tmp, head_path=tmp / HEAD_FILE if person else the_head.path,
                   landmarks=face.standard(), extra=extra)
        _move_into_place(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
