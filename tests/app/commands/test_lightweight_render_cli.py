"""``sheer render --mode lightweight --face DIR`` and a captured face's albedo in the physical modes."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import numpy as np
import pytest
from PIL import Image

if TYPE_CHECKING:
    from pathlib import Path

pytestmark = pytest.mark.gl


@pytest.fixture
def face_dir(tmp_path: Path) -> Path:
    import OpenEXR

    from capture.face import FACE_SCHEMA_VERSION
    from capture.phong import PhongParams

    d = tmp_path / "face"
    d.mkdir()
    p = PhongParams(diffuse=np.array([0.5, 0.35, 0.3]), specular=0.1, exponent=20.0, ambient_scale=1.0,
                    flash_rgb=np.ones(3), ambient_rgb=np.full(3, 0.02))
    (d / "face.json").write_text(json.dumps({"schema_version": FACE_SCHEMA_VERSION, "phong": p.to_json()}))
    detail = np.ones((64, 64, 3), np.float32)
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(hdr, {"RGB": detail}).write(str(d / "detail.exr"))
    return d


@pytest.mark.parametrize("mode", ["lightweight", "off"])
def test_render_captured_face(mode: str, face_dir: Path, tmp_path: Path) -> None:
    from app.cli import main

    out = tmp_path / f"{mode}.png"
    assert main(["render", "--mode", mode, "--face", str(face_dir), "--size", "160x90", "--out", str(out)]) == 0
    img = np.asarray(Image.open(out))
    assert img.shape == (90, 160, 3) and img[20:60, 60:100].mean() > 40


def test_lightweight_needs_a_face(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main

    assert main(["render", "--mode", "lightweight", "--out", str(tmp_path / "x.png")]) == 2
    assert main(["render", "--mode", "lightweight", "--face", str(tmp_path), "--out", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert "needs --face" in err and "no face.json" in err and "Traceback" not in err
