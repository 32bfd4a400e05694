"""``sheer render`` driven as an outsider would (issue 14): the capture's camera, ``--camera FILE``, option
values that start with a minus sign, light colours and ``--light from-capture``."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import numpy as np
import pytest
from PIL import Image

if TYPE_CHECKING:
    from pathlib import Path

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def face_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A face folder with a camera (160×120, the validation's view) and a flash from the upper left."""
    import OpenEXR

    from capture.camera import Camera
    from capture.face import FACE_SCHEMA_VERSION
    from capture.phong import PhongParams

    d = tmp_path_factory.mktemp("face")
    p = PhongParams(diffuse=np.array([0.5, 0.35, 0.3]), specular=0.1, exponent=20.0, ambient_scale=1.0,
                    flash_rgb=np.array([1.2, 0.95, 0.7]) / float(np.array([1.2, 0.95, 0.7]) @ [0.2126, 0.7152, 0.0722]),
                    ambient_rgb=np.full(3, 0.02))
    cam = Camera.looking_at(np.array([0.0, 1.3, 45.0]), np.array([0.0, 1.3, 0.0]), np.array([0.0, 1.0, 0.0]),
                            8.0, 160, 120)
    light = np.array([0.3, 0.3, 1.0]) / np.linalg.norm([0.3, 0.3, 1.0])
    (d / "face.json").write_text(json.dumps({"schema_version": FACE_SCHEMA_VERSION, "phong": p.to_json(),
                                             "camera": cam.to_json(), "light_dir_world": light.tolist()}))
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(hdr, {"RGB": np.ones((64, 64, 3), np.float32)}).write(str(d / "detail.exr"))
    (d / "camera.json").write_text(json.dumps({"P": cam.P.tolist()}))
    (d / "camera_sized.json").write_text(json.dumps({"P": cam.P.tolist(), "width": 160, "height": 120}))
    return d


def _render(*args: str) -> tuple[int, np.ndarray | None, str]:
    import contextlib
    import io

    from app.cli import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["render", *args])
    out = next((a for i, a in enumerate(args) if i and args[i - 1] == "--out"), None)
    img = np.asarray(Image.open(out)) if code == 0 and out else None
    return code, img, err.getvalue()


def test_the_captures_camera_and_size_by_default(face_dir: Path, tmp_path: Path) -> None:
    code, img, err = _render("--face", str(face_dir), "--light", "from-capture", "--out", str(tmp_path / "a.png"))
    assert code == 0, err
    assert img is not None and img.shape == (120, 160, 3)  # the capture's 160×120
    # The view is the capture's: the head fills the middle of the frame (8° field at 45 units).
    assert img[40:80, 60:100].mean() > 60 and img[:, :8].mean() < 20
    # The captured flash is warm (its colour reused): red over blue on the face.
    face = img[40:80, 60:100].reshape(-1, 3).astype(float).mean(axis=0)
    assert face[0] > 1.3 * face[2]


def test_camera_file_gives_the_same_image(face_dir: Path, tmp_path: Path) -> None:
    _, by_face, _ = _render("--face", str(face_dir), "--light", "from-capture", "--out", str(tmp_path / "a.png"))
    code, by_file, err = _render("--face", str(face_dir), "--light", "from-capture", "--camera",
                                 str(face_dir / "camera_sized.json"), "--out", str(tmp_path / "b.png"))
    assert code == 0, err
    assert by_face is not None and by_file is not None
    assert np.abs(by_face.astype(int) - by_file.astype(int)).max() <= 1
    # Twice the size, same aspect: the same picture, finer.
    code, big, err = _render("--face", str(face_dir), "--light", "from-capture", "--size", "320x240",
                             "--out", str(tmp_path / "c.png"))
    assert code == 0 and big is not None and big.shape == (240, 320, 3), err
    small = big.reshape(120, 2, 160, 2, 3).mean(axis=(1, 3))
    assert np.abs(small - by_face).mean() < 6


def test_values_may_start_with_a_minus_sign_and_lights_take_a_colour(face_dir: Path, tmp_path: Path) -> None:
    code, white, err = _render("--face", str(face_dir), "--light", "-12,5,1", "--out", str(tmp_path / "w.png"))
    assert code == 0, err
    code, blue, err = _render("--face", str(face_dir), "--light", "-12,5,1,#6080ff", "--out", str(tmp_path / "b.png"))
    assert code == 0, err
    code, blue2, err = _render("--face", str(face_dir), "--light", "-12,5,1", "--light-color", "#6080ff",
                               "--yaw", "-10", "--out", str(tmp_path / "b2.png"))
    assert code == 0, err
    assert white is not None and blue is not None and blue2 is not None

    def blue_over_red(img: np.ndarray) -> float:
        px = img[40:80, 60:100].reshape(-1, 3).astype(float).mean(axis=0)
        return float(px[2] / px[0])

    assert blue_over_red(blue) > 1.3 * blue_over_red(white)
    assert blue_over_red(blue2) > 1.3 * blue_over_red(white)


@pytest.mark.parametrize(("args", "message"), [
    (["--light", "from-capture"], "needs --face"),
    (["--light", "10,5,1,#12345"], "#RRGGBB"),
    (["--light-color", "#000000"], "not be black"),
    (["--camera", "{dir}/camera.json"], "--size"),
    (["--face", "{dir}", "--size", "300x100"], "aspect ratio"),
    (["--camera", "{dir}/camera_sized.json", "--yaw", "5"], "exclude each other"),
])
def test_bad_camera_and_light_options_are_one_line(args: list[str], message: str, face_dir: Path,
                                                   tmp_path: Path) -> None:
    args = [a.replace("{dir}", str(face_dir)) for a in args]
    code, _, err = _render(*args, "--out", str(tmp_path / "x.png"))
    assert code == 2
    assert message in err and "Traceback" not in err
    assert len([ln for ln in err.splitlines() if "error" in ln]) == 1  # argparse's usage, then one error line


def test_help_states_units_and_defaults(capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main

    assert main(["render", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for phrase in ("photograph's units", "a light of intensity 1 is the captured flash", "exposure 0.85", "from-capture",
                   "#RRGGBB", "--camera"):
        assert phrase in text, phrase
