"""Test images for the automatic capture (issue #15): renders of the sample head with known cameras, and
the shared portraits altered (blurred, exposed, shrunk, doubled).

The renders use the capture's own CPU renderer (:func:`capture.pipeline.pixel_data`: the sample head
rasterised for a :class:`capture.camera.Camera`, its albedo sampled, Lambert-shaded by a light at the
camera plus a little ambient, over a grey background, optionally with that light's highlight), so the truth
of a landmark is its sidecar point projected by the same camera. Cached per process (each is ≈ 0.3 s).
"""

from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from capture.camera import Camera

DATA_POINTS = "portrait_standard_points.json"
#: Where the renders look: the sample head's face centre (mesh units).
FACE_CENTRE = (-0.1, 1.1, 2.0)


@cache
def sample_head():  # type: ignore[no-untyped-def]
    """The sample head (loaded once)."""
    from painting.head import load_head

    return load_head()


@cache
def render_sample(yaw_deg: float, size: int = 512, distance: float = 20.0, fov_deg: float = 15.0,
                  roll_deg: float = 0.0, aim_mm: float = 0.0, specular: float = 0.0,
                  exponent: float = 20.0) -> tuple[np.ndarray, Camera]:
    """The sample head seen from ``yaw_deg`` about the vertical (and rolled ``roll_deg`` in the image).

    Returns uint8 sRGB (size, size, 3) and the camera. ``distance`` in mesh units (20 ≈ 1.05 m), vertical
    field ``fov_deg``: the face fills about 60 % of the frame's height. ``aim_mm``: the camera, still at
    ``yaw_deg`` from the face, aims that far to its right of the face's centre (mm), so the face sits
    off-centre (to the left for a positive value). ``specular``: the light's white highlight added,
    i_s · max(r·v, 0)^``exponent`` with the light at the camera (r·v = 2 (n·v)² − 1): a flash photograph
    as the automatic capture assumes one (0: none, the matte render).
    """
    from capture.camera import Camera
    from capture.pipeline import linear_to_srgb8, pixel_data, sample_texture
    from km.srgb import srgb_decode

    head = sample_head()
    target = np.asarray(FACE_CENTRE)
    a = np.radians(yaw_deg)
    eye = target + distance * np.array([np.sin(a), 0.0, np.cos(a)])
    target = target + np.array([np.cos(a), 0.0, -np.sin(a)]) * aim_mm / head.mm_per_unit
    r = np.radians(roll_deg)
    up = np.array([np.sin(r), np.cos(r), 0.0])
    cam = Camera.looking_at(eye, target, up, fov_deg, size, size)
    pix = pixel_data(head, cam)
    albedo = srgb_decode(np.asarray(head.albedo, dtype=np.float64) / 255.0)
    colour = sample_texture(albedo, pix.uv)
    lambert = np.clip(np.einsum("pc,pc->p", pix.normals, pix.view), 0.0, 1.0)
    img = np.full((size, size, 3), 0.18)
    img[pix.rows, pix.cols] = colour * (0.25 + 0.9 * lambert[:, None])
    if specular:
        img[pix.rows, pix.cols] += specular * (np.clip(2 * lambert ** 2 - 1, 0.0, None) ** exponent)[:, None]
    out = linear_to_srgb8(img)
    out.flags.writeable = False
    return out, cam


#: The phone lens of :func:`phone_photo` (35 mm equivalent, mm), its photograph's side (pixels) and the
#: face's plane it frames (mm: the face about half its height, as in the bench).
LENS_MM = 26.0
PHONE_SIZE = 512
FRAME_MM = 400.0


def phone_photo(yaw_deg: float = 0.0, aim_mm: float = 0.0) -> tuple[np.ndarray, Camera]:
    """The sample head through :data:`LENS_MM` from the distance framing :data:`FRAME_MM` (34 cm): uint8 and
    the camera (``yaw_deg``, ``aim_mm`` as in :func:`render_sample`)."""
    import math

    from capture.exif import focal_px_from_35mm

    f_px = focal_px_from_35mm(LENS_MM, PHONE_SIZE, PHONE_SIZE)
    distance = f_px * FRAME_MM / PHONE_SIZE / sample_head().mm_per_unit
    fov = math.degrees(2 * math.atan(PHONE_SIZE / 2 / f_px))
    return render_sample(yaw_deg, PHONE_SIZE, distance, fov, aim_mm=aim_mm)


#: EXIF's sub-IFD and its FocalLengthIn35mmFilm tag.
EXIF_IFD = 0x8769
FOCAL_35 = 0xA405


def exif_bytes(tags: dict[int, object]) -> bytes:
    """An EXIF block (for Pillow's ``save(..., exif=)``) with ``tags`` in the EXIF sub-IFD."""
    from PIL import Image

    exif = Image.Exif()
    if tags:
        exif.get_ifd(EXIF_IFD).update(tags)
    return exif.tobytes()


def truth_points(yaw_deg: float) -> dict[str, np.ndarray]:
    """The sample head's sidecar landmarks projected into :func:`render_sample` at ``yaw_deg`` (pixels)."""
    head = sample_head()
    _, cam = render_sample(yaw_deg)
    names = list(head.metadata.landmarks)
    px, _ = cam.project(np.array([head.metadata.landmarks[n] for n in names]))
    return dict(zip(names, px))


@cache
def portrait(name: str) -> np.ndarray:
    """A shared portrait (``astronaut`` or ``grace_hopper``) as uint8 sRGB."""
    from PIL import Image

    from core.assets import find_asset

    ext = "png" if name == "astronaut" else "jpg"
    with Image.open(find_asset(f"photos/{name}.{ext}")) as im:
        arr = np.asarray(im.convert("RGB"))
    arr.flags.writeable = False
    return arr


def blurred(image: np.ndarray, sigma_px: float) -> np.ndarray:
    """``image`` Gaussian-blurred by ``sigma_px`` (Pillow's GaussianBlur radius)."""
    from PIL import Image, ImageFilter

    return np.asarray(Image.fromarray(np.asarray(image)).filter(ImageFilter.GaussianBlur(sigma_px)))


def exposed(image: np.ndarray, gain: float) -> np.ndarray:
    """``image``'s code values times ``gain``, clipped to 255 (an over- or under-exposure)."""
    return np.clip(np.asarray(image, dtype=np.float64) * gain, 0, 255).astype(np.uint8)


def tiny(image: np.ndarray, scale: float = 2.0) -> np.ndarray:
    """``image`` in the middle of a grey canvas ``scale`` times its size (the face becomes small)."""
    h, w = image.shape[:2]
    canvas = np.full((int(h * scale), int(w * scale), 3), 128, np.uint8)
    y0, x0 = (canvas.shape[0] - h) // 2, (canvas.shape[1] - w) // 2
    canvas[y0:y0 + h, x0:x0 + w] = image
    return canvas


def side_by_side(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Two images of the same height next to each other (two faces)."""
    return np.concatenate([np.asarray(a), np.asarray(b)], axis=1)
