"""Where the kiosk keeps its files, and who may read them: the configuration (the PIN's hash) and the PIN
lock file are written mode 0600 from the moment they exist, in the configuration folder
(``$XDG_CONFIG_HOME/sheer``), an older wider file is tightened on the next write; the log goes to
``--log FILE``, the configuration's ``log`` or ``$XDG_STATE_HOME/sheer/kiosk.log``."""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from app.cli import main
from app.kiosk.config import KioskConfig, check_pin, default_log_path
from app.kiosk.pin_lock import PinGuard, lock_path_for
from tests.app.kiosk import kiosk_support

RIGHT, WRONG = "975318", "864297"


def mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


@pytest.fixture
def wide_umask() -> object:
    """The usual umask (022), under which a plain write makes a file every user can read."""
    old = os.umask(0o022)
    yield
    os.umask(old)


def test_set_pin_writes_the_configuration_0600_in_the_configuration_folder(tmp_path: Path, wide_umask: object) -> None:
    """A real ``sheer kiosk --set-pin`` with no ``--config``: ``$XDG_CONFIG_HOME/sheer/kiosk.json``, mode 0600."""
    env = {**os.environ, "XDG_CONFIG_HOME": str(tmp_path / "xdg")}
    done = subprocess.run([sys.executable, "-m", "app.cli", "kiosk", "--set-pin"], input=f"{RIGHT}\n", text=True,
                          capture_output=True, timeout=120, env=env)
    assert done.returncode == 0, done.stderr
    path = tmp_path / "xdg" / "sheer" / "kiosk.json"
    assert str(path) in done.stdout
    assert mode(path) == 0o600 and check_pin(RIGHT, KioskConfig.load(path).pin_hash)


def test_a_readable_configuration_is_tightened_on_the_next_write_never_wider(
        tmp_path: Path, wide_umask: object, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "kiosk.json"
    path.write_text(json.dumps({"pin_hash": kiosk_support.pin_hash(RIGHT)}), encoding="utf-8")
    assert mode(path) == 0o644  # as an older Sheer (or an editor) left it
    renamed: list[tuple[str, int, int]] = []
    real_replace = os.replace

    def replace(src: str | os.PathLike[str], dst: str | os.PathLike[str]) -> None:
        # the new file's mode at the moment it takes the configuration's place, and the old one's
        renamed.append((str(dst), mode(Path(src)), mode(Path(dst)) if Path(dst).exists() else -1))
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    assert main(["kiosk", "--config", str(path), "--snapshot-dir", str(tmp_path / "photos")]) == 0
    capsys.readouterr()
    assert renamed == [(str(path), 0o600, 0o644)]
    assert mode(path) == 0o600
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no temporary file left


def test_the_pin_lock_file_is_0600_beside_the_configuration(tmp_path: Path, wide_umask: object) -> None:
    config = tmp_path / "kiosk.json"
    lock = lock_path_for(config)
    assert lock == tmp_path / "kiosk-pin-lock.json"
    guard = PinGuard(kiosk_support.pin_hash(RIGHT), lock)
    assert not guard.attempt(WRONG).accepted
    assert mode(lock) == 0o600 and json.loads(lock.read_text(encoding="utf-8"))["failures"] == 1
    os.chmod(lock, 0o644)
    assert not PinGuard(kiosk_support.pin_hash(RIGHT), lock).attempt(WRONG).accepted
    assert mode(lock) == 0o600 and json.loads(lock.read_text(encoding="utf-8"))["failures"] == 2


def test_where_the_kiosk_logs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("SHEER_KIOSK_LOG", raising=False)
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    assert default_log_path() == tmp_path / "state" / "sheer" / "kiosk.log"
    monkeypatch.delenv("XDG_STATE_HOME")
    assert default_log_path() == Path.home() / ".local" / "state" / "sheer" / "kiosk.log"
    cfg = KioskConfig.load(tmp_path / "cfg" / "kiosk.json")
    assert cfg.log_path() == default_log_path()
    cfg.log = "logs/kiosk.log"  # the configuration's key: relative to its folder
    assert cfg.log_path() == tmp_path / "cfg" / "logs" / "kiosk.log"
    assert cfg.log_path(str(tmp_path / "given.log")) == tmp_path / "given.log"  # --log FILE first
    monkeypatch.setenv("SHEER_KIOSK_LOG", str(tmp_path / "env.log"))
    assert cfg.log_path() == tmp_path / "env.log"
    assert cfg.log_path(str(tmp_path / "given.log")) == tmp_path / "given.log"


def test_a_log_the_kiosk_cannot_write_is_one_line_before_the_kiosk_starts(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setenv("QT_QPA_PLATFORM", os.environ.get("QT_QPA_PLATFORM", "offscreen"))  # past the display check
    config = tmp_path / "kiosk.json"
    config.write_text(json.dumps({"pin_hash": kiosk_support.pin_hash(RIGHT), "resolution": 64}), encoding="utf-8")
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("", encoding="utf-8")
    assert main(["kiosk", "--config", str(config), "--log", str(blocker / "kiosk.log")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(blocker / "kiosk.log") in err and "--log" in err, err
