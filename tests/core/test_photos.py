"""EXIF orientation (tags 2–8) in every reader of a user's photograph: the capture's (``--points`` /
``--camera``, the probe and ``--calibrate-light``: ``capture.pipeline.read_photo``), the automatic
capture's, ``sheer shade match --photo``'s, the mirror's ``--photo`` and the kiosk's watched folder read
the same upright pixels as from a file stored upright; and ``sheer shade match --photo`` gives the same
answer for a sideways-stored portrait as for the upright one."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

#: For each EXIF orientation, how the stored pixels are turned back to upright (Pillow's transposes).
STORED_FROM_UPRIGHT = {
    2: Image.Transpose.FLIP_LEFT_RIGHT,
    3: Image.Transpose.ROTATE_180,
    4: Image.Transpose.FLIP_TOP_BOTTOM,
    5: Image.Transpose.TRANSPOSE,
    6: Image.Transpose.ROTATE_90,
    7: Image.Transpose.TRANSVERSE,
    8: Image.Transpose.ROTATE_270,
}


def _stored(upright: Image.Image, orientation: int, path: Path) -> Path:
    """``upright`` stored as a camera would with ``orientation``: the pixels turned, the tag saying so."""
    stored = upright.transpose(STORED_FROM_UPRIGHT[orientation])
    exif = Image.Exif()
    exif[0x0112] = orientation
    stored.save(path, exif=exif.tobytes())  # PNG: lossless, so the pixels compare exactly
    return path


def _readers() -> dict[str, object]:
    from app.camera_source import read_photo_file
    from app.commands.render_views import read_photo_srgb8 as mirror_photo
    from capture.auto import read_photo_srgb8 as auto_photo
    from capture.pipeline import read_photo as capture_photo
    from shade.photo import read_photo as shade_photo

    def u8(values: np.ndarray, linear: bool = False) -> np.ndarray:
        from km.srgb import srgb_encode

        return np.round((srgb_encode(values) if linear else values) * 255.0).astype(np.uint8)

    return {
        "capture (points, camera, probe, calibrate-light)": lambda p: u8(capture_photo(p), linear=True),
        "automatic capture": lambda p: auto_photo(p)[0],
        "shade match --photo": lambda p: u8(shade_photo(p)),
        "render --view mirror --photo": lambda p: mirror_photo(str(p)),
        "kiosk watched folder": lambda p: read_photo_file(Path(p)),
    }


@pytest.mark.parametrize("orientation", sorted(STORED_FROM_UPRIGHT))
def test_every_reader_turns_the_photo_upright(orientation: int, tmp_path: Path) -> None:
    rng = np.random.default_rng(orientation)
    upright = Image.fromarray(rng.integers(0, 256, (48, 32, 3), dtype=np.uint8))  # 32 wide, 48 tall
    plain = tmp_path / "upright.png"
    upright.save(plain)
    stored = _stored(upright, orientation, tmp_path / f"stored-{orientation}.png")
    for name, read in _readers().items():
        want = np.asarray(read(plain))  # type: ignore[operator]
        got = np.asarray(read(stored))  # type: ignore[operator]
        assert got.shape == want.shape and np.array_equal(got, want), (name, orientation, got.shape)


def test_shade_match_reads_a_sideways_portrait_as_the_upright_one(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main
    from core.assets import find_asset

    with Image.open(find_asset("photos/grace_hopper.jpg")) as im:
        portrait = im.convert("RGB")
    plain = tmp_path / "hopper.png"
    portrait.save(plain)
    sideways = _stored(portrait, 6, tmp_path / "hopper-sideways.png")
    answers = []
    for path in (plain, sideways):
        assert main(["shade", "match", "--photo", str(path)]) == 0
        answers.append(capsys.readouterr().out.replace(str(path), "PHOTO"))
    assert answers[0] == answers[1]
