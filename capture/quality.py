"""The capture's quality gate: what an automatic capture refuses, and why, in one place.

:func:`assess` measures a photograph and its detected faces against :data:`THRESHOLDS` and returns a
:class:`QualityReport` (every measurement, every threshold, the issues found); :class:`QualityError`
carries the issues of a refused photograph, each with a ``code`` and a friendly one-line ``message``
(what the kiosk shows as a prompt). ``face.json`` records the report (``quality``).

The checks (codes):

- ``no_face`` / ``two_faces``: exactly one face must be found;
- ``turned`` / ``tilted``: the head's yaw, or its roll or pitch, beyond :data:`THRESHOLDS` (the pose of the
  detected mesh against the canonical model, :func:`capture.person.head_pose`, through the photograph's
  focal length when it is known, else the portrait-lens prior);
- ``small``: the face mesh's height under a fraction of the frame's height;
- ``eyes_closed``: the lids' gap over the eye's width (both eyes' mean) under a threshold, unless allowed
  (the sample head's scan has its eyes closed);
- ``blur``: the central face's (eye corners × brows to the lower lip, box-averaged down to at most 80 px
  wide, so the measure does not depend on the photo's resolution) Laplacian variance over its grey-level
  variance, dimensionless;
- ``clipped`` / ``dark``: the skin's pixels (the face oval less the eyes, brows and lips) with a channel
  at 250 or more, as a fraction, and their median luminance (linear, 0–1).

The thresholds were set on the two portraits in the shared assets, renders of the sample head at
−15°, 0° and +15° of yaw, and those photographs blurred, over- and under-exposed
(tests/capture/test_quality.py; the measured values are in the README's capture section).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from capture.errors import CaptureError

if TYPE_CHECKING:
    from capture.landmarks import FaceLandmarks

#: Every threshold of the gate (units in the names; "ratio" = dimensionless).
THRESHOLDS: dict[str, float] = {
    # ~15° with room for the estimate: renders of the sample head at ±15° of yaw read 15.3–15.9°.
    "max_yaw_deg": 20.0,
    "max_roll_deg": 20.0,
    "max_pitch_deg": 25.0,
    "min_face_height_ratio": 0.30,
    # open eyes measured 0.23–0.38 (the portraits, blurred too), the sample head's closed lids 0.045–0.075
    "min_eye_openness_ratio": 0.15,
    # sharp portraits 0.80–0.94, the sample head's renders 0.22–0.24; Gaussian blur σ = 1.5 px: 0.03–0.08
    "min_sharpness_ratio": 0.12,
    # Grace Hopper's portrait (bright forehead) 0.08; exposed ×1.6 0.86
    "max_clipped_skin_ratio": 0.25,
    # linear luminance (≈ sRGB code 39); the portraits 0.32–0.46, Hopper at 0.15× exposure 0.008
    "min_skin_luminance": 0.02,
}
#: The skin's clipped level (8-bit code value, any channel).
CLIPPED_CODE = 250

#: MediaPipe's face-oval contour (face-mesh indices, clockwise from the forehead's top).
FACE_OVAL = (10, 338, 297, 332, 284, 251, 389, 356, 454, 323, 361, 288, 397, 365, 379, 378, 400, 377, 152, 148,
             176, 149, 150, 136, 172, 58, 132, 93, 234, 127, 162, 21, 54, 103, 67, 109)

#: The friendly message of each code (``{value}`` filled in where it helps).
MESSAGES: dict[str, str] = {
    "no_face": "No face found: come close enough to fill the frame, look straight at the camera, in good light.",
    "two_faces": "More than one face in the picture: only one person at a time, please.",
    "turned": "Your head is turned {value:.0f}° to the side: please face the camera.",
    "tilted": "Your head is tilted {value:.0f}°: please hold it upright and look straight ahead.",
    "small": "Your face fills only {value:.0f} % of the picture's height: please come closer.",
    "eyes_closed": "Your eyes look closed: please open them and look at the camera.",
    "blur": "The picture is blurred: please hold still (and check the lens is clean).",
    "clipped": "Too much light on your face ({value:.0f} % of the skin is washed out): step back from the light.",
    "dark": "Your face is too dark: please find more light.",
}


@dataclass(frozen=True)
class QualityIssue:
    """One reason a photograph is refused: ``code`` (a key of :data:`MESSAGES`) and a friendly ``message``."""

    code: str
    message: str


@dataclass
class QualityReport:
    """The gate's findings: ``measured`` (the values, units as in :data:`THRESHOLDS`), ``issues``, ``allow_closed_eyes``."""

    measured: dict[str, float] = field(default_factory=dict)
    issues: list[QualityIssue] = field(default_factory=list)
    allow_closed_eyes: bool = False

    @property
    def ok(self) -> bool:
        """Whether the photograph passes."""
        return not self.issues

    def to_json(self) -> dict[str, Any]:
        """The report for face.json: thresholds, measured values, issues (code and message)."""
        return {"thresholds": dict(THRESHOLDS), "measured": {k: round(float(v), 4) for k, v in self.measured.items()},
                "allow_closed_eyes": self.allow_closed_eyes,
                "issues": [{"code": i.code, "message": i.message} for i in self.issues]}


class QualityError(CaptureError):
    """A photograph the quality gate refuses; ``issues`` lists every reason (code + friendly message)."""

    def __init__(self, issues: list[QualityIssue], report: QualityReport | None = None) -> None:
        self.issues = list(issues)
        self.report = report
        super().__init__(" ".join(i.message for i in self.issues))


def _issue(code: str, value: float = 0.0) -> QualityIssue:
    return QualityIssue(code, MESSAGES[code].format(value=value))


def sharpness(photo_srgb8: np.ndarray, face: FaceLandmarks) -> float:
    """The central face's Laplacian variance over its grey-level variance (see the module docstring), ratio."""
    from PIL import Image
    from scipy import ndimage

    xy = face.xy
    x0, x1 = float(xy[33, 0]), float(xy[263, 0])
    y0, y1 = float(xy[[52, 282], 1].min()), float(xy[17, 1])
    x0, x1 = sorted((x0, x1))
    box = (max(int(x0), 0), max(int(y0), 0), min(int(np.ceil(x1)), face.width), min(int(np.ceil(y1)), face.height))
    if box[2] - box[0] < 4 or box[3] - box[1] < 4:
        return 0.0
    crop = Image.fromarray(photo_srgb8).crop(box).convert("L")
    k = min(1.0, 80.0 / crop.size[0])
    if k < 1.0:
        crop = crop.resize((max(8, round(crop.size[0] * k)), max(8, round(crop.size[1] * k))), Image.Resampling.BOX)
    g = np.asarray(crop, dtype=np.float64) / 255.0
    return float(ndimage.laplace(g).var() / max(float(g.var()), 1e-9))


def skin_pixels(photo_srgb8: np.ndarray, face: FaceLandmarks) -> np.ndarray:
    """The photograph's skin pixels: inside the face oval, outside the eyes, brows and lips; uint8 (N, 3).

    A large face is sampled on a grid (about 40,000 pixels tested at most).
    """
    from matplotlib.path import Path as MplPath

    from painting.region_shapes import CONTOURS

    xy = face.xy
    x0, y0, x1, y1 = (int(v) for v in face.box())
    x0, y0 = max(x0, 0), max(y0, 0)
    x1, y1 = min(x1 + 1, face.width), min(y1 + 1, face.height)
    if x1 <= x0 or y1 <= y0:
        return np.zeros((0, 3), np.uint8)
    # at most ~40k pixels tested (every step-th row and column of a large face: the gate's statistics
    # are fractions and medians, and a live preview calls this every frame)
    step = max(1, int(np.ceil(np.sqrt((x1 - x0) * (y1 - y0) / 40_000))))
    yy, xx = np.mgrid[y0:y1:step, x0:x1:step]
    pts = np.stack([xx.ravel() + 0.5, yy.ravel() + 0.5], axis=1)
    inside = MplPath(xy[list(FACE_OVAL)]).contains_points(pts)
    holes = [("lipsUpperOuter", "lipsLowerOuter")] + [
        (f"{s}EyeUpper0", f"{s}EyeLower0") for s in ("left", "right")] + [
        (f"{s}EyebrowUpper", f"{s}EyebrowLower") for s in ("left", "right")]
    for a, b in holes:
        poly = np.concatenate([xy[CONTOURS[a]], xy[CONTOURS[b][::-1]]])
        inside &= ~MplPath(poly).contains_points(pts, radius=0.0)
    return photo_srgb8[y0:y1:step, x0:x1:step].reshape(-1, 3)[inside]


def assess(photo_srgb8: np.ndarray, faces: list[FaceLandmarks], allow_closed_eyes: bool = False,
           focal_px: float | None = None) -> QualityReport:
    """Measure a photograph and its detected faces against :data:`THRESHOLDS`; never raises for a bad photo.

    Args:
        photo_srgb8: uint8 (H, W, 3) sRGB, the image the faces were detected in.
        faces: :func:`capture.landmarks.detect_faces`'s result (largest first).
        allow_closed_eyes: do not refuse closed eyes (a scan like the sample head's).
        focal_px: the photograph's focal length (pixels of ``photo_srgb8``) when known (EXIF,
            ``--focal-mm``), so the pose is read as the person's head is built from it
            (:func:`capture.person.head_pose`); None: the portrait-lens prior.
    """
    from capture.person import head_pose
    from km.srgb import srgb_decode

    rep = QualityReport(allow_closed_eyes=allow_closed_eyes)
    rep.measured["faces"] = float(len(faces))
    if not faces:
        rep.issues.append(_issue("no_face"))
        return rep
    if len(faces) > 1:
        rep.issues.append(_issue("two_faces"))
    face = faces[0]
    t = THRESHOLDS
    pose = head_pose(face, focal_px)
    m = rep.measured
    m.update(yaw_deg=pose.yaw_deg, pitch_deg=pose.pitch_deg, roll_deg=pose.roll_deg)
    if abs(pose.yaw_deg) > t["max_yaw_deg"]:
        rep.issues.append(_issue("turned", abs(pose.yaw_deg)))
    if abs(pose.roll_deg) > t["max_roll_deg"] or abs(pose.pitch_deg) > t["max_pitch_deg"]:
        rep.issues.append(_issue("tilted", max(abs(pose.roll_deg), abs(pose.pitch_deg))))
    x0, y0, x1, y1 = face.box()
    m["face_height_ratio"] = (y1 - y0) / face.height
    if m["face_height_ratio"] < t["min_face_height_ratio"]:
        rep.issues.append(_issue("small", 100 * m["face_height_ratio"]))
    openness = face.eye_openness()
    m["eye_openness_ratio"] = float(np.mean(list(openness.values())))
    if m["eye_openness_ratio"] < t["min_eye_openness_ratio"] and not allow_closed_eyes:
        rep.issues.append(_issue("eyes_closed"))
    m["sharpness_ratio"] = sharpness(photo_srgb8, face)
    if m["sharpness_ratio"] < t["min_sharpness_ratio"]:
        rep.issues.append(_issue("blur"))
    skin = skin_pixels(photo_srgb8, face)
    m["skin_pixels"] = float(len(skin))
    if len(skin):
        m["clipped_skin_ratio"] = float(np.mean(skin.max(axis=1) >= CLIPPED_CODE))
        lum = srgb_decode(skin / 255.0) @ np.array([0.2126, 0.7152, 0.0722])
        m["skin_luminance"] = float(np.median(lum))
        if m["clipped_skin_ratio"] > t["max_clipped_skin_ratio"]:
            rep.issues.append(_issue("clipped", 100 * m["clipped_skin_ratio"]))
        if m["skin_luminance"] < t["min_skin_luminance"]:
            rep.issues.append(_issue("dark"))
    return rep


def eyes_open(report: QualityReport) -> bool:
    """Whether the report measured open eyes (the irises can then set the scale)."""
    return report.measured.get("eye_openness_ratio", 0.0) >= THRESHOLDS["min_eye_openness_ratio"]
