"""What render reads from a captured face (render/captured.py): capture's Face is a CapturedFace, and
face.json's camera and flash are parsed by it alone, with one-line errors naming the file (no GL)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pytest

from capture.camera import Camera
from capture.errors import CaptureError
from capture.face import Face
from capture.phong import PhongParams
from core.camera import Pinhole
from render.captured import CapturedFace

if TYPE_CHECKING:
    from pathlib import Path


def _face(data: dict, folder: Path | None = None) -> Face:
    params = PhongParams(diffuse=np.array([0.5, 0.35, 0.3]), specular=0.1, exponent=20.0, ambient_scale=1.0)
    return Face(params=params, detail=np.ones((4, 4, 3), np.float32), data=data, folder=folder)


def test_capture_face_is_a_captured_face() -> None:
    cam = Camera.looking_at((0.0, 1.0, 30.0), (0.0, 1.0, 0.0), (0.0, 1.0, 0.0), 20.0, 320, 240)
    face = _face({"camera": cam.to_json(), "light_dir_world": [0.0, 3.0, 4.0]})
    assert isinstance(face, CapturedFace)
    read = face.camera()
    assert isinstance(read, Pinhole) and (read.width, read.height) == (320, 240)
    for name in ("K", "R", "t"):
        np.testing.assert_array_equal(getattr(read, name), getattr(cam, name))
    np.testing.assert_allclose(face.light_dir(), [0.0, 0.6, 0.8])
    assert face.has_camera


EYE = np.eye(3).tolist()
BAD_CAMERAS = [None, {"K": [[1, 0, 0], [0, 1, 0]], "R": EYE, "t": [0, 0, 1], "width": 4, "height": 3},
               {"K": EYE, "R": EYE, "t": [0, 0, 1], "width": 0, "height": 3},
               {"K": "eye", "R": [], "t": [], "width": 4, "height": 3}]


@pytest.mark.parametrize("camera", BAD_CAMERAS)
def test_a_missing_or_malformed_camera_names_face_json(camera: dict | None, tmp_path: Path) -> None:
    face = _face({} if camera is None else {"camera": camera}, tmp_path)
    assert face.has_camera == (camera is not None)
    with pytest.raises(CaptureError, match=r"face\.json: .*'camera'") as exc:
        face.camera()
    assert str(tmp_path) in str(exc.value) and "\n" not in str(exc.value)


@pytest.mark.parametrize("light", [None, [0.0, 0.0, 0.0], [1.0, "x", 0.0], [1.0, 0.0]])
def test_a_missing_or_malformed_flash_direction_is_one_line(light: list | None) -> None:
    face = _face({} if light is None else {"light_dir_world": light})
    with pytest.raises(CaptureError, match=r"face\.json: no usable 'light_dir_world'"):
        face.light_dir()
