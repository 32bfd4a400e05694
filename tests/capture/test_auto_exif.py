"""The automatic capture takes the photograph's focal length (issue 14): its EXIF, or ``--focal-mm``.

The photographs are real files with real EXIF written by Pillow: the sample head drawn by the capture's
CPU renderer (:func:`tests.capture.auto_support.render_sample`) through a 26 mm-equivalent phone lens
from 34 cm — the case where the automatic capture's own assumption (a portrait lens, 61 mm for a square
photograph) is furthest off. The camera is compared with the true one through the similarity that maps
the person's head's landmarks onto the sample head's (:func:`bench.capture_auto.compare_camera`), so the
distance error is the camera's geometry, not the metric scale.
"""

from __future__ import annotations

import contextlib
import io
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest
from PIL import Image

from tests.capture.auto_support import FOCAL_35, LENS_MM, phone_photo, sample_head
from tests.capture.auto_support import PHONE_SIZE as SIZE
from tests.capture.auto_support import exif_bytes as _exif

if TYPE_CHECKING:
    from pathlib import Path


@pytest.fixture(scope="module")
def captures(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """Three automatic captures of the phone photograph: with EXIF (``sheer capture``, a JPEG; the command's
    standard error kept), with a corrupt tag (``capture_auto``, a PNG) and with ``--focal-mm`` on a file
    without EXIF. All in this process: the command's own process is tests/capture/test_cli_output.py's."""
    from app.cli import main
    from capture.auto import capture_auto
    from capture.face import load_face

    d = tmp_path_factory.mktemp("auto-exif")
    srgb8, camera = phone_photo()
    Image.fromarray(srgb8).save(d / "exif.jpg", quality=95, exif=_exif({FOCAL_35: round(LENS_MM)}))
    Image.fromarray(srgb8).save(d / "corrupt.png", exif=_exif({FOCAL_35: 0}))
    Image.fromarray(srgb8).save(d / "bare.png")
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        rc_exif = main(["capture", "--photo", str(d / "exif.jpg"), "--out", str(d / "exif"), "--allow-closed-eyes",
                        "--texture-size", "128"])
    lines: list[str] = []
    capture_auto(d / "corrupt.png", d / "corrupt", allow_closed_eyes=True, texture_size=128, progress=lines.append)
    rc = main(["capture", "--photo", str(d / "bare.png"), "--focal-mm", str(LENS_MM), "--out", str(d / "given"),
               "--allow-closed-eyes", "--texture-size", "128"])
    assert rc_exif == 0 and rc == 0, err.getvalue()
    return {"camera": camera, "cli": err.getvalue(), "lines": lines,
            **{k: load_face(d / k) for k in ("exif", "corrupt", "given")}}


def _figures(face: Any, camera: Any) -> dict[str, float]:
    from bench.capture_auto import compare_camera

    return compare_camera(sample_head(), camera, face)[0]


def test_the_photos_exif_sets_the_automatic_captures_camera(captures: dict[str, Any]) -> None:
    """``sheer capture`` reads the JPEG's FocalLengthIn35mmFilm (26 mm): the log and face.json say so, the
    person's head is un-projected through it, and the camera's distance comes out within 5 % (measured
    −0.2 % on the GPU bench; the fitted focal length 0.94 × the true one)."""
    face = captures["exif"]
    assert "focal length 26.0 mm (35 mm equivalent)" in captures["cli"]
    assert "from the photo's EXIF" in captures["cli"], captures["cli"]
    assert face.data["focal"]["source"] == "exif" and face.data["focal"]["mm_35"] == pytest.approx(26.0)
    assert face.data["focal"]["px"] == pytest.approx(captures["camera"].K[0, 0], rel=0.01)
    assert "the photograph's focal length" in face.load_head().metadata.scale_note
    f = _figures(face, captures["camera"])
    assert abs(f["distance_error_pct"]) < 5.0, f
    assert 0.85 < f["focal_ratio"] < 1.15, f


def test_a_corrupt_tag_warns_and_the_prior_is_used(captures: dict[str, Any]) -> None:
    """FocalLengthIn35mmFilm = 0: one warning line, the capture goes on with the portrait-lens prior
    (61.2 mm for a square photograph) and its camera is then more than twice as far as the true one."""
    face, lines = captures["corrupt"], captures["lines"]
    warnings = [ln for ln in lines if ln.startswith("warning:")]
    assert len(warnings) == 1 and "FocalLengthIn35mmFilm" in warnings[0] and "\n" not in warnings[0]
    assert any("assumed (a portrait lens" in ln for ln in lines)
    assert face.data["focal"]["source"] == "prior"
    assert face.data["focal"]["px"] == pytest.approx(2.0 * SIZE)
    assert any("FocalLengthIn35mmFilm" in n for n in face.data["notes"])
    assert "a portrait lens assumed" in face.load_head().metadata.scale_note
    assert _figures(face, captures["camera"])["distance_error_pct"] > 50.0


def test_focal_mm_is_accepted_by_the_automatic_capture(captures: dict[str, Any]) -> None:
    """``--focal-mm 26`` on a file without EXIF: the same camera as the EXIF's, to within a few per cent."""
    face = captures["given"]
    assert face.data["focal"]["source"] == "focal_mm" and face.data["focal"]["mm_35"] == pytest.approx(LENS_MM)
    given, exif = _figures(face, captures["camera"]), _figures(captures["exif"], captures["camera"])
    assert abs(given["distance_error_pct"]) < 5.0
    assert given["focal_ratio"] == pytest.approx(exif["focal_ratio"], rel=0.03)


def test_the_focal_length_changes_the_persons_head(tmp_path: Path) -> None:
    """Un-projected through the true 26 mm lens the person's head differs from the prior's (61 mm) one,
    and the sidecar says which lens; with no focal length the head is exactly the prior's (``focal_px``
    None = :data:`capture.person.PORTRAIT_FOCAL` × the longer side: the kiosk's frames are unchanged)."""
    from capture.exif import focal_px_from_35mm
    from capture.landmarks import detect_faces
    from capture.person import PORTRAIT_FOCAL, person_head

    srgb8, _ = phone_photo()
    face = detect_faces(srgb8)[0]
    none = person_head(face, tmp_path, eyes_open=False)
    prior = person_head(face, tmp_path, eyes_open=False, focal_px=PORTRAIT_FOCAL * SIZE)
    wide = person_head(face, tmp_path, eyes_open=False, focal_px=focal_px_from_35mm(LENS_MM, SIZE, SIZE))
    assert np.array_equal(none.vertices, prior.vertices)
    assert np.abs(wide.vertices - prior.vertices).max() > 0.05  # cm
    assert "photograph's focal length" in wide.metadata.scale_note
    assert "portrait lens assumed" in none.metadata.scale_note


def test_photo_focal_sources(tmp_path: Path) -> None:
    """What :func:`capture.auto.photo_focal` takes: --focal-mm over the file's EXIF; the EXIF in 35 mm terms
    whatever the file's size; nothing for an array (the kiosk's camera frame) or a file without the tag."""
    from capture.auto import photo_focal
    from capture.errors import CaptureError

    img = Image.new("RGB", (600, 400), (180, 120, 100))
    img.save(tmp_path / "t.jpg", exif=_exif({FOCAL_35: 35}))
    img.save(tmp_path / "bare.jpg")
    assert photo_focal(tmp_path / "t.jpg", None, (600, 400))[:2] == (pytest.approx(35.0), "exif")
    assert photo_focal(tmp_path / "t.jpg", 85.0, (600, 400))[:2] == (85.0, "focal_mm")
    assert photo_focal(tmp_path / "bare.jpg", None, (600, 400)) == (None, "prior", [])
    assert photo_focal(np.zeros((4, 4, 3), np.uint8), None, (4, 4)) == (None, "prior", [])
    with pytest.raises(CaptureError, match="4–2000 mm"):
        photo_focal(tmp_path / "t.jpg", 3.0, (600, 400))
