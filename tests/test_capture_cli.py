"""``sheer capture`` end to end on the synthetic scene, and its bad-input messages."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    from capture.synthetic import make_scene, read_env
    from painting.head import load_head
    from resources import find_asset

    d = tmp_path_factory.mktemp("capture_cli")
    scene = make_scene(load_head(), read_env(str(find_asset("environments/warehouse.exr"))), size=256,
                       probe_size=128)
    Image.fromarray(scene.photo_srgb8).save(d / "photo.png")
    Image.fromarray(scene.probe_srgb8).save(d / "probe.png")
    (d / "camera.json").write_text(json.dumps({"P": scene.camera.P.tolist()}))
    rng = np.random.default_rng(3)
    head = load_head()
    idx = rng.choice(len(head.vertices), 5, replace=False)
    x, _ = scene.camera.project(head.vertices[idx])
    pts = [{"image": a.tolist(), "mesh": b.tolist()} for a, b in zip(x, head.vertices[idx])]
    (d / "few_points.json").write_text(json.dumps({"points": pts}))
    return {"dir": d}


def test_capture_writes_face_folder(inputs: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main

    d = inputs["dir"]
    out = d / "face"
    rc = main(["capture", "--photo", str(d / "photo.png"), "--camera", str(d / "camera.json"),
               "--probe", str(d / "probe.png"), "--texture-size", "256", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 0, err
    assert "Phong fit" in err and "reproduction" in err
    for name in ("face.json", "detail.exr", "report.png", "skin_mask.png"):
        assert (out / name).is_file()
    report = np.asarray(Image.open(out / "report.png"))
    assert report.shape == (256, 1024, 3)  # photo | fitted | difference | detail (unseen texels marked)


@pytest.mark.parametrize("case", ["missing_photo", "few_points", "bad_mask"])
def test_capture_bad_input_is_one_line(case: str, inputs: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main

    d = inputs["dir"]
    args = ["capture", "--photo", str(d / "photo.png"), "--camera", str(d / "camera.json"), "--out", str(d / "x")]
    if case == "missing_photo":
        args[2] = str(d / "nope.png")
    elif case == "few_points":
        args[3:5] = ["--points", str(d / "few_points.json")]
    else:
        Image.new("L", (10, 10), 255).save(d / "mask.png")
        args += ["--mask", str(d / "mask.png")]
    rc = main(args)
    err = capsys.readouterr().err
    assert rc == 2
    lines = [ln for ln in err.splitlines() if ln.startswith("sheer: error")]
    assert len(lines) == 1 and "Traceback" not in err
