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


def test_the_photograph_is_kept_on_her_face_and_her_skin_tone_elsewhere() -> None:
    from capture.full_head import blend_detail, face_weight
    from capture.pipeline import uv_layout

    person, fit = _hopper()
    head = fit.head
    w = face_weight(head, person, np.array([0.0, 0.0, 60.0]))  # a camera 60 cm in front of her face
    assert w.min() >= 0.0 and w.max() <= 1.0
    nose = int(np.argmin(np.linalg.norm(head.vertices - np.asarray(head.metadata.landmarks["nose_tip"]), axis=1)))
    cheek = int(np.argmin(np.linalg.norm(head.vertices - np.asarray(head.metadata.landmarks["left_cheek"]), axis=1)))
    assert w[nose] > 0.99 and w[cheek] > 0.99
    behind = head.vertices[:, 2] < person.vertices[:, 2].min() - 1.0  # the skull, ears, neck behind her face mesh
    assert behind.sum() > 2000 and w[behind].max() == 0.0 and (w == 0.0).sum() > len(w) // 2
    # a detail texture with a streak everywhere (what a smeared photograph would leave): only her face keeps it
    size = 128
    rng = np.random.default_rng(3)
    # her face paler and less red than the fitted diffuse colour (detail 0.9, 0.85, 0.8 on average)
    detail = (np.array([0.9, 0.85, 0.8]) * (1.0 + rng.uniform(-0.5, 0.5, (size, size, 3)))).astype(np.float32)
    out = blend_detail(head, detail, w)
    gb, _, _ = uv_layout(head.uv, head.faces, size)
    tri = np.maximum(gb.tri, 0)
    off = gb.covered & (w[head.faces].max(axis=1)[tri] == 0.0)
    on = gb.covered & (w[head.faces].min(axis=1)[tri] >= 0.999)
    assert off.sum() > size * size // 4
    # off her face: one plain tone, her face's own (the median detail over her skin), not the fitted colour
    tone = out[off][0]
    np.testing.assert_array_equal(out[off], np.broadcast_to(tone, out[off].shape))
    np.testing.assert_allclose(tone, [0.9, 0.85, 0.8], atol=0.03)
    assert on.sum() > 500
    np.testing.assert_allclose(out[on], detail[on], atol=2e-3)  # on her face: the photograph's detail


def test_sheer_capture_full_head_writes_her_full_head(tmp_path: Path) -> None:
    import contextlib
    import io

    from app.cli import main
    from capture.face import load_face
    from core.assets import find_asset
    from painting.region_shapes import regions_for

    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["capture", "--photo", str(find_asset("photos/grace_hopper.jpg")), "--full-head",
                     "--texture-size", "64", "--out", str(tmp_path / "g")])
    assert code == 0, err.getvalue()
    assert "head.obj (+ sidecar" in err.getvalue()
    face = load_face(tmp_path / "g")
    head = face.load_head()
    assert face.data["head_kind"] == "full" and len(head.vertices) == 9279 and head.mm_per_unit == 10.0
    assert face.data["full_head"]["residual_mm"]["p95"] < 1.0
    assert head.albedo is not None and head.skin_mask is not None and face.detail.shape == (64, 64, 3)
    assert "lips" in regions_for(head).names()
    # the sample head's UVs as they are (rounded to 6 decimals one sliver folded, and the paint layout was an unwrap)
    from painting.head import load_head

    assert np.abs(head.uv - load_head().uv).max() < 1e-9
    # with --points it is one line
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["capture", "--photo", str(find_asset("photos/grace_hopper.jpg")), "--full-head", "--points",
                     str(DATA / "grace_hopper_points.json"), "--out", str(tmp_path / "p")])
    assert code == 2 and "--full-head is for the automatic capture" in err.getvalue()
    assert len(err.getvalue().strip().splitlines()) == 1


def test_a_full_head_with_a_given_head_is_one_line(tmp_path: Path) -> None:
    from capture.auto import capture_auto
    from capture.errors import CaptureError
    from core.assets import find_asset

    with pytest.raises(CaptureError, match="cannot be combined with a given head"):
        capture_auto(find_asset("photos/grace_hopper.jpg"), tmp_path / "g", head=find_asset("heads/lee-perry-smith/head.glb"),
                     full_head=True)
    assert not (tmp_path / "g").exists()


def test_a_look_moves_onto_her_full_head_texel_for_texel() -> None:
    """The full head paints in the sample head's layout, so a layer painted on the sample head lands on the
    same texels of hers: every texel matched (the 3D correspondence matched 58 % of them, the scalp and neck
    beyond its reach), the thickness copied exactly."""
    from painting.document import Document
    from painting.head import load_head
    from painting.transfer import inner_mouth_texels, same_paint_layout, transfer_layers

    _, fit = _hopper()
    source = Document(load_head(), resolution=64)  # the sample head
    layer = source.add_layer("Blush Rose", resolution=64)
    rng = np.random.default_rng(5)
    thickness = (rng.uniform(0.0, 12.0, (64, 64)) * source.atlas_at(64).coverage).astype(np.float32)
    source.set_thickness(layer, thickness, detail="test")
    target = Document(fit.head, resolution=64, library=source.library)
    assert same_paint_layout(source, target)
    report = transfer_layers(source, target)
    assert report.matched_fraction == 1.0
    moved = target.layers[-1].thickness
    covered = target.atlas_at(64).coverage
    mouth = inner_mouth_texels(target, 64)  # a transfer leaves the inside of the mouth bare, as always
    assert mouth is not None and 0 < mouth.sum() < 50
    np.testing.assert_array_equal(moved[covered & ~mouth], thickness[covered & ~mouth])
    assert not moved[mouth].any()
