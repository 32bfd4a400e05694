"""What ``sheer capture`` says: what matters by default, every step with ``--verbose``, nothing of MediaPipe's
logging, and an output folder it cannot write refused before the capture's work."""

from __future__ import annotations

import contextlib
import io
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from app.cli import main
from core.assets import find_asset

SHEER = str(Path(sys.executable).with_name("sheer"))
POINTS = Path(__file__).resolve().parents[1] / "data" / "capture" / "grace_hopper_points.json"
#: The astronaut's hand-picked points: a capture from points that fits in a few seconds (Grace Hopper's,
#: with no flash highlight for the sample head's lobe, takes ~20 s in the lobe's registration).
ASTRONAUT_POINTS = POINTS.with_name("astronaut_points.json")

pytestmark = pytest.mark.slow


def test_a_capture_says_what_matters(tmp_path: Path) -> None:
    """A real process (MediaPipe writes below Python): a few lines, each Sheer's (the face, the focal length and
    where it came from, the reproduction, notes, what was written), none of them the RMS error of a head built
    from the same landmarks (0.00 px) or an ambient scale without a probe."""
    out = tmp_path / "grace"
    done = subprocess.run([SHEER, "capture", "--photo", str(find_asset("photos/grace_hopper.jpg")), "--out", str(out),
                           "--texture-size", "64"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert all(line.startswith("capture: ") for line in lines), done.stderr  # no I0000/W0000/INFO: lines
    assert len(lines) <= 6, done.stderr
    assert any(line.startswith("capture: focal length") for line in lines), done.stderr
    assert lines[0].startswith("capture: face found:") and "quality gate passed" in lines[0]
    assert any(line.startswith("capture: reproduction: mean ΔE2000") for line in lines)
    assert lines[-1].startswith(f"capture: wrote {out}/: face.json")
    assert "reprojection" not in done.stderr and "ambient scale" not in done.stderr
    assert (out / "face.json").is_file()


def test_verbose_prints_every_step_and_only_true_ones(tmp_path: Path) -> None:
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        rc = main(["capture", "--photo", str(find_asset("photos/grace_hopper.jpg")), "--out", str(tmp_path / "g"),
                   "--texture-size", "64", "--verbose"])
    text = err.getvalue()
    assert rc == 0, text
    for step in ("focal length", "person's head", "camera from", "skin mask", "Phong fit", "detail texture",
                 "reproduction"):
        assert f"capture: {step}" in text, step
    camera = next(line for line in text.splitlines() if "camera from" in line)
    assert re.fullmatch(r"capture: camera from \d+ detected landmarks", camera)  # no "error 0.00 px"
    phong = next(line for line in text.splitlines() if "Phong fit" in line)
    assert "ambient" not in phong and "—" not in phong  # no probe: no ambient light to speak of


def test_points_report_their_reprojection_error(tmp_path: Path) -> None:
    """With --points the error is the user's own points': said without --verbose."""
    spec = json.loads(ASTRONAUT_POINTS.read_text(encoding="utf-8"))
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        rc = main(["capture", "--photo", str(find_asset(spec["photo"])), "--head", str(find_asset(spec["head"])),
                   "--points", str(ASTRONAUT_POINTS), "--out", str(tmp_path / "p"), "--texture-size", "64"])
    text = err.getvalue()
    assert rc == 0, text
    assert "capture: camera from correspondences: RMS reprojection error" in text
    assert "Phong fit" not in text and "skin mask" not in text


@pytest.mark.parametrize("mode", [[], ["--points", str(POINTS)]])
def test_an_output_folder_it_cannot_write_is_refused_first(tmp_path: Path, mode: list[str]) -> None:
    """A folder under a file (the suite runs as root, for whom no folder is read-only): one line naming the
    output, and no step of the capture before it."""
    blocker = tmp_path / "a-file"
    blocker.write_text("in the way")
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        rc = main(["capture", "--photo", str(find_asset("photos/grace_hopper.jpg")), *mode,
                   "--out", str(blocker / "face"), "--verbose"])
    text = err.getvalue()
    assert rc == 2
    assert text.count("\n") == 1 and f"{blocker / 'face'}: cannot be created" in text, text
    assert "capture:" not in text
