"""The full head (capture/full_head.py): the sample head warped onto a person's face-mesh landmarks."""

from __future__ import annotations

from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

from tests.capture.portraits import DATA

if TYPE_CHECKING:
    from capture.full_head import FullHeadFit
    from painting.head import Head


@cache
def _hopper() -> tuple[Head, FullHeadFit]:
    """Grace Hopper's own (face-only) head from her portrait's detected landmarks (stored: MediaPipe's 478
    points, tests/data/capture/grace_hopper_landmarks.json), and the full head fitted to it."""
    import json

    from capture.full_head import fit_full_head
    from capture.landmarks import FaceLandmarks
    from capture.person import person_head

    data = json.loads((DATA / "grace_hopper_landmarks.json").read_text())
    face = FaceLandmarks(points=np.asarray(data["points_px"], dtype=np.float64), width=data["width"],
                         height=data["height"])
    person = person_head(face, Path("unused"), eyes_open=True)
    return person, fit_full_head(person.vertices)


def _triangle_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    return np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])


def test_her_landmarks_are_met_within_a_millimetre() -> None:
    from capture.full_head import WARP_POINTS

    person, fit = _hopper()
    r = fit.residual_mm[WARP_POINTS]
    assert np.median(r) < 0.3 and np.percentile(r, 95) < 1.0 and r.max() < 2.5, np.percentile(r, [50, 95, 100])
    # measured, not assumed: the points on the fitted head against her landmarks
    again = np.linalg.norm(fit.face_points() - person.vertices, axis=1) * 10.0
    np.testing.assert_allclose(again, fit.residual_mm, atol=1e-9)
    # the sample head scaled to her: about its own 52.5 mm per unit (a woman's face a little smaller or larger)
    assert 4.2 < fit.scale < 6.2


def test_no_triangle_is_inverted_and_the_head_is_whole() -> None:
    from capture.full_head import WARP_POINTS, similarity
    from painting.head import load_head

    person, fit = _hopper()
    sample = load_head()
    src = fit.correspondences.points(sample.vertices, sample.faces)[WARP_POINTS]
    s, rot, t = similarity(src, person.vertices[WARP_POINTS])
    before = _triangle_normals(np.asarray(sample.vertices) @ (s * rot).T + t, sample.faces)
    after = _triangle_normals(fit.head.vertices, fit.head.faces)
    cos = (before * after).sum(1) / np.maximum(np.linalg.norm(before, axis=1) * np.linalg.norm(after, axis=1), 1e-30)
    assert (cos <= 0).sum() == 0, f"{(cos <= 0).sum()} triangles inverted"
    # the whole sample head (skull, ears, neck), not a face: as many vertices, and it reaches far behind her face
    assert fit.head.vertices.shape == sample.vertices.shape and fit.head.uv.shape == sample.uv.shape
    depth_cm = np.ptp(fit.head.vertices[:, 2])
    assert depth_cm > 2.0 * np.ptp(person.vertices[:, 2]) and 18.0 < depth_cm < 35.0, depth_cm
    assert np.isfinite(fit.head.vertices).all() and fit.head.mm_per_unit == 10.0


def test_the_face_has_her_proportions() -> None:
    from capture.person import eye_centres

    person, fit = _hopper()
    lm = fit.head.metadata.landmarks

    def dist(a: str, b: str) -> float:
        return float(np.linalg.norm(np.subtract(lm[a], lm[b])))

    le, re = eye_centres(person.vertices)
    assert dist("left_eye", "right_eye") == pytest.approx(float(np.linalg.norm(le - re)), rel=0.03)
    her = person.metadata.landmarks
    for a, b in (("nasion", "gnathion"), ("mouth_left", "mouth_right"), ("nose_tip", "chin")):
        hers = float(np.linalg.norm(np.subtract(her[a], her[b])))
        assert dist(a, b) == pytest.approx(hers, rel=0.03), (a, b)
    # and not the sample head's: her inter-ocular distance differs from the sample's scaled by the similarity
    from painting.head import load_head

    sample = load_head()
    ratio = (np.linalg.norm(sample.landmark("left_eye") - sample.landmark("right_eye")) * fit.scale
             / dist("left_eye", "right_eye"))
    assert abs(ratio - 1.0) > 0.005


def test_bad_landmarks_are_one_line() -> None:
    from capture.errors import CaptureError
    from capture.full_head import fit_full_head

    with pytest.raises(CaptureError, match="468 finite 3D"):
        fit_full_head(np.zeros((20, 3)))
    with pytest.raises(CaptureError, match="468 finite 3D"):
        fit_full_head(np.full((468, 3), np.nan))
