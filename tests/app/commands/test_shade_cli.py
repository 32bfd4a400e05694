"""``sheer shade match`` and ``sheer shade coverage`` through ``app.cli.main``: output, JSON, refusals (exit 2)."""

from __future__ import annotations

import json
import subprocess
import sys
from typing import TYPE_CHECKING

import numpy as np
import OpenEXR
import pytest
from PIL import Image

from app.cli import main
from capture.phong import PhongParams
from core.assets import find_asset
from km.colour import delta_e2000
from km.library import default_library
from km.optics import over
from km.skin import fit_skin, lab_of, skin_reflectance
from km.srgb import srgb_encode
from tests.shade.photos import SKIN_BOX, write_photo

if TYPE_CHECKING:
    from pathlib import Path


def run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(["shade", *args])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def _rgb8(linear: np.ndarray) -> str:
    return ",".join(str(int(v)) for v in np.round(srgb_encode(np.clip(linear, 0, 1)) * 255))


def test_match_table_and_json(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "match", "--rgb", "150,100,75", "--top", "3")
    assert code == 0
    rows = [line for line in out.splitlines() if line[:2].strip().isdigit()]
    assert len(rows) == 3 and "Foundation" in rows[0]
    code, out, _ = run(capsys, "match", "--rgb", "150,100,75", "--json", "--store-light", "F2")
    assert code == 0
    js = json.loads(out)
    assert set(js["skin"]["params"]) == {"melanin", "blood", "oxygenation", "scattering", "pheomelanin"}
    assert len(js["skin"]["reflectance"]) == len(js["skin"]["wavelengths_nm"]) == 81
    assert js["lights"] == ["D65", "F2", "A"]
    assert len(js["shades"]) == 6
    for shade in js["shades"]:
        assert {"name", "thickness_um", "de2000", "de2000_by_illuminant", "metameric"} <= set(shade)
        assert set(shade["de2000_by_illuminant"]) == {"D65", "F2", "A"}
    assert any("Prahl" in c for c in js["credits"])  # the haemoglobin spectra the skin model is made of
    des = [s["de2000"] for s in js["shades"]]
    assert des == sorted(des)


def test_a_made_up_skin_as_target_is_found(capsys: pytest.CaptureFixture[str]) -> None:
    """Caramel at 40 µm on a medium skin, given as the target colour: the CLI ranks Caramel first near 40 µm."""
    skin = fit_skin(linear_rgb=np.array([0.20, 0.11, 0.07]))
    caramel = default_library().get("Foundation Caramel")
    R0, T = caramel.rt(40.0)
    lab = lab_of(over(R0, T, skin.reflectance))
    code, out, _ = run(capsys, "match", "--lab", ",".join(f"{v:.4f}" for v in skin.lab),
                       "--target", "lab:" + ",".join(f"{v:.4f}" for v in lab), "--json")
    assert code == 0
    first = json.loads(out)["shades"][0]
    assert first["name"] == "Foundation Caramel" and first["thickness_um"] == pytest.approx(40.0, rel=0.1)


def test_match_from_a_face_folder(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """A face folder's fitted diffuse colour is the skin (face.json + detail.exr as 'sheer capture' writes them)."""
    diffuse = skin_reflectance(0.05, 0.01)
    from km.colour import spectrum_to_rgb

    linear = spectrum_to_rgb(diffuse)
    params = PhongParams(diffuse=linear, specular=0.1, exponent=20.0, ambient_scale=0.2)
    (tmp_path / "face.json").write_text(json.dumps({"schema_version": 1, "phong": params.to_json()}), "utf-8")
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(hdr, {"RGB": np.ones((4, 4, 3), np.float32)}).write(str(tmp_path / "detail.exr"))
    code, out, _ = run(capsys, "match", "--face", str(tmp_path), "--json")
    assert code == 0
    js = json.loads(out)
    assert js["source"]["kind"] == "face" and js["skin"]["residual_de2000"] < 0.5
    assert js["skin"]["params"]["melanin"] == pytest.approx(0.05, rel=0.02)


def test_match_from_a_photo_with_a_checker(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    photo = tmp_path / "tinted.png"
    skin_r = write_photo(photo, "LED-B3", (0.06, 0.012))
    code, out, _ = run(capsys, "match", "--photo", str(photo), "--region", ",".join(map(str, SKIN_BOX)), "--json")
    assert code == 0
    js = json.loads(out)
    assert js["source"]["checker"] is True and js["note"].startswith("camera colour-corrected")
    assert float(delta_e2000(js["skin"]["target_lab"], lab_of(skin_r))) < 2.0


def test_match_from_a_portrait_states_the_srgb_assumption(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "match", "--photo", str(find_asset("photos/astronaut.png")), "--no-checker",
                       "--top", "2")
    assert code == 0 and "assumes an sRGB camera" in out


@pytest.mark.parametrize("args,message", [
    (["--rgb", "0,255,0"], "not a skin colour the skin model can produce"),
    (["--rgb", "10,20"], "--rgb: expected 3 numbers"),
    (["--rgb", "300,20,20"], "0..255"),
    (["--rgb", "150,100,75", "--target", "pinker"], "unknown target 'pinker'"),
    (["--rgb", "150,100,75", "--illuminant", "D99"], "unknown light 'D99'"),
    (["--rgb", "150,100,75", "--region", "1,2,3,4"], "--region needs --photo"),
    (["--rgb", "150,100,75", "--top", "0"], "--top must be at least 1"),
])
def test_match_refusals(capsys: pytest.CaptureFixture[str], args: list[str], message: str) -> None:
    code, _, err = run(capsys, "match", *args)
    assert code == 2 and err.count("\n") == 1 and message in err


def test_photo_refusals(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    blank = tmp_path / "wall.png"
    Image.fromarray(np.full((200, 300, 3), 90, np.uint8)).save(blank)
    code, _, err = run(capsys, "match", "--photo", str(blank))
    assert code == 2 and err.count("\n") == 1 and "no face found" in err
    code, _, err = run(capsys, "match", "--photo", str(blank), "--region", "250,150,100,100")
    assert code == 2 and err.count("\n") == 1 and "outside the photograph (300×200 px" in err
    code, _, err = run(capsys, "match", "--face", str(tmp_path))
    assert code == 2 and "not a face folder" in err


def test_a_library_without_foundation_exits_2(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    lib = default_library()
    for name in [m.name for m in lib if m.category == "foundation"]:
        lib.remove(name)
    path = lib.save(tmp_path / "no-foundation.json")
    for args in (["match", "--rgb", "150,100,75"], ["coverage", "--out", str(tmp_path / "c.png")]):
        code, _, err = run(capsys, *args, "--library", str(path))
        assert code == 2 and err.count("\n") == 1 and "no foundation in the library" in err
    assert not (tmp_path / "c.png").exists()


def test_coverage_writes_the_plot_and_json(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    png = tmp_path / "coverage.png"
    code, out, _ = run(capsys, "coverage", "--out", str(png), "--skins", "96", "--json")
    assert code == 0
    js = json.loads(out)
    assert js["skins"] == 96 and js["plot"] == str(png)
    assert js["ita_range_deg"][0] < -30 and js["ita_range_deg"][1] > 55
    assert js["gap"] is None or abs(sum(js["gap"]["recipe"].values()) - 1.0) < 1e-3
    with Image.open(png) as im:
        assert im.format == "PNG" and im.width > 600
    code, _, err = run(capsys, "coverage", "--out", str(tmp_path / "coverage.jpg"))
    assert code == 2 and ".png" in err


def test_the_sheer_command_runs_as_a_process() -> None:
    proc = subprocess.run([sys.executable, "-m", "app", "shade", "match", "--rgb", "0,255,0"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
