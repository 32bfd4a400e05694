"""``sheer capture`` end to end on the synthetic scene, and its bad-input messages."""

from __future__ import annotations

import contextlib
import io
import json
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import pytest
from PIL import Image

if TYPE_CHECKING:
    from pathlib import Path

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    from bench.capture_synthetic import make_scene, read_env
    from core.assets import find_asset
    from painting.head import load_head

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


class Captured(NamedTuple):
    """One run of ``sheer capture``: its exit status, what it wrote on stderr and its output folder."""

    rc: int
    err: str
    out: Path


@pytest.fixture(scope="module")
def captured(inputs: dict[str, Path]) -> Captured:
    """``sheer capture --verbose`` run once on the synthetic scene (photo, camera and probe; 256² texture) for
    the tests that read its face folder and its every step."""
    from app.cli import main

    d = inputs["dir"]
    out = d / "face"
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        rc = main(["capture", "--photo", str(d / "photo.png"), "--camera", str(d / "camera.json"),
                   "--probe", str(d / "probe.png"), "--texture-size", "256", "--out", str(out), "--verbose"])
    return Captured(rc, err.getvalue(), out)


def test_capture_writes_face_folder(captured: Captured) -> None:
    rc, err, out = captured
    assert rc == 0, err
    assert "Phong fit" in err and "reproduction" in err
    for name in ("face.json", "detail.exr", "report.png", "skin_mask.png"):
        assert (out / name).is_file()
    report = np.asarray(Image.open(out / "report.png"))
    # A caption strip over photo | fitted | difference | detail (unseen texels marked), 256 px each.
    assert report.shape[1:] == (1024, 3) and 256 + 8 <= report.shape[0] <= 256 + 40
    caption = report[: report.shape[0] - 256]
    assert all(caption[:, i * 256:(i + 1) * 256].std() > 5 for i in range(4))  # each panel is named
    assert "i_s = " in err and "joint fit" in err


def _numbers(x: object, path: str = "") -> list[str]:
    """Paths of the numeric leaves (a list of numbers counts as one) of a JSON value."""
    if isinstance(x, dict):
        return [p for k, v in x.items() for p in _numbers(v, f"{path}.{k}" if path else k)]
    if isinstance(x, list) and x and not all(isinstance(v, (int, float)) for v in x):
        return [p for v in x for p in _numbers(v, path)]
    if isinstance(x, bool):
        return []
    return [path] if isinstance(x, (int, float)) or (isinstance(x, list) and x) else []


def test_every_number_in_face_json_has_a_unit(captured: Captured) -> None:
    # A key names its unit (…_deg, …_px, timings_s…) or face.json's "units" gives it (for the path or
    # an enclosing object's path).
    assert captured.rc == 0, captured.err
    data = json.loads((captured.out / "face.json").read_text())
    units = data["units"]
    suffixes = ("_deg", "_px", "_s", "schema_version", "starts")

    def has_unit(path: str) -> bool:
        parts = path.split(".")
        return (parts[-1].endswith(suffixes) or any(p.endswith("_s") for p in parts)
                or any(".".join(parts[:i]) in units for i in range(1, len(parts) + 1)))

    missing = [p for p in _numbers(data) if not p.startswith("units") and not has_unit(p)]
    assert not missing, missing


def test_capture_with_the_probes_directional_ambient(inputs: dict[str, Path], captured: Captured) -> None:
    """``--ambient directional`` fits D with the probe's irradiance per normal (capture.ambient) and says so in
    face.json; the photograph's own view still comes back (the detail texture keeps the constant ambient)."""
    from app.cli import main

    d = inputs["dir"]
    out = d / "face_directional"
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        rc = main(["capture", "--photo", str(d / "photo.png"), "--camera", str(d / "camera.json"),
                   "--probe", str(d / "probe.png"), "--ambient", "directional", "--texture-size", "256",
                   "--out", str(out)])
    assert rc == 0, err.getvalue()
    directional = json.loads((out / "face.json").read_text())
    mean = json.loads((captured.out / "face.json").read_text())
    assert directional["fit_ambient"] == "directional" and mean["fit_ambient"] == "mean"
    assert len(directional["probe"]["ambient_sh"]) == 9
    d_dir = np.asarray(directional["phong"]["diffuse_rgb"])
    d_mean = np.asarray(mean["phong"]["diffuse_rgb"])
    assert np.abs(d_dir - d_mean).max() > 1e-4  # another ambient, another D
    reproduction = directional["residual"]["reproduction_mean_de2000_skin"]
    assert reproduction < 1.0, reproduction


@pytest.mark.parametrize("case", ["missing_photo", "few_points", "bad_mask", "bad_reflectance", "reflectance_alone",
                                  "directional_without_probe", "directional_automatic", "without_flash_missing",
                                  "without_flash_other_size", "without_flash_alone"])
def test_capture_bad_input_is_one_line(case: str, inputs: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main

    d = inputs["dir"]
    args = ["capture", "--photo", str(d / "photo.png"), "--camera", str(d / "camera.json"), "--out", str(d / "x")]
    if case == "missing_photo":
        args[2] = str(d / "nope.png")
    elif case == "few_points":
        args[3:5] = ["--points", str(d / "few_points.json")]
    elif case == "bad_reflectance":
        args += ["--probe", str(d / "photo.png"), "--probe-reflectance", "1.5"]
    elif case == "reflectance_alone":
        args += ["--probe-reflectance", "0.6"]
    elif case == "directional_without_probe":
        args += ["--ambient", "directional"]
    elif case in ("without_flash_missing", "without_flash_other_size"):
        # the photo (256²) as the flash-less probe of a 128² ball: another size
        other = "nope.png" if case == "without_flash_missing" else "photo.png"
        args += ["--probe", str(d / "probe.png"), "--probe-without-flash", str(d / other)]
    elif case == "without_flash_alone":
        args += ["--probe-without-flash", str(d / "probe.png")]
    elif case == "directional_automatic":
        args = ["capture", "--photo", str(d / "photo.png"), "--probe", str(d / "probe.png"), "--ambient",
                "directional", "--out", str(d / "x")]
    else:
        Image.new("L", (10, 10), 255).save(d / "mask.png")
        args += ["--mask", str(d / "mask.png")]
    rc = main(args)
    err = capsys.readouterr().err
    assert rc == 2
    lines = [ln for ln in err.splitlines() if ln.startswith("sheer: error")]
    assert len(lines) == 1 and "Traceback" not in err
    expected = {"without_flash_missing": "nope.png: photo not found",
                "without_flash_other_size": "photo.png: the photograph without the flash is 256×256 px, the probe "
                                            "with it 128×128",
                "without_flash_alone": "--probe-without-flash needs --probe"}
    assert expected.get(case, "") in lines[0], lines[0]


def test_the_probe_without_the_flash_gives_the_flashs_hue(inputs: dict[str, Path]) -> None:
    """``--probe-without-flash``: the synthetic scene's ball photographed without the flash (the warehouse alone,
    the same exposure), read as the probe is (app.commands.capture.read_probe): the flash's hue from the
    difference, measured within 0.12 % of the truth (from the flash probe alone R −0.86 %, B +0.53 %)."""
    import argparse

    from app.commands.capture import read_probe
    from bench.capture_synthetic import DIM_ROOM, FLASH_RGB, env_mean_radiance, read_env, validation_camera
    from capture.pipeline import linear_to_srgb8
    from capture.probe import probe_environment
    from core.assets import find_asset

    d = inputs["dir"]
    env = read_env(str(find_asset("environments/warehouse.exr")))
    room = probe_environment(env, validation_camera().R, 128, DIM_ROOM / float(env_mean_radiance(env).mean()))
    Image.fromarray(linear_to_srgb8(room)).save(d / "probe0.png")
    args = argparse.Namespace(probe=str(d / "probe.png"), probe_without_flash=str(d / "probe0.png"),
                              probe_reflectance=1.0)
    probe = read_probe(args)
    assert probe is not None and probe.hue_from_difference and probe.to_json()["flash_hue_from_difference"]
    error = probe.flash_rgb / FLASH_RGB - 1.0
    assert np.all(np.abs(error) < 0.005), error
