"""The automatic capture's quality gate (issue #15): every refusal exercised by a real image through real
MediaPipe — no face, two faces, a turned and a tilted head, a tiny face, closed eyes, blur, clipped and
dark skin — and the photographs that must pass."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pytest

from tests.capture.auto_support import blurred, exposed, portrait, render_sample, side_by_side, tiny

if TYPE_CHECKING:
    from collections.abc import Callable


def _assess(img: np.ndarray, allow_closed_eyes: bool = False):  # type: ignore[no-untyped-def]
    from capture.landmarks import detect_faces
    from capture.quality import assess

    return assess(img, detect_faces(img), allow_closed_eyes=allow_closed_eyes)


def _codes(img: np.ndarray, allow_closed_eyes: bool = False) -> list[str]:
    return [i.code for i in _assess(img, allow_closed_eyes).issues]


CASES: dict[str, tuple[Callable[[], np.ndarray], str, bool]] = {
    # name: (image, the code it must raise, allow_closed_eyes)
    "no face": (lambda: np.full((480, 640, 3), 90, np.uint8), "no_face", False),
    "two faces": (lambda: side_by_side(portrait("grace_hopper"), portrait("grace_hopper")[:, ::-1]), "two_faces", False),
    "turned 35°": (lambda: render_sample(35.0)[0], "turned", True),
    "tilted 30°": (lambda: render_sample(0.0, roll_deg=30.0)[0], "tilted", True),
    "tiny face": (lambda: tiny(portrait("grace_hopper")), "small", False),
    "eyes closed": (lambda: render_sample(0.0)[0], "eyes_closed", False),
    "blur": (lambda: blurred(portrait("grace_hopper"), 1.5), "blur", False),
    "clipped": (lambda: exposed(portrait("grace_hopper"), 1.6), "clipped", False),
    "dark": (lambda: exposed(portrait("grace_hopper"), 0.15), "dark", False),
}


@pytest.mark.parametrize("case", list(CASES))
def test_each_refusal_is_exercised(case: str) -> None:
    make, code, allow = CASES[case]
    codes = _codes(make(), allow)
    assert codes == [code], f"{case}: {codes}"


@pytest.mark.parametrize("yaw", [-15.0, 0.0, 15.0])
def test_sample_renders_pass_with_closed_eyes_allowed(yaw: float) -> None:
    report = _assess(render_sample(yaw)[0], allow_closed_eyes=True)
    assert report.ok, report.issues
    assert abs(abs(report.measured["yaw_deg"]) - abs(yaw)) < 3.0  # the pose estimate (measured 0.3–0.9° off)


def test_grace_hopper_passes_and_the_report_says_why() -> None:
    from capture.quality import THRESHOLDS

    report = _assess(portrait("grace_hopper"))
    assert report.ok, report.issues
    data = report.to_json()
    assert data["thresholds"] == THRESHOLDS and data["issues"] == []
    m = data["measured"]
    assert m["faces"] == 1 and m["eye_openness_ratio"] > THRESHOLDS["min_eye_openness_ratio"]
    assert m["sharpness_ratio"] > THRESHOLDS["min_sharpness_ratio"]


def test_astronaut_face_is_too_small_for_a_capture() -> None:
    """The astronaut's face is 21 % of her portrait's height: the gate asks her to come closer."""
    report = _assess(portrait("astronaut"))
    assert [i.code for i in report.issues] == ["small"]
    assert "come closer" in report.issues[0].message and "21 %" in report.issues[0].message


def test_quality_error_carries_every_issue_in_one_line() -> None:
    from capture.pipeline import CaptureError
    from capture.quality import QualityError

    report = _assess(blurred(tiny(portrait("grace_hopper"), 2.0), 2.0))
    codes = [i.code for i in report.issues]
    assert "small" in codes and "blur" in codes
    exc = QualityError(report.issues, report)
    assert isinstance(exc, CaptureError) and exc.issues == report.issues and "\n" not in str(exc)
