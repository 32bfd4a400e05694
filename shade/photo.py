"""A skin colour from a region of a photograph, colour-corrected by a checker.

The region is given in pixels (the face's is found with MediaPipe's landmarks by
:mod:`capture.skin`, the one reading of a portrait's skin behind ``sheer shade match --photo`` and the
kiosk's *Find my foundation*); the camera is colour-corrected with a ColorChecker when the photograph
holds one.

- **Checker**: ``colour-checker-detection`` finds a ColorChecker Classic (24 patches) by segmentation;
  its patches' colours are mapped to the checker's reference colours under D65 (the spectral
  reflectances of colour-science's "ColorChecker N Ohta", rendered to linear sRGB by :mod:`km.colour`)
  with colour-science's characterisation (``colour.colour_correction``, Finlayson et al. 2015's
  root-polynomial of degree 2: exposure-invariant, and within ΔE2000 1.5 on the patches under the
  tinted lights we tested). The skin colour is then a reflectance colour under D65.
- **Without a checker** the photograph's sRGB values are taken as they are: the result says that the
  match assumes an sRGB camera, white balanced for the light, exposed so that white is 1.

The colour of a region is the per-channel median of its pixels whose luminance lies between the 20th
and 80th percentiles (drops highlights, shadows, hair and eyebrows), decoded to linear sRGB.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from core.errors import SheerError
from km.srgb import srgb_decode

if TYPE_CHECKING:
    from pathlib import Path

__all__ = ["PhotoError", "PhotoSkin", "read_photo", "detect_checker", "region_colour", "skin_from_photo",
           "checker_reference_rgb", "SRGB_ASSUMPTION", "MAX_PHOTO_PIXELS"]

FloatArray = NDArray[np.float64]
Box = tuple[int, int, int, int]

#: The largest photograph read (pixels; checked from the header, before decoding): read as float64,
#: 36 Mpx is 0.8 GiB.
MAX_PHOTO_PIXELS = 36_000_000
#: colour-science's characterisation method and its options.
CORRECTION_METHOD = "Finlayson 2015"
CORRECTION_DEGREE = 2
#: A detection is accepted as a checker only if its corrected patches are this close to the reference
#: (mean ΔE2000); a checker-like pattern that is not one is ignored.
CHECKER_ACCEPT_MEAN_DE2000 = 5.0
SRGB_ASSUMPTION = ("no colour checker in the photograph: the match assumes an sRGB camera, white balanced for "
                   "the light and exposed so that white is 1")


class PhotoError(SheerError, ValueError):
    """A photograph that cannot be used (unreadable, a region outside it, no face to read the skin on)."""


@dataclass(frozen=True)
class PhotoSkin:
    """The skin colour read from a photograph.

    Attributes:
        linear_rgb: linear sRGB (3,), a reflectance colour under D65 when ``checker``.
        boxes: the regions sampled, (x, y, w, h) in pixels from the top-left corner.
        source: ``region`` (given) or ``face`` (the cheeks of a detected face, :mod:`capture.skin`).
        checker: whether a colour checker corrected the camera.
        checker_de2000: mean and max ΔE2000 of the corrected patches against the reference (checker only).
        note: what the result assumes (the sRGB camera assumption without a checker).
    """

    linear_rgb: FloatArray
    boxes: tuple[Box, ...]
    source: str
    checker: bool
    checker_de2000: tuple[float, float] | None
    note: str

    def to_json(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {"linear_rgb": [round(float(v), 5) for v in self.linear_rgb], "boxes": [list(b) for b in self.boxes],
                "source": self.source, "checker": self.checker,
                "checker_de2000": None if self.checker_de2000 is None else [round(v, 3) for v in self.checker_de2000],
                "note": self.note}


def read_photo(path: str | Path) -> FloatArray:
    """The photograph as sRGB-encoded floats (H, W, 3) in [0, 1] (alpha dropped, greys expanded)."""
    from pathlib import Path

    from PIL import Image, UnidentifiedImageError

    from core.photos import upright

    p = Path(path)
    if not p.is_file():
        raise PhotoError(f"{p}: no such photograph")
    try:
        with Image.open(p) as im:
            if im.width * im.height > MAX_PHOTO_PIXELS:
                raise PhotoError(f"{p}: photograph too large ({im.width}×{im.height} px)")
            codes = np.asarray(upright(im).convert("RGB"))  # EXIF orientation applied
    except PhotoError:
        raise
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError, Image.DecompressionBombError) as exc:
        raise PhotoError(f"{p}: cannot read the photograph: {exc}") from None
    return _CODE_VALUES[codes]  # looked up once the image is closed: no float temporaries


#: The float of each 8-bit code, code / 255 (:func:`read_photo`).
_CODE_VALUES = np.arange(256, dtype=np.float64) / 255.0


@functools.lru_cache(maxsize=1)
def checker_reference_rgb() -> FloatArray:
    """Linear sRGB (24, 3) of the ColorChecker Classic's patches under D65 (Ohta's spectra, via km.colour)."""
    import colour

    from km.colour import spectrum_to_rgb
    from km.spectra import DEFAULT_GRID

    sds = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    refl = np.stack([DEFAULT_GRID.resample(np.asarray(sd.values), np.asarray(sd.wavelengths), extrapolate=True)
                     for sd in sds.values()])
    out = spectrum_to_rgb(refl, DEFAULT_GRID, "D65")
    out.setflags(write=False)
    return out


def _correct(rgb: FloatArray, swatches: FloatArray) -> FloatArray:
    import colour

    return np.asarray(colour.colour_correction(rgb, swatches, checker_reference_rgb(), method=CORRECTION_METHOD,
                                               degree=CORRECTION_DEGREE), dtype=np.float64)


def _patch_de(swatches: FloatArray) -> FloatArray:
    from km.colour import delta_e2000, linear_rgb_to_lab

    return delta_e2000(linear_rgb_to_lab(_correct(swatches, swatches)), linear_rgb_to_lab(checker_reference_rgb()))


def detect_checker(encoded: FloatArray) -> tuple[FloatArray, FloatArray] | None:
    """The ColorChecker's 24 patch colours (linear, reference order) and their corrected ΔE2000, or None.

    ``encoded``: the photograph (H, W, 3), sRGB-encoded in [0, 1]. A detection whose neutral row is not
    ordered white → black, or whose corrected patches miss the reference by more than
    :data:`CHECKER_ACCEPT_MEAN_DE2000` on average, is not a checker (None).
    """
    import colour_checker_detection as ccd

    found = ccd.detect_colour_checkers_segmentation(np.asarray(encoded, dtype=np.float32))
    for swatches_encoded in found:
        sw = srgb_decode(np.asarray(swatches_encoded, dtype=np.float64).reshape(-1, 3))
        if sw.shape != (24, 3):
            continue
        for candidate in (sw, sw[::-1]):  # the detector may read the card upside down
            luminance = candidate[18:24] @ np.array([0.2126, 0.7152, 0.0722])
            if not (np.diff(luminance) < 0).all():
                continue
            de = _patch_de(candidate)
            if float(de.mean()) <= CHECKER_ACCEPT_MEAN_DE2000:
                return candidate, de
    return None


def _check_box(box: Box, shape: tuple[int, ...], where: str) -> None:
    x, y, w, h = box
    height, width = shape[:2]
    if w <= 0 or h <= 0 or x < 0 or y < 0 or x + w > width or y + h > height:
        raise PhotoError(f"{where}: region {x},{y},{w},{h} is outside the photograph ({width}×{height} px; "
                         "give x,y,w,h in pixels from the top-left corner, inside the image)")


def region_colour(encoded: FloatArray, boxes: tuple[Box, ...]) -> FloatArray:
    """Robust linear sRGB (3,) of the pixels in ``boxes`` (see the module docstring)."""
    pixels = np.concatenate([encoded[y:y + h, x:x + w].reshape(-1, 3) for x, y, w, h in boxes])
    lin = srgb_decode(pixels)
    lum = lin @ np.array([0.2126, 0.7152, 0.0722])
    lo, hi = np.percentile(lum, [20, 80])
    keep = (lum >= lo) & (lum <= hi)
    return np.asarray(np.median(lin[keep] if keep.any() else lin, axis=0), dtype=np.float64)


def skin_from_photo(path: str | Path, region: Box, *, use_checker: bool = True, source: str = "region") -> PhotoSkin:
    """The skin colour of ``region`` (x, y, w, h pixels from the top-left) of a photograph (module docstring).

    ``source`` says where the region came from (``region``: given; ``face``: a face's cheeks).

    Raises:
        PhotoError: an unreadable photograph, or a region outside it.
    """
    encoded = read_photo(path)
    _check_box(region, encoded.shape, str(path))
    boxes: tuple[Box, ...] = (region,)
    rgb = region_colour(encoded, boxes)
    checker = detect_checker(encoded) if use_checker else None
    if checker is None:
        return PhotoSkin(rgb, boxes, source, False, None, SRGB_ASSUMPTION)
    swatches, de = checker
    corrected = _correct(rgb, swatches)
    return PhotoSkin(corrected, boxes, source, True, (float(de.mean()), float(de.max())),
                     "camera colour-corrected with the ColorChecker in the photograph (reference: D65)")
