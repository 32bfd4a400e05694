"""The try-on's picture sources on this camera-less machine: a real ``cv2.VideoCapture`` on a video file
written here (it stands in for a camera: it opens, gives frames, then stops as an unplugged camera does),
and a watched folder (the newest photo written after the source opened, read once and deleted)."""

from __future__ import annotations

import os
import time
from typing import TYPE_CHECKING

import numpy as np
import pytest

from app.camera_source import (
    MAX_SIDE,
    CameraError,
    CameraGone,
    CameraSource,
    FolderSource,
    open_source,
    read_photo_file,
)

if TYPE_CHECKING:
    from pathlib import Path


def portrait_path() -> Path:
    """Grace Hopper's portrait, from the sample assets' search path (core.assets)."""
    from core.assets import find_asset

    return find_asset("photos/grace_hopper.jpg")


def write_video(path: Path, frames: int = 6, size: tuple[int, int] = (320, 240)) -> Path:
    """A short MJPG video of a colour ramp (frame k's red channel ≈ 40·k)."""
    import cv2

    w, h = size
    out = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (w, h))
    assert out.isOpened()
    for k in range(frames):
        bgr = np.zeros((h, w, 3), np.uint8)
        bgr[:, :, 2] = 40 * k
        bgr[:, :, 1] = 128
        out.write(bgr)
    out.release()
    return path


def test_a_video_device_gives_rgb_frames_then_is_gone(tmp_path: Path) -> None:
    cam = CameraSource(str(write_video(tmp_path / "cam.avi")))
    frames = []
    with pytest.raises(CameraGone, match="stopped giving pictures"):
        for _ in range(50):
            f = cam.read()
            assert f is not None and f.shape == (240, 320, 3) and f.dtype == np.uint8
            frames.append(f)
    # RGB order (the file is BGR): green 128 everywhere, red rising frame by frame
    assert abs(int(np.median(frames[0][:, :, 1])) - 128) <= 3
    reds = [int(np.median(f[:, :, 0])) for f in frames[:6]]
    assert reds == sorted(reds) and reds[-1] - reds[0] > 150
    cam.close()
    cam.close()  # idempotent


def test_whether_a_camera_is_there(tmp_path: Path) -> None:
    from pathlib import Path

    from app.camera_source import camera_present

    assert not camera_present("off")
    assert camera_present("auto") == any(Path("/dev").glob("video*"))
    assert not camera_present(str(tmp_path / "no-such-device")) and not camera_present("97")
    assert camera_present(str(write_video(tmp_path / "cam.avi")))


def test_no_camera_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(CameraError, match="no camera could be opened"):
        CameraSource(str(tmp_path / "no-such-device"))
    with pytest.raises(CameraError, match="camera is off"):
        open_source("off", "")
    # a camera that cannot be opened falls back to the watched folder
    assert isinstance(open_source(str(tmp_path / "no-such-device"), str(tmp_path / "drop")), FolderSource)


def test_the_watched_folder_takes_the_newest_new_photo_and_deletes_it(tmp_path: Path) -> None:
    from PIL import Image

    drop = tmp_path / "drop"
    drop.mkdir()
    old = drop / "old.jpg"
    Image.new("RGB", (64, 64), (10, 10, 10)).save(old)
    past = time.time() - 3600
    os.utime(old, (past, past))
    src = open_source("off", str(drop))
    assert not src.live and src.read() is None
    Image.open(portrait_path()).save(drop / "shopper.png")
    (drop / "notes.txt").write_text("not a photo", encoding="utf-8")
    deadline = time.time() + 5
    photo = None
    while photo is None and time.time() < deadline:
        photo = src.read()
        time.sleep(0.05)
    assert photo is not None and photo.shape == np.asarray(Image.open(portrait_path()).convert("RGB")).shape
    assert not (drop / "shopper.png").exists(), "the shopper's photo is kept in memory only"
    assert old.exists() and src.read() is None  # an older file is not hers


@pytest.mark.parametrize("mode", ["L", "CMYK"])
def test_grey_and_cmyk_photos_become_rgb(tmp_path: Path, mode: str) -> None:
    from PIL import Image

    path = tmp_path / f"p-{mode}.jpg"
    Image.open(portrait_path()).convert(mode).save(path)
    rgb = read_photo_file(path)
    assert rgb.ndim == 3 and rgb.shape[2] == 3 and rgb.dtype == np.uint8


def test_a_large_photo_is_reduced_and_a_truncated_one_refused(tmp_path: Path) -> None:
    from PIL import Image

    big = tmp_path / "big.png"
    Image.new("RGB", (3872, 2592), (200, 150, 120)).save(big)  # 10 megapixels
    assert max(read_photo_file(big).shape[:2]) == MAX_SIDE
    cut = tmp_path / "cut.jpg"
    data = portrait_path().read_bytes()
    cut.write_bytes(data[: len(data) // 3])
    with pytest.raises(CameraError, match="cut.jpg: not a readable photo"):
        read_photo_file(cut)
