"""The kiosk has no default PIN: it refuses to start (one clear line naming ``sheer kiosk --set-pin``)
until an administrator PIN is configured; ``--set-pin`` stores it hashed and the kiosk then starts."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import pytest

from app.cli import main
from app.kiosk_config import KioskConfig, check_pin, require_pin
from core.errors import SheerError

if TYPE_CHECKING:
    from pathlib import Path


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
    from app.kiosk import KioskWindow

    with pytest.raises(SheerError, match="--set-pin"):
        KioskWindow(KioskConfig())


def test_set_pin_stores_a_hash_and_the_kiosk_may_start(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    import getpass

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
