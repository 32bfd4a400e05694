"""The kiosk has no default PIN: it refuses to start (one clear line naming ``sheer kiosk --set-pin``)
until an administrator PIN is configured; ``--set-pin`` stores it hashed and the kiosk then starts."""

from __future__ import annotations

import json
import subprocess
import sys
from typing import TYPE_CHECKING

import pytest

from app.cli import main
from app.kiosk.config import KioskConfig, check_pin, require_pin
from core.errors import SheerError

if TYPE_CHECKING:
    from pathlib import Path


class _Terminal:
    """Standard input as a terminal (the PIN is then asked with getpass)."""

    def isatty(self) -> bool:
        return True


def _sheer(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    """``sheer ARGS`` in a real process (standard input a pipe holding ``stdin``, or /dev/null)."""
    return subprocess.run([sys.executable, "-m", "app.cli", *args], input=stdin, text=True, capture_output=True,
                          timeout=120, stdin=None if stdin is not None else subprocess.DEVNULL)


def test_a_missing_config_has_no_pin(tmp_path: Path) -> None:
    cfg = KioskConfig.load(tmp_path / "absent.json")
    assert not cfg.has_pin and cfg.pin_hash == ""
    assert not check_pin("0000", cfg.pin_hash)
    with pytest.raises(SheerError, match="sheer kiosk --set-pin"):
        require_pin(cfg)


def test_a_plain_pin_in_the_file_is_not_a_pin(tmp_path: Path) -> None:
    path = tmp_path / "kiosk.json"
    path.write_text(json.dumps({"pin_hash": "0000"}), encoding="utf-8")
    assert not KioskConfig.load(path).has_pin


def test_the_kiosk_refuses_to_start_without_a_pin(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "kiosk.json"
    path.write_text(json.dumps({"snapshot_dir": str(tmp_path / "photos"), "fullscreen": False}), encoding="utf-8")
    assert main(["kiosk", "--config", str(path), "--windowed"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "sheer kiosk --set-pin" in err and "Traceback" not in err


def test_the_window_itself_refuses_a_config_without_a_pin() -> None:
    from app.kiosk.window import KioskWindow

    with pytest.raises(SheerError, match="--set-pin"):
        KioskWindow(KioskConfig())


def test_set_pin_stores_a_hash_and_the_kiosk_may_start(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    import getpass

    monkeypatch.setattr("sys.stdin", _Terminal())
    path = tmp_path / "kiosk.json"
    answers = iter(["135790", "135790"])
    monkeypatch.setattr(getpass, "getpass", lambda prompt="": next(answers))
    assert main(["kiosk", "--config", str(path), "--set-pin"]) == 0
    stored = json.loads(path.read_text(encoding="utf-8"))["pin_hash"]
    assert "135790" not in stored
    cfg = KioskConfig.load(path)
    assert cfg.has_pin and check_pin("135790", cfg.pin_hash) and not check_pin("0000", cfg.pin_hash)
    require_pin(cfg)  # no error
    capsys.readouterr()


def test_set_pin_refuses_a_mismatch_and_short_pins(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    import getpass

    monkeypatch.setattr("sys.stdin", _Terminal())
    path = tmp_path / "kiosk.json"
    for first, second in (("1234", "4321"), ("12", "12")):
        answers = iter([first, second])
        monkeypatch.setattr(getpass, "getpass", lambda prompt="", a=answers: next(a))
        assert main(["kiosk", "--config", str(path), "--set-pin"]) == 2
        assert not KioskConfig.load(path).has_pin
    capsys.readouterr()


def test_engine_settings_are_checked(tmp_path: Path) -> None:
    path = tmp_path / "kiosk.json"
    path.write_text(json.dumps({"engine": "warp-drive", "max_frame_ms": -5.0, "face_dir": "/faces/anna"}),
                    encoding="utf-8")
    cfg = KioskConfig.load(path)
    assert cfg.engine == "auto" and cfg.max_frame_ms == 10.0 and cfg.face_dir == "/faces/anna"
    path.write_text(json.dumps({"engine": "lightweight"}), encoding="utf-8")
    assert KioskConfig.load(path).engine == "lightweight"


def test_a_provisioning_script_sets_the_pin_on_standard_input_or_from_a_file(tmp_path: Path) -> None:
    """Not a terminal: the PIN is the first line of standard input (a second line must repeat it), or of
    ``--pin-file``; a refused PIN changes nothing, in one line."""
    path = tmp_path / "kiosk.json"
    done = _sheer("kiosk", "--config", str(path), "--set-pin", stdin="482913\n")
    assert done.returncode == 0, done.stderr
    cfg = KioskConfig.load(path)
    assert check_pin("482913", cfg.pin_hash) and "482913" not in path.read_text(encoding="utf-8")
    refused = _sheer("kiosk", "--config", str(path), "--set-pin", stdin="111222\n111333\n")
    assert refused.returncode == 2 and "differ" in refused.stderr and len(refused.stderr.strip().splitlines()) == 1
    empty = _sheer("kiosk", "--config", str(path), "--set-pin", stdin="")
    assert empty.returncode == 2 and "--pin-file" in empty.stderr
    assert check_pin("482913", KioskConfig.load(path).pin_hash)  # unchanged
    pin_file = tmp_path / "pin.txt"
    pin_file.write_text("97531086\n", encoding="utf-8")
    done = _sheer("kiosk", "--config", str(path), "--set-pin", "--pin-file", str(pin_file))
    assert done.returncode == 0, done.stderr
    assert check_pin("97531086", KioskConfig.load(path).pin_hash)
    missing = _sheer("kiosk", "--config", str(path), "--set-pin", "--pin-file", str(tmp_path / "nope.txt"))
    assert missing.returncode == 2 and "nope.txt" in missing.stderr and "Traceback" not in missing.stderr
    short = _sheer("kiosk", "--config", str(path), "--set-pin", stdin="1234\n")
    assert short.returncode == 2 and "at least 6" in short.stderr
    assert check_pin("97531086", KioskConfig.load(path).pin_hash)


def test_camera_and_watched_folder_settings(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "kiosk.json"
    assert KioskConfig.load(path).camera == "auto" and KioskConfig.load(path).can_try_on
    assert main(["kiosk", "--config", str(path), "--camera", "off"]) == 0
    cfg = KioskConfig.load(path)
    assert not cfg.camera_enabled and not cfg.can_try_on
    assert main(["kiosk", "--config", str(path), "--watch-dir", str(tmp_path / "drop")]) == 0
    cfg = KioskConfig.load(path)
    assert not cfg.camera_enabled and cfg.can_try_on and cfg.watch_dir == str(tmp_path / "drop")
    capsys.readouterr()
