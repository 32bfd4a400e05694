"""The command line round trip (issue 14): a flash photograph drawn on the GPU by another renderer
(bench/capture_truth.py), ``sheer capture`` on it from its files alone (the photograph, the probe and
landmarks clicked with 1 px of noise — never the true camera), then ``sheer render --face DIR --light
from-capture`` — both through the command line (``app.cli.main``, in this process: the render reads the
face folder the capture wrote, nothing else passes between them) — must give the photograph back: mean
ΔE2000 over the skin pixels the capture used ≤ 2.5. The installed ``sheer`` entry point runs both commands
in a process of its own (their ``--help``; a full run in a process costs its start-up four times over and
proves nothing more).

Measured (mean ΔE2000 on skin, against the photograph; 512² images, the detail texture at the CLI's
default 1024²): ``--light from-capture`` (the lightweight engine, issue 14), and the two views of issue
15 — ``--view relight`` (the captured flash by default; target ≤ 3.0) and ``--view mirror`` with no makeup
(the photograph from ``--photo``; target ≤ 1.0):

================= ============================================================== ============ ======= ======
case              what it is                                                     from-capture relight mirror
================= ============================================================== ============ ======= ======
validation-scene  s 24, i_s 0.18, flash 4° up 3° right, warehouse                0.51         0.49    0.00
turned-15-beside  s 12, the camera turned −15°, flash 8° right, city sky          0.48         0.46    0.00
turned-30-above   s 24, the camera turned +30°, flash 8° above, lobby sky         0.58         0.59    0.00
dark-skin-s60     s 60, i_s 0.10, dark skin, city, flash 6° down 9° right         0.40         0.38    0.00
================= ============================================================== ============ ======= ======

Before issue 15 the detail texture was the photograph ÷ the paper's reflectance map, and the relit
images came back at 1.51, 1.87, 2.62 and 1.44: the face turned 30° missed the 2.5 target (the capture's
own reproduction was 2.65 there). The detail is now the photograph ÷ the fitted model (see
tests/capture/test_detail.py for what that gains away from the photograph's view).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest
from PIL import Image

from bench.capture_truth import Case, draw_case
from capture.phong import delta_e2000
from capture.pipeline import linear_to_srgb8
from km.srgb import srgb_decode
from tests.cli_support import sheer as _sheer

if TYPE_CHECKING:
    import moderngl

pytestmark = [pytest.mark.slow, pytest.mark.gl]

#: The issue's target.
TARGET_DE = 2.5
#: The issue's targets for the two views (issue 15), mean ΔE2000 on skin.
RELIGHT_DE, MIRROR_DE = 3.0, 1.0
#: The case, and the bound just above its measured mean ΔE2000 (the module docstring).
CASES = {
    "validation-scene": (Case("sample", 24.0, camera="noisy"), 0.6),
    "turned-15-beside": (Case("sample", 12.0, environment="city", light_deg=(0.0, 8.0), camera="noisy",
                              ambient="irradiance", yaw_deg=-15.0), 0.6),
    "turned-30-above": (Case("sample", 24.0, environment="lobby", light_deg=(8.0, 0.0), camera="noisy",
                             ambient="irradiance", yaw_deg=30.0), 0.7),
    "dark-skin-s60": (Case("sample", 60.0, 0.10, (0.25, 0.15, 0.11), "city", (-6.0, 9.0), camera="noisy"), 0.5),
}


def test_the_installed_sheer_command_runs_capture_and_render() -> None:
    """The venv's ``sheer`` console script (beside this interpreter), in a process of its own."""
    exe = Path(sys.executable).with_name("sheer")
    for command in ("capture", "render"):
        done = subprocess.run([str(exe), command, "--help"], capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        assert done.stdout.startswith(f"usage: sheer {command}"), done.stdout[:200]


def _points_file(path: Path, scene: object) -> None:
    """The head's landmarks where the noisy calibration put them (clicked with 1 px of noise): the image
    points the fit's camera projects them to, so the CLI calibrates the same camera from the file."""
    head, cam = scene.head, scene.fit_camera  # type: ignore[attr-defined]
    names = sorted(set(head.metadata.landmarks) - {"gnathion"})
    mesh = np.array([head.metadata.landmarks[n] for n in names])
    image, _ = cam.project(mesh)
    path.write_text(json.dumps({"points": [{"name": n, "image": list(map(float, im)), "mesh": list(map(float, m))}
                                           for n, im, m in zip(names, image, mesh)]}))


@pytest.mark.parametrize("name", sorted(CASES))
def test_capture_then_render_from_capture_gives_the_photograph_back(name: str, gl_ctx: moderngl.Context,
                                                                    tmp_path: Path) -> None:
    case, bound = CASES[name]
    assert bound <= TARGET_DE
    scene = draw_case(gl_ctx, case)
    Image.fromarray(scene.photo.srgb8).save(tmp_path / "photo.png")
    Image.fromarray(linear_to_srgb8(scene.probe_linear)).save(tmp_path / "probe.png")
    _points_file(tmp_path / "points.json", scene)
    face = tmp_path / "face"
    cap = _sheer("capture", "--photo", str(tmp_path / "photo.png"), "--probe", str(tmp_path / "probe.png"),
                 "--points", str(tmp_path / "points.json"), "--out", str(face))
    assert cap.returncode == 0, cap.stderr
    relit_path = tmp_path / "relit.png"
    ren = _sheer("render", "--face", str(face), "--light", "from-capture", "--out", str(relit_path))
    assert ren.returncode == 0, ren.stderr
    relit = srgb_decode(np.asarray(Image.open(relit_path), dtype=np.float64) / 255.0)
    assert relit.shape == scene.photo.linear.shape  # the capture's camera and size by default
    skin = np.asarray(Image.open(face / "skin_mask.png")) > 0
    de = float(delta_e2000(relit[skin], scene.photo.linear[skin]).mean())
    assert de < bound, f"{name}: mean ΔE2000 {de:.2f} on {int(skin.sum())} skin pixels"
    for view, extra, target in (("relight", [], RELIGHT_DE), ("mirror", ["--photo", str(tmp_path / "photo.png")],
                                                               MIRROR_DE)):
        ren = _sheer("render", "--face", str(face), "--view", view, *extra, "--out", str(tmp_path / f"{view}.png"))
        assert ren.returncode == 0, ren.stderr
        img = srgb_decode(np.asarray(Image.open(tmp_path / f"{view}.png"), dtype=np.float64) / 255.0)
        de = float(delta_e2000(img[skin], scene.photo.linear[skin]).mean())
        assert de < min(target, bound), f"{name}, --view {view}: mean ΔE2000 {de:.2f}"
