"""How far the relight view turns (render.mirror.turn_limits): what her photograph supports.

Grace Hopper's face from her portrait's stored landmarks (tests/data/capture/grace_hopper_landmarks.json:
no detection, no capture): her own face mesh and the full head fitted to it, with the camera the automatic
capture calibrates from the same points. Photographed head-on she turns about ±25° each way; the same face
photographed from 15° to one side (the camera orbited about her neck, as a head turned in the photograph)
turns less towards the side the photograph then saw at a grazing angle, and still 25° the other way.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

from tests.capture.portraits import DATA

if TYPE_CHECKING:
    from core.camera import Pinhole
    from painting.head import Head


@cache
def _hopper() -> tuple[Head, Head, Pinhole]:
    """Her face-mesh head, her full head and her photograph's camera (from the stored landmarks)."""
    from capture.auto import correspondences
    from capture.camera import calibrate
    from capture.full_head import fit_full_head
    from capture.landmarks import FaceLandmarks
    from capture.person import person_head

    data = json.loads((DATA / "grace_hopper_landmarks.json").read_text())
    face = FaceLandmarks(points=np.asarray(data["points_px"], dtype=np.float64), width=data["width"],
                         height=data["height"])
    person = person_head(face, Path("unused"), eyes_open=True)
    x, X, _ = correspondences(face, person, True)
    camera = calibrate(x, X, data["width"], data["height"], good_enough_px=0.5)
    return person, fit_full_head(person.vertices).head, camera


def _photographed_from(camera: Pinhole, head: Head, yaw_deg: float) -> Pinhole:
    """``camera`` orbited ``yaw_deg`` about her neck (positive: from her left), as the relight view turns."""
    from core.camera import Pinhole
    from render.pinhole import turn_matrix, turn_pivot

    pivot = turn_pivot(head.vertices, head.metadata.landmarks, float(head.mm_per_unit))
    m = camera.camera_from_world() @ np.linalg.inv(turn_matrix(yaw_deg, 0.0, pivot))
    return Pinhole(K=camera.K, R=m[:3, :3], t=m[:3, 3], width=camera.width, height=camera.height)


@pytest.mark.parametrize("kind", ["face mesh", "full head"])
def test_a_head_on_photograph_turns_about_25_degrees_each_way(kind: str) -> None:
    from render.mirror import MAX_TURN_DEG, turn_limits

    person, full, camera = _hopper()
    head = person if kind == "face mesh" else full
    lim = turn_limits(head, camera)
    assert lim.yaw[0] <= -0.9 * MAX_TURN_DEG and lim.yaw[1] >= 0.9 * MAX_TURN_DEG, lim
    assert lim.pitch[0] <= -0.9 * MAX_TURN_DEG and lim.pitch[1] >= 0.9 * MAX_TURN_DEG, lim
    assert max(abs(x) for x in (*lim.yaw, *lim.pitch)) <= MAX_TURN_DEG


@pytest.mark.parametrize("kind", ["face mesh", "full head"])
@pytest.mark.parametrize("side", [-1.0, 1.0])
def test_a_turned_photograph_turns_less_towards_its_grazing_side(kind: str, side: float) -> None:
    from render.mirror import MAX_TURN_DEG, TURN_MIN_SHARE, turn_limits

    person, full, camera = _hopper()
    head = person if kind == "face mesh" else full
    lim = turn_limits(head, _photographed_from(camera, head, 15.0 * side))
    # photographed from her left (side +1), her right cheek was grazing: the turn towards it (negative yaw) stops
    grazing = -lim.yaw[0] if side > 0 else lim.yaw[1]
    other = lim.yaw[1] if side > 0 else -lim.yaw[0]
    assert 5.0 <= grazing <= 20.0 and other >= 0.9 * MAX_TURN_DEG, lim
    assert min(lim.share) >= TURN_MIN_SHARE  # the share at each limit, measured


def test_the_limits_clamp_and_refuse_bad_arguments() -> None:
    from render.errors import RenderError
    from render.mirror import TurnLimits, turn_limits

    lim = TurnLimits(yaw=(-10.0, 25.0), pitch=(-20.0, 15.0))
    assert lim.clamp(-30.0, 30.0) == (-10.0, 15.0) and lim.clamp(3.0, -4.0) == (3.0, -4.0)
    assert lim.allows(-10.0, 15.0) and not lim.allows(-10.5, 0.0) and not lim.allows(float("nan"), 0.0)
    person, _, camera = _hopper()
    with pytest.raises(RenderError, match="share in 0..1"):
        turn_limits(person, camera, min_share=1.5)
    # a head without the face's landmarks: no limit can be measured, the view's own ±25°
    from dataclasses import replace

    bare = replace(person, metadata=replace(person.metadata, landmarks={}))
    assert turn_limits(bare, camera) == TurnLimits()
