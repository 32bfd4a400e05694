"""The face folder: what ``sheer capture`` writes and the lightweight renderer reads.

A face folder (:func:`write_face`) holds:

- ``face.json`` — parameters (:class:`capture.phong.PhongParams`), light, camera, residuals, timings,
  the separation of i_s from the albedo (``specular_separation``) and every number's unit (``units``,
  where the key's name does not say it);
- ``detail.exr`` — the detail texture, **float32** RGB in the head's UV space (top row first, the
  conventions of :mod:`painting.head`), values in [0, 2ⁿ] with n = 3 (the paper's [0, 8] range; we store
  floats rather than n doubling passes over an 8-bit texture);
- ``report.png`` — photograph | fitted Phong render | difference (ΔE2000 × 10 as grey), like Fig. 9 |
  the detail texture (×½) with the texels the photograph did not see tinted magenta, under a caption
  strip naming each panel and its scale;
- ``skin_mask.png`` — the skin pixels used.

:func:`load_face` reads one back as a :class:`Face`; :func:`face_albedo` turns it into an albedo for the
physical renderer.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from capture.errors import CaptureError
from capture.phong import PhongParams, delta_e2000
from capture.pipeline import DETAIL_DOUBLINGS, UNSEEN_FADE_MM, linear_to_srgb8, to_uint8

if TYPE_CHECKING:
    from capture.camera import Camera
    from capture.landmarks import FaceLandmarks
    from capture.pipeline import CaptureResult
    from painting.head import Head

#: face.json's ``schema_version``.
FACE_SCHEMA_VERSION = 1

#: face.json's ``units``: the unit of every number a key name does not already say (``_deg``, ``_px``,
#: ``timings_s``). "photograph units": linear sRGB, the sensor saturating at 1.
FACE_JSON_UNITS: dict[str, str] = {
    "phong.diffuse_rgb": "linear sRGB reflectance D (the detail texture averages 1 over the skin)",
    "phong.specular_intensity": "photograph units at the lobe's peak, times the flash colour",
    "phong.exponent": "dimensionless (Phong exponent s)",
    "phong.ambient_scale": "dimensionless k, relative to the probe's ambient_rgb",
    "phong.flash_rgb": "linear sRGB, luminance 1 (the flash's intensity is folded into D and i_s)",
    "phong.ambient_rgb": "photograph units (the probe's mean radiance, same exposure)",
    "light_dir_world": "unit vector towards the flash, mesh coordinates",
    "exponent.s": "dimensionless (the exponent used)", "exponent.s_saturation": "dimensionless (saturation curve)",
    "exponent.s_eq3": "dimensionless (the paper's Eq. 3)", "exponent.spec_over_diffuse": "dimensionless ratio",
    "residual.rms_luv_per_pixel": "CIE L*u*v* distance (D65), RMS over skin pixels",
    "residual.l2_luv": "CIE L*u*v* distance, L2 norm over skin pixels",
    "residual.evaluations": "model evaluations",
    "residual.ambient_scale_photo": "dimensionless k (diagnostic)",
    "residual.reproduction_mean_de2000_skin": "CIEDE2000, mean over skin pixels",
    "specular_separation.specular_intensity": "as phong.specular_intensity",
    "specular_separation.specular_intensity_joint_fit": "as phong.specular_intensity",
    "specular_separation.pixels": "skin pixels",
    "camera.K": "pixels", "camera.R": "rotation, world to camera", "camera.t": "mesh units",
    "camera.P": "pixels per mesh unit (3x4 projection)", "camera.width": "pixels", "camera.height": "pixels",
    "probe.light_dir_camera": "unit vector, camera coordinates (x right, y down, z forward)",
    "probe.flash_rgb": "linear sRGB, luminance 1", "probe.ambient_rgb": "photograph units",
    "probe.ambient_sh": "9 x RGB spherical-harmonic coefficients (l <= 2, real basis, camera coordinates) of the "
                        "irradiance E(n), photograph units x pi: the fit's ambient is k * E(n)/pi; the detail "
                        "texture and sheer render use the constant ambient_rgb",
    "probe.clipped_fraction": "fraction of the ball's pixels",
    "probe.reflectance": "dimensionless, the ball's reflectance (1 = a perfect mirror)", "probe.flash_hue_spread": "relative (0.01 = 1 %)",
    "skin_pixels": "pixels", "detail_texture.range": "dimensionless ratio (photograph / shaded model)",
    "detail_texture.size": "texels (height, width)", "detail_texture.texels_seen": "texels",
    "timings_s": "seconds", "robustness.relative_std": "std / |mean|, dimensionless",
    "vignetting.k1": "dimensionless (lensfun's pa model, r = 1 in the corners; written only when the photograph "
                     "was divided by the lens's falloff, sheer capture --vignetting)",
    "vignetting.k2": "dimensionless, as vignetting.k1", "vignetting.k3": "dimensionless, as vignetting.k1",
}

#: How a face folder's PNGs are written (Pillow's ``save`` options): zlib level 1 instead of Pillow's 6 —
#: a kiosk shopper waits for her face folder to be written, and level 6 took ~190 ms more per capture
#: (photo, albedo, report: 84 → 21, 62 → 14, 125 → 50 ms) for files only ~8 % smaller. Lossless either way.
PNG_SAVE: dict[str, int] = {"compress_level": 1}


def face_json(result: CaptureResult) -> dict[str, Any]:
    """The contents of ``face.json`` for a capture (JSON types only; the units in ``FACE_JSON_UNITS``)."""
    e = result.exponent
    return {
        "schema_version": FACE_SCHEMA_VERSION,
        "units": FACE_JSON_UNITS,
        "phong": result.params.to_json(),
        "light_dir_world": result.light_dir_world.tolist(),
        "exponent": {"s": e.s, "s_saturation": e.s_saturation, "s_eq3": e.s_eq3, "alpha_deg": e.alpha_deg, "alpha_left_deg": e.alpha_left_deg,
                     "alpha_right_deg": e.alpha_right_deg, "spec_over_diffuse": e.spec_over_diffuse},
        "residual": {"rms_luv_per_pixel": result.fit.rms_luv, "l2_luv": result.fit.l2_luv,
                     "evaluations": result.fit.evaluations,
                     "ambient_scale_photo": result.ambient_scale_photo,
                     "reproduction_mean_de2000_skin": result.reproduction_de2000_skin},
        "specular_separation": None if result.specular_separation is None else {
            "specular_intensity": result.specular_separation.specular,
            "specular_intensity_joint_fit": result.specular_joint,
            "high_pass_sigma_px": result.specular_separation.sigma_px,
            "specular_core_radius_px": result.specular_separation.core_radius_px,
            "pixels": result.specular_separation.pixels},
        "camera": result.camera.to_json(),
        "probe": None if result.probe is None else result.probe.to_json(),
        "skin_pixels": int(result.skin_mask.sum()),
        "detail_texture": {"file": "detail.exr", "storage": "float32 RGB, UV space, top row first",
                           "range": [0.0, float(2 ** DETAIL_DOUBLINGS)],
                           "size": list(result.detail.shape[:2]),
                           "texels_seen": int(result.detail_valid.sum()),
                           "unseen_fill": f"seen detail low-passed (sigma 2 mm) at the nearest seen texel "
                                          f"in 3D, faded to 1 as exp(-d / {UNSEEN_FADE_MM:g} mm)"},
        "timings_s": result.timings_s,
        "robustness": result.robustness,
    }


#: The report's difference panel: grey level 255 × ΔE2000 / ``REPORT_DE_WHITE`` (white at and above).
REPORT_DE_WHITE = 25.5


def report_image(result: CaptureResult, landmarks: dict[str, np.ndarray] | None = None) -> np.ndarray:
    """The report image of a capture, uint8 RGB (H + caption, 4W, 3) for an H × W photograph.

    Photograph (with ``landmarks``, name → pixel (x, y), drawn as green dots when given) | fitted Phong
    render (no detail) | difference (ΔE2000 as grey, white at ``REPORT_DE_WHITE`` and above, skin
    pixels) | the detail texture in UV space (× ½), with the texels the photograph did not see (filled,
    see :func:`capture.pipeline.bake_detail`) tinted magenta; a caption strip above names each panel and
    its scale.
    """
    from PIL import Image, ImageDraw, ImageFont

    photo = result.photo_lin
    h, w = photo.shape[:2]
    de = np.zeros(photo.shape[:2])
    m = result.skin_mask
    de[m] = delta_e2000(result.fitted_render[m], photo[m])
    diff = np.repeat(np.clip(de / REPORT_DE_WHITE, 0, 1)[..., None], 3, axis=2)
    det = linear_to_srgb8(np.asarray(result.detail, dtype=np.float64) * 0.5)
    tint = ~result.detail_valid
    det[tint] = (0.5 * det[tint] + 0.5 * np.array([255, 0, 255])).astype(np.uint8)
    det = np.asarray(Image.fromarray(det).resize((w, h), Image.Resampling.NEAREST))
    shown = linear_to_srgb8(photo)
    if landmarks:
        shown = _draw_points(shown, landmarks)
    panels = np.concatenate([shown, linear_to_srgb8(result.fitted_render), to_uint8(diff), det], axis=1)
    mean_de = float(de[m].mean()) if m.any() else 0.0
    # ASCII only: Pillow's built-in font has no Δ, × or ½.
    captions = ["photograph" + (f" + {len(landmarks)} landmarks" if landmarks else ""), "fitted Phong, no detail", f"dE2000 0-{REPORT_DE_WHITE:g} (skin mean {mean_de:.1f})",
                "detail x0.5 (magenta: unseen)"]
    size = max(8, min(w // 20, 24))
    strip = Image.new("RGB", (4 * w, size + size // 2), (32, 32, 32))
    draw = ImageDraw.Draw(strip)
    font = ImageFont.load_default(size=size)
    for i, text in enumerate(captions):
        while len(text) > 4 and draw.textlength(text, font=font) > w - 8:
            text = text[:-4] + "..."
        draw.text((i * w + 4, size // 4), text, fill=(230, 230, 230), font=font)
    return np.concatenate([np.asarray(strip), panels], axis=0)


def _draw_points(image: np.ndarray, points: dict[str, np.ndarray]) -> np.ndarray:
    """``image`` (uint8 RGB) with each point (pixels, x right, y down) drawn as a green dot ringed in black."""
    from PIL import Image, ImageDraw

    im = Image.fromarray(image)
    draw = ImageDraw.Draw(im)
    r = max(1.5, min(image.shape[:2]) / 200)
    for x, y in points.values():
        draw.ellipse((x - r, y - r, x + r, y + r), fill=(40, 255, 80), outline=(0, 0, 0))
    return np.asarray(im)


def write_face(result: CaptureResult, out_dir: str | Path, head_path: str | Path | None = None,
               landmarks: dict[str, np.ndarray] | None = None, extra: dict[str, Any] | None = None) -> Path:
    """Write the face folder of ``result`` into ``out_dir`` (created; see the module docstring).

    ``head_path`` (a path as the caller names it: absolute, or relative to the working directory) is
    recorded in face.json's ``head`` relative to the folder when it lies inside it, else absolute
    (:func:`recorded_path`), so the folder reads the same from any working directory. ``landmarks``
    (name → pixel (x, y)) are drawn on the report's photograph; ``extra`` keys are added to face.json
    (automatic capture: ``landmarks``, ``quality``, ``photo``…, see :mod:`capture.auto`). Returns the
    folder; :class:`CaptureError` when it cannot be created.
    """
    import OpenEXR
    from PIL import Image

    from core.atomicio import atomic_write_text

    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CaptureError(f"{out}: cannot create the output folder: {exc.strerror}") from None
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(hdr, {"RGB": np.ascontiguousarray(result.detail, dtype=np.float32)}).write(str(out / "detail.exr"))
    Image.fromarray(report_image(result, landmarks)).save(out / "report.png", **PNG_SAVE)
    Image.fromarray((result.skin_mask * 255).astype(np.uint8)).save(out / "skin_mask.png", **PNG_SAVE)
    data = face_json(result)
    data["head"] = None if head_path is None else recorded_path(head_path, out)
    data.update(extra or {})
    atomic_write_text(out / "face.json", json.dumps(data, indent=2))
    return out


def recorded_path(path: str | Path, folder: str | Path) -> str:
    """How face.json records a file: relative to the face ``folder`` when inside it, else absolute.

    ``path`` is named as the caller names it (absolute, or relative to the working directory). Every
    reader resolves face.json's relative paths against the folder (:attr:`Face.head_path`,
    :attr:`Face.photo_path`), never against its own working directory.
    """
    file = Path(os.path.abspath(path))
    try:
        return file.relative_to(os.path.abspath(folder)).as_posix()
    except ValueError:
        return str(file)


@dataclass
class Face:
    """A captured face read back from its folder.

    Attributes:
        params: the fitted Phong parameters (linear RGB, photograph units).
        detail: float32 (H, W, 3) the detail texture in the head's UV space (top row first), [0, 8].
        data: face.json as read (JSON types).
        folder: the face folder it was read from, absolute (None for one made in memory).

    What the renderer reads from it (``params``, ``detail``, :meth:`camera`, :meth:`light_dir`) is
    :class:`render.captured.CapturedFace`; face.json's camera and flash are parsed here only.
    """

    params: PhongParams
    detail: np.ndarray
    data: dict[str, Any]
    folder: Path | None = None

    def _file(self, key: str) -> Path | None:
        """face.json's file ``key``: a relative path is resolved against the folder (:func:`recorded_path`)."""
        value = self.data.get(key)
        if not isinstance(value, str) or not value:
            return None
        p = Path(value)
        return p if p.is_absolute() or self.folder is None else self.folder / p

    @property
    def head_path(self) -> Path | None:
        """The head's mesh file (face.json ``head``; a relative path is inside the folder), or None."""
        return self._file("head")

    @property
    def photo_path(self) -> Path | None:
        """The photograph as captured (automatic capture's ``photo.png``), or None."""
        return self._file("photo")

    @property
    def original_photo_path(self) -> Path | None:
        """The photograph a reduced ``photo.png`` was made from, if that file is still there; else None.

        face.json ``source_photo`` (an absolute path), when ``downscale`` says the capture reduced it.
        """
        if not self.data.get("downscale"):
            return None
        path = self._file("source_photo")
        return path if path is not None and path.is_absolute() and path.is_file() else None

    def load_head(self) -> Head:
        """The head the face was captured on (:func:`painting.head.load_head`; None in face.json: the sample head)."""
        from painting.head import load_head

        return load_head(self.head_path)

    def landmarks(self) -> FaceLandmarks | None:
        """The detected landmarks of an automatic capture (face.json ``landmarks``, pixels of photo.png), or None."""
        from capture.landmarks import FaceLandmarks

        lm = self.data.get("landmarks")
        if not isinstance(lm, dict) or "points_px" not in lm:
            return None
        return FaceLandmarks(points=np.asarray(lm["points_px"], dtype=np.float64), width=int(lm["width"]),
                             height=int(lm["height"]))

    @property
    def has_camera(self) -> bool:
        """Whether face.json has a ``camera`` (a face folder written by hand may have none)."""
        return isinstance(self.data.get("camera"), dict)

    def camera(self) -> Camera:
        """The photograph's camera (face.json ``camera``: K, R, t in the head's mesh units, the photo's size).

        Raises:
            CaptureError: naming face.json, when it has no camera or a malformed one (K and R 3×3, t 3, a
                positive size, finite numbers).
        """
        from capture.camera import Camera

        where = self.folder / "face.json" if self.folder is not None else "face.json"
        c = self.data.get("camera")
        try:
            if not isinstance(c, dict):
                raise TypeError
            K, R, t = (np.asarray(c[k], dtype=np.float64) for k in ("K", "R", "t"))
            w, h = int(c["width"]), int(c["height"])
        except (KeyError, TypeError, ValueError):
            raise CaptureError(f"{where}: no usable 'camera' (K, R, t, width, height)") from None
        if K.shape != (3, 3) or R.shape != (3, 3) or t.shape != (3,) or w < 1 or h < 1 \
                or not (np.all(np.isfinite(K)) and np.all(np.isfinite(R)) and np.all(np.isfinite(t))):
            raise CaptureError(f"{where}: the 'camera' is malformed (K and R 3×3, t 3, a positive size)")
        return Camera(K=K, R=R, t=t, width=w, height=h, reprojection_error_px=c.get("reprojection_error_px"))

    def light_dir(self) -> np.ndarray:
        """The captured flash's direction (``light_dir_world``): unit (3,) towards it, mesh coordinates.

        Raises:
            CaptureError: naming face.json, when it has no usable ``light_dir_world``.
        """
        where = self.folder / "face.json" if self.folder is not None else "face.json"
        try:
            d = np.asarray(self.data.get("light_dir_world", []), dtype=float)
        except (TypeError, ValueError):
            d = np.zeros(0)
        if d.shape != (3,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) < 1e-9:
            raise CaptureError(f"{where}: no usable 'light_dir_world'")
        return np.asarray(d / np.linalg.norm(d))


def face_albedo(face: Face) -> np.ndarray:
    """The captured skin albedo for the physical renderer, uint8 sRGB (H, W, 3) in the head's UV space.

    Detail × fitted diffuse colour, in reflectance: the Phong diffuse colour is in the photograph's units
    (the flash's intensity and the exposure are unknown, set to 1), so it is scaled by
    :func:`albedo_scale` to the reflectance of a skin, then encoded as 8-bit sRGB (what is still above 1 —
    the eyes' and teeth's highlights — clips).
    """
    lin = np.asarray(face.detail, dtype=np.float64) * np.asarray(face.params.diffuse, dtype=np.float64)[None, None, :]
    return linear_to_srgb8(lin * albedo_scale(lin))


#: Luminance (Rec. 709 / sRGB primaries) of linear RGB.
_LUMA = np.array([0.2126, 0.7152, 0.0722])


def albedo_scale(linear_rgb: np.ndarray) -> float:
    """The factor that turns a capture's diffuse colour map (photograph units, (H, W, 3)) into reflectance.

    Its median colour over the texels it covers (non-zero) is fitted by the skin model
    (:func:`km.skin.fit_skin`: melanin, blood, scattering); the map is scaled so that colour's luminance is
    the fitted skin's (Y under D65, a fraction). A photograph's skin brighter than any skin (a flash, an
    exposure, a print's gain) would otherwise give albedos of 1 and more: clipped red channels, an orange
    face. Her colour's chromaticity is kept. 1 for a map with no colour.
    """
    from km.skin import SkinError, fit_skin

    texels = linear_rgb.reshape(-1, 3)
    texels = texels[np.all(np.isfinite(texels), axis=1) & (texels.sum(axis=1) > 0)]
    if len(texels) == 0:
        return 1.0
    median = np.median(texels, axis=0)
    y_map = float(median @ _LUMA)
    if y_map <= 0:
        return 1.0
    try:
        fit = fit_skin(linear_rgb=median)
    except SkinError:
        return 1.0
    y_skin = ((float(fit.lab[0]) + 16.0) / 116.0) ** 3  # L* → Y (L* > 8)
    return y_skin / y_map


def load_face(folder: str | Path) -> Face:
    """Read a face folder written by :func:`write_face`.

    Raises :class:`capture.errors.CaptureError` naming the file for a missing or unreadable face.json
    or detail.exr, a schema_version other than ``FACE_SCHEMA_VERSION`` or malformed Phong parameters.
    """
    from painting.maps_io import MapError, read_exr_channels

    folder = Path(folder)
    try:
        data = json.loads((folder / "face.json").read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise CaptureError(f"{folder}: not a face folder (no face.json)") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise CaptureError(f"{folder / 'face.json'}: cannot read: {exc}") from None
    if not isinstance(data, dict):
        raise CaptureError(f"{folder / 'face.json'}: must be a JSON object")
    if data.get("schema_version") != FACE_SCHEMA_VERSION:
        raise CaptureError(f"{folder / 'face.json'}: unsupported schema_version {data.get('schema_version')!r}")
    try:
        channels = read_exr_channels(folder / "detail.exr")
    except MapError as exc:  # names the file; the library's own output is captured, never printed
        raise CaptureError(str(exc)) from None
    if "RGB" not in channels:
        raise CaptureError(f"{folder / 'detail.exr'}: the detail texture has no RGB channels "
                           f"(has {sorted(channels)})")
    detail = np.asarray(channels["RGB"], dtype=np.float32)
    try:
        params = PhongParams.from_json(data["phong"])
    except (KeyError, TypeError, ValueError) as exc:
        raise CaptureError(f"{folder / 'face.json'}: missing or malformed Phong parameters ({exc!r})") from None
    # the folder absolute: its files resolve against it even after the reader's working directory changed
    return Face(params=params, detail=detail, data=data, folder=Path(os.path.abspath(folder)))

