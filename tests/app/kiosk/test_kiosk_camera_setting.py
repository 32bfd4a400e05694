"""The kiosk's camera setting is checked when it is stored (``sheer kiosk --camera``) and when the kiosk
starts: a word that is no device and no file, a missing file, a still image (with the hint to use a watched
folder) or a file that is not a video is one line and exit status 2, and nothing is saved; a video file is
stored with its absolute path. A camera that gives no pictures as the kiosk opens is logged with its reason,
and the start screen says so, or "Try it on me" takes the photo from the watched folder."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from app.cli import main
from app.kiosk.config import KioskConfig
from app.qt_compat import pin_singletons
from tests.app.kiosk.kiosk_support import pin_hash
from tests.app.test_kiosk_camera import write_video

pin_singletons()


def refused(config: Path, camera: str, capsys: pytest.CaptureFixture[str]) -> str:
    """``sheer kiosk --camera CAMERA``: status 2, nothing saved; the one line on standard error."""
    assert main(["kiosk", "--config", str(config), "--camera", camera]) == 2
    out = capsys.readouterr()
    lines = out.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in out.err and "saved" not in out.out, out
    assert not config.exists(), "a refused camera saves nothing"
    return lines[0]


def test_a_camera_that_can_never_work_is_refused_when_it_is_stored(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from PIL import Image

    config = tmp_path / "kiosk.json"
    assert "camera 'banana': no such device or file" in refused(config, "banana", capsys)
    assert "camera '/missing.mp4': no such device or file" in refused(config, "/missing.mp4", capsys)
    still = tmp_path / "still.jpg"
    Image.new("RGB", (64, 48), (120, 110, 100)).save(still)
    line = refused(config, str(still), capsys)
    assert "is a still image" in line and "--watch-dir" in line, line
    text = tmp_path / "clip.mp4"
    text.write_text("not a video\n", encoding="utf-8")
    assert "not a video OpenCV can read a frame from" in refused(config, str(text), capsys)
    absent = next(str(n) for n in range(9, 64) if not Path(f"/dev/video{n}").exists())
    assert f"there is no video device /dev/video{absent}" in refused(config, absent, capsys)
    assert "camera /dev/video-gone: no such device" in refused(config, "/dev/video-gone", capsys)


def test_a_video_file_auto_and_off_are_stored(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    config = tmp_path / "kiosk.json"
    write_video(tmp_path / "cam.avi")
    monkeypatch.chdir(tmp_path)
    assert main(["kiosk", "--config", str(config), "--camera", "cam.avi"]) == 0
    assert KioskConfig.load(config).camera == str(tmp_path / "cam.avi")
    for camera in ("auto", "off", "OFF"):
        assert main(["kiosk", "--config", str(config), "--camera", camera]) == 0
        assert KioskConfig.load(config).camera == camera.lower()
    capsys.readouterr()


def test_the_configured_camera_is_checked_when_the_kiosk_starts(tmp_path: Path) -> None:
    """A hand-edited configuration: one line naming it, status 2, before the display check."""
    from PIL import Image

    still = tmp_path / "still.png"
    Image.new("RGB", (64, 48), (120, 110, 100)).save(still)
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM")}
    for camera, words in (("banana", "no such device or file"), (str(still), "is a still image")):
        config = tmp_path / "kiosk.json"
        config.write_text(json.dumps({"pin_hash": pin_hash("2468"), "camera": camera}), encoding="utf-8")
        done = subprocess.run([sys.executable, "-m", "app.cli", "kiosk", "--config", str(config)], env=env,
                              capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
        lines = done.stderr.strip().splitlines()
        assert done.returncode == 2 and len(lines) == 1, done.stderr
        assert str(config) in lines[0] and words in lines[0] and "display" not in lines[0], lines[0]


@pytest.mark.qt
@pytest.mark.gl
@pytest.mark.parametrize("watched", [False, True])
def test_a_camera_gone_at_start_is_logged_and_said_or_the_watched_folder_is_used(
        qapp: object, tmp_path: Path, caplog: pytest.LogCaptureFixture, watched: bool) -> None:
    from app.kiosk.window import CAMERA_DOWN
    from tests.app.kiosk.test_kiosk_pin import open_kiosk

    config: dict[str, Any] = {"camera": "/dev/video-unplugged"}
    if watched:
        config["watch_dir"] = str(tmp_path / "drop")
    with caplog.at_level("INFO", logger="sheer.kiosk"), open_kiosk(qapp, tmp_path, **config) as kiosk:
        assert kiosk.screen_name == "start" and kiosk.start_button.isVisible()
        said = [r.getMessage() for r in caplog.records if "/dev/video-unplugged: no such device" in r.getMessage()]
        assert len(said) == 1, caplog.text
        if watched:
            assert kiosk.tryon_button.isVisible() and not kiosk.camera_notice.isVisible()
            assert "watched folder" in said[0]
        else:
            assert not kiosk.tryon_button.isVisible()
            assert kiosk.camera_notice.isVisible() and kiosk.camera_notice.text() == CAMERA_DOWN
            assert "not offered" in said[0]


@pytest.mark.qt
@pytest.mark.gl
def test_a_working_camera_at_start_offers_try_it_on_me_and_says_nothing(qapp: object, tmp_path: Path) -> None:
    from tests.app.kiosk.test_kiosk_pin import open_kiosk

    camera = write_video(tmp_path / "cam.avi")
    with open_kiosk(qapp, tmp_path, camera=str(camera)) as kiosk:
        assert kiosk.tryon_button.isVisible() and not kiosk.camera_notice.isVisible()
