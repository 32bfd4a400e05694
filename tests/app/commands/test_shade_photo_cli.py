"""``sheer shade match --photo``: one reading of a portrait's skin, the kiosk's, a match with an honest
confidence, and "no face" when there is none.

``grace_hopper.jpg``, the README's own example, was refused ("not a skin colour the skin model can produce:
ΔE2000 11.9 > 10") while the kiosk's *Find my foundation* matched the same photograph (Honey, with a "hard to
read" note); a photo of no face was read as a face by a Haar cascade and refused as "not a skin colour".
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageFilter

from app.cli import main
from core.assets import find_asset

SHEER = str(Path(sys.executable).with_name("sheer"))


def test_the_readme_portrait_is_matched_as_the_kiosk_reads_it(tmp_path: Path) -> None:
    """A real process: exit 0, her skin read on the kiosk's cheek band (capture.skin, MediaPipe's landmarks),
    the kiosk's ranking (its job: own skin as the target, daylight) with a low confidence, and no MediaPipe
    log lines."""
    from capture.landmarks import detect_faces
    from capture.skin import cheek_band, skin_from_landmarks
    from km.library import default_library
    from km.skin import fit_skin
    from shade.match import ShadeBank, foundations, match_shades

    photo = find_asset("photos/grace_hopper.jpg")
    done = subprocess.run([SHEER, "shade", "match", "--photo", str(photo), "--json", "--no-checker"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""  # no I0000/W0000/INFO: lines of MediaPipe's C++ side
    js = json.loads(done.stdout)
    # the kiosk's reading: the band across her cheeks, from the same landmarks
    face = detect_faces(np.asarray(Image.open(photo).convert("RGB")))[0]
    band = cheek_band(face.standard(), face.width, face.height)
    assert js["source"]["source"] == "face" and js["source"]["boxes"] == [list(band)]
    kiosk = skin_from_landmarks(photo, face.standard(), face.width, face.height, use_checker=False)
    np.testing.assert_allclose(js["source"]["linear_rgb"], kiosk.linear_rgb, atol=1e-5)
    fit = fit_skin(linear_rgb=kiosk.linear_rgb)
    assert js["skin"]["residual_de2000"] == pytest.approx(fit.residual_de2000, abs=1e-3)
    # matched, not refused, as the kiosk ranks it, and honest about it
    kiosk_ranked = match_shades(fit.reflectance, fit.reflectance, ShadeBank.from_materials(foundations(default_library())))
    assert [s["name"] for s in js["shades"]] == [s.name for s in kiosk_ranked]
    assert js["confidence"]["level"] == "low" and "confirm the shade in person" in js["confidence"]["words"]


def test_the_table_states_the_confidence(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["shade", "match", "--photo", str(find_asset("photos/astronaut.png")), "--no-checker",
                 "--top", "1"]) == 0
    out = capsys.readouterr().out
    assert any(line.startswith("confidence: ") for line in out.splitlines())
    assert "OUT OF THE MODEL'S GAMUT" not in out


def test_a_typed_skin_colour_has_a_high_confidence(capsys: pytest.CaptureFixture[str]) -> None:
    from km.colour import spectrum_to_rgb
    from km.skin import skin_reflectance
    from km.srgb import srgb_encode

    rgb = np.round(srgb_encode(spectrum_to_rgb(skin_reflectance(0.08, 0.01))) * 255).astype(int)
    assert main(["shade", "match", "--rgb", ",".join(map(str, rgb)), "--json", "--top", "1"]) == 0
    js = json.loads(capsys.readouterr().out)
    assert js["confidence"]["level"] == "high"


def _no_face(path: Path) -> Path:
    """Blurred coloured noise, with no face in it, where OpenCV's Haar cascade still finds one (as on a photo
    of dogs): 480² px, seeded."""
    rng = np.random.default_rng(0)
    small = Image.fromarray(rng.integers(0, 255, (60, 60, 3)).astype(np.uint8))
    small.resize((480, 480), Image.Resampling.BILINEAR).filter(ImageFilter.GaussianBlur(3)).save(path)
    return path


def test_a_photo_without_a_face_says_no_face(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """Not "not a skin colour": the photo has no face; --region still reads given pixels."""
    photo = _no_face(tmp_path / "no-face.png")
    assert main(["shade", "match", "--photo", str(photo)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no face found in the photograph" in err and "--region" in err
    assert "skin colour" not in err
