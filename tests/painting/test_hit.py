"""Picking: a camera ray and the depth-buffer path agree; hits carry triangle, barycentrics, UV, normal."""

from __future__ import annotations

import numpy as np
import pytest

from core.camera import look_at, perspective
from painting.hit import PickError, depth_hit, pixel_to_ndc, ray_hit, unproject
from tests.painting.helpers import make_doc


def _camera(eye):
    view = look_at(eye, (-0.1, 1.2, 2.0))
    proj = perspective(30.0, 4 / 3, 1.0, 50.0)
    vp = proj @ view
    return vp, np.linalg.inv(vp)


@pytest.mark.parametrize("eye", [(0.0, 1.5, 12.0), (6.0, 2.0, 8.0)])
def test_ray_and_depth_picks_agree(eye) -> None:
    doc = make_doc(256)
    vp, inv = _camera(eye)
    width, height = 64, 48
    agreed = 0
    for px, py in [(32, 24), (20, 18), (40, 30), (28, 10), (36, 36), (1, 1)]:
        ndc = pixel_to_ndc(px, py, width, height)
        near = unproject(ndc, 0.0, inv)
        far = unproject(ndc, 1.0, inv)
        hit = ray_hit(doc, near, far - near)
        if hit is None:
            assert depth_hit(doc, ndc, 1.0, inv) is None  # background
            continue
        # The depth the GPU would store for this hit, computed analytically.
        clip = vp @ np.append(hit.point, 1.0)
        depth = (clip[2] / clip[3] + 1.0) / 2.0
        picked = depth_hit(doc, ndc, depth, inv)
        assert picked is not None
        assert np.linalg.norm(picked.point - hit.point) * doc.mm_per_unit < 0.01
        assert np.allclose(picked.uv, hit.uv, atol=1e-4)
        assert np.allclose(picked.normal, hit.normal, atol=1e-3)
        agreed += 1
        # The hit's fields are consistent with the layout.
        corners = doc.layout.faces[hit.face]
        assert np.allclose(hit.barycentric @ doc.layout.vertices[corners], hit.point, atol=1e-6)
        assert np.allclose(hit.barycentric.sum(), 1.0)
        assert hit.head_face == doc.layout.face_map[hit.face]
        assert np.dot(hit.normal, far - near) < 0  # front-facing
    assert agreed >= 4


def test_ray_from_the_front_hits_the_nose_first() -> None:
    doc = make_doc(256)
    tip = doc.head.landmark("nose_tip")
    hit = doc.hit(tip + np.array([0.0, 0.0, 3.0]), (0.0, 0.0, -2.0))
    assert hit is not None and np.linalg.norm(hit.point - tip) < 0.02
    assert hit.distance == pytest.approx(3.0, abs=0.02)
    assert doc.hit(tip + np.array([0.0, 0.0, 3.0]), (0.0, 0.0, 1.0)) is None
    with pytest.raises(PickError):
        doc.hit(tip, (0.0, 0.0, 0.0))
    with pytest.raises(PickError):
        doc.hit((np.nan, 0.0, 0.0), (0.0, 0.0, 1.0))
    with pytest.raises(PickError):
        unproject((0.0, 0.0), 2.0, np.eye(4))
