"""The sample heads' sidecars: calibrated scale, landmarks on the surface, midplane, skin mask."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from core.assets import find_asset
from painting.head import load_head, resolve_texture_path

REQUIRED = ["left_eye", "right_eye", "left_eye_inner", "left_eye_outer", "right_eye_inner", "right_eye_outer",
            "lip_centre", "upper_lip", "lower_lip", "mouth_left", "mouth_right", "left_cheek", "right_cheek",
            "nose_tip", "chin", "forehead", "left_eyelid", "right_eyelid", "left_brow", "right_brow"]
HEADS = ["heads/lee-perry-smith/head.glb", "heads/canonical-face/canonical_face_model.obj"]


@pytest.fixture(scope="module", params=HEADS)
def head(request: pytest.FixtureRequest):
    return load_head(find_asset(request.param))


def test_calibrated_with_all_landmarks_on_the_surface(head) -> None:
    meta = head.metadata
    assert meta.calibrated and meta.scale_note and meta.credit
    assert set(REQUIRED) <= set(meta.landmarks)
    mesh = trimesh.Trimesh(head.vertices, head.faces, process=False)
    pts = np.array([meta.landmarks[k] for k in REQUIRED])
    _, dist, _ = trimesh.proximity.closest_point(mesh, pts)
    assert dist.max() * head.mm_per_unit < 0.5, dict(zip(REQUIRED, dist * head.mm_per_unit))


def test_scale_gives_adult_proportions(head) -> None:
    mm = head.mm_per_unit

    def d(a: str, b: str) -> float:
        return float(np.linalg.norm(head.landmark(a) - head.landmark(b))) * mm

    assert 80 < d("left_eye_outer", "right_eye_outer") < 100  # biocular width, adult mean ~88-91 mm
    assert 27 < d("left_eye_inner", "right_eye_inner") < 40  # intercanthal width ~31-34 mm
    assert 40 < d("mouth_left", "mouth_right") < 62
    assert 100 < d("forehead", "chin") < 200


def test_left_is_plus_x_and_the_midplane_mirrors_pairs(head) -> None:
    meta = head.metadata
    c = np.asarray(meta.midplane_point)
    n = np.asarray(meta.midplane_normal)
    assert np.isclose(np.linalg.norm(n), 1.0)
    for left in [k for k in REQUIRED if k.startswith("left_")]:
        right = "right_" + left[len("left_"):]
        pl, pr = head.landmark(left), head.landmark(right)
        assert (pl - c) @ n > 0 > (pr - c) @ n, left  # the subject's left is on +X here
        mirrored = pr - 2 * ((pr - c) @ n) * n
        assert np.linalg.norm(mirrored - pl) * head.mm_per_unit < 4.0, left
    for mid in ("nose_tip", "lip_centre", "chin", "forehead"):
        assert abs((head.landmark(mid) - c) @ n) * head.mm_per_unit < 1.0


def test_sample_skin_mask_excludes_lips_and_brows() -> None:
    head = load_head(None)
    mask = head.skin_mask
    assert mask is not None and mask.shape == head.albedo.shape[:2]
    # The albedo's lips and brows (UV texel rows/columns measured on the albedo) are not skin; cheeks are.
    assert not mask[478, 512] and not mask[262, 430] and not mask[260, 590]
    assert mask[385, 435] and mask[385, 590] and mask[200, 512]
    assert 0.8 < mask.mean() < 0.97


def test_texture_paths_resolve_beside_mesh_then_beside_sidecar(tmp_path: Path) -> None:
    mesh = tmp_path / "m" / "head.obj"
    side = tmp_path / "s" / "head.json"
    mesh.parent.mkdir()
    side.parent.mkdir()
    (side.parent / "mask.png").write_bytes(b"x")
    assert resolve_texture_path("mask.png", mesh, side) == side.parent / "mask.png"
    (mesh.parent / "mask.png").write_bytes(b"y")
    assert resolve_texture_path("mask.png", mesh, side) == mesh.parent / "mask.png"
    assert resolve_texture_path("/abs/a.png", mesh, side) == Path("/abs/a.png")
    assert resolve_texture_path("none.png", mesh, side) == mesh.parent / "none.png"
