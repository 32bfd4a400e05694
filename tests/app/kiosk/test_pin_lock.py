"""The kiosk PIN's lockout (app.kiosk.pin_lock): locked after 5 wrong PINs, doubling to 15 minutes, kept beside
the configuration across a restart (a real second process), the right PIN accepted once the lock ends,
wrong attempts logged with a timestamp and no digit of any PIN; ``--set-pin`` refuses short PINs."""

from __future__ import annotations

import json
import logging
import os
import re
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from app.kiosk.config import KioskConfig
from app.kiosk.pin_lock import MAX_LOCK_S, PinGuard, lock_path_for, lock_seconds
from tests.app.kiosk import kiosk_support
from tests.app.kiosk.test_kiosk_config import _Terminal

RIGHT, WRONG = "975318", "864297"
REPO = Path(__file__).resolve().parents[3]


class Clock:
    """A wall clock the test moves by hand (seconds since the epoch)."""

    def __init__(self, t: float = 1_700_000_000.0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


@pytest.fixture(scope="module")
def pin_hash() -> str:
    return kiosk_support.pin_hash(RIGHT)  # 200k PBKDF2 rounds: once per test process


def _config(tmp_path: Path, pin_hash: str) -> Path:
    path = tmp_path / "kiosk.json"
    KioskConfig(pin_hash=pin_hash).save(path)
    return path


def test_five_wrong_pins_lock_the_pad_and_the_right_pin_works_once_it_ends(tmp_path: Path, pin_hash: str) -> None:
    clock = Clock()
    guard = PinGuard.for_config(KioskConfig.load(_config(tmp_path, pin_hash)), clock)
    for n in range(1, 5):
        v = guard.attempt(WRONG)
        assert (v.accepted, v.locked_s, v.failures) == (False, 0.0, n)
    v = guard.attempt(WRONG)
    assert (v.accepted, v.locked_s, v.failures) == (False, 30.0, 5) and guard.remaining() == 30.0
    clock.t += 29.5
    assert guard.remaining() == pytest.approx(0.5)
    assert not guard.attempt(RIGHT).accepted  # locked: not even the right PIN is checked
    assert guard.failures == 5  # …and a refusal while locked does not count
    clock.t += 0.5
    assert guard.remaining() == 0.0
    v = guard.attempt(RIGHT)
    assert v.accepted and v.failures == 0 and guard.remaining() == 0.0
    assert json.loads(lock_path_for(tmp_path / "kiosk.json").read_text())["failures"] == 0
    for _ in range(4):  # the count starts again from zero
        assert guard.attempt(WRONG).locked_s == 0.0


def test_each_further_wrong_pin_doubles_the_lock_up_to_15_minutes(tmp_path: Path, pin_hash: str) -> None:
    assert [lock_seconds(n) for n in range(12)] == [0, 0, 0, 0, 0, 30, 60, 120, 240, 480, 900, 900]
    assert lock_seconds(10_000) == MAX_LOCK_S == 900
    clock = Clock()
    guard = PinGuard.for_config(KioskConfig.load(_config(tmp_path, pin_hash)), clock)
    locks = []
    for _ in range(12):
        v = guard.attempt(WRONG)
        locks.append(v.locked_s)
        clock.t += v.locked_s  # wait out the lock, then guess again
    assert locks == [0, 0, 0, 0, 30, 60, 120, 240, 480, 900, 900, 900]


def test_a_clock_set_back_restarts_the_lock(tmp_path: Path, pin_hash: str) -> None:
    clock = Clock()
    guard = PinGuard.for_config(KioskConfig.load(_config(tmp_path, pin_hash)), clock)
    for _ in range(5):
        guard.attempt(WRONG)
    clock.t -= 86_400  # a day back: the lock does not vanish
    assert guard.remaining() == 30.0


def test_the_lock_survives_a_restart_in_another_process(tmp_path: Path, pin_hash: str) -> None:
    """A real process guesses 5 wrong PINs and exits; a second real process (a restarted kiosk on the
    same configuration) finds the pad locked and refuses the right PIN; once the lock ends it takes it."""
    config = _config(tmp_path, pin_hash)
    code = textwrap.dedent("""
        import json, sys
        from pathlib import Path
        from app.kiosk.config import KioskConfig
        from app.kiosk.pin_lock import PinGuard
        guard = PinGuard.for_config(KioskConfig.load(Path(sys.argv[1])))
        pins = sys.argv[2:]
        print(json.dumps({"remaining": guard.remaining(),
                          "verdicts": [guard.attempt(p).accepted for p in pins], "failures": guard.failures}))
    """)

    def kiosk(*pins: str) -> dict[str, object]:
        out = subprocess.run([sys.executable, "-c", code, str(config), *pins], cwd=REPO, capture_output=True,
                             text=True, timeout=120, env={**os.environ})
        assert out.returncode == 0, out.stderr
        return json.loads(out.stdout)

    first = kiosk(*[WRONG] * 5)
    assert first == {"remaining": 0.0, "verdicts": [False] * 5, "failures": 5}
    lock_file = lock_path_for(config)
    assert lock_file.parent == config.parent and lock_file.name == "kiosk-pin-lock.json"
    assert RIGHT not in lock_file.read_text() and WRONG not in lock_file.read_text()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # written atomically
    second = kiosk(RIGHT)
    assert 20.0 < second["remaining"] <= 30.0 and second["verdicts"] == [False] and second["failures"] == 5
    later = PinGuard.for_config(KioskConfig.load(config), clock=lambda: time.time() + 31.0)
    assert later.remaining() == 0.0 and later.attempt(RIGHT).accepted and later.failures == 0


def test_an_unreadable_lock_file_locks_the_pad(tmp_path: Path, pin_hash: str, caplog: pytest.LogCaptureFixture) -> None:
    config = _config(tmp_path, pin_hash)
    lock_path_for(config).write_text("{not json", encoding="utf-8")
    with caplog.at_level(logging.WARNING, logger="sheer.kiosk"):
        guard = PinGuard.for_config(KioskConfig.load(config), Clock())
    assert guard.remaining() == 30.0 and "malformed" in caplog.text
    assert json.loads(lock_path_for(config).read_text())["lock_s"] == 30.0  # rewritten whole


def test_wrong_pins_are_logged_with_a_timestamp_and_no_digits(tmp_path: Path, pin_hash: str,
                                                              caplog: pytest.LogCaptureFixture) -> None:
    clock = Clock()
    guard = PinGuard.for_config(KioskConfig.load(_config(tmp_path, pin_hash)), clock)
    tried = [WRONG, "13", "8642", "20240607", WRONG, RIGHT]  # the sixth (right) one comes during the lock
    with caplog.at_level(logging.DEBUG):
        for pin in tried:
            guard.attempt(pin)
            clock.t += 1
    lines = [r.getMessage() for r in caplog.records]
    wrong = [m for m in lines if "wrong PIN" in m]
    assert len(wrong) == 5
    for m in wrong:
        assert re.search(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", m), m
    assert "locked for 30 s" in wrong[-1] and any("refused" in m for m in lines)
    text = re.sub(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", "<time>", "\n".join(lines))
    for pin in (*tried, RIGHT):
        assert pin not in text
    assert re.findall(r"\d{3,}", text) == []  # beside the timestamps only counts and seconds (< 1000)


def test_set_pin_refuses_fewer_than_6_digits_unless_allowed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    import getpass

    from app.cli import main
    from app.kiosk.config import check_pin

    path = tmp_path / "kiosk.json"

    monkeypatch.setattr("sys.stdin", _Terminal())  # asked at a terminal (piped input is read instead)

    def set_pin(pin: str, *extra: str) -> int:
        answers = iter([pin, pin])
        monkeypatch.setattr(getpass, "getpass", lambda prompt="": next(answers))
        return main(["kiosk", "--config", str(path), "--set-pin", *extra])

    assert set_pin("24680") == 2
    err = capsys.readouterr().err
    assert "at least 6" in err and "--allow-short-pin" in err and "Traceback" not in err
    assert not KioskConfig.load(path).has_pin
    assert set_pin("2468", "--allow-short-pin") == 0
    assert check_pin("2468", KioskConfig.load(path).pin_hash)
    assert set_pin("246", "--allow-short-pin") == 2 and "at least 4" in capsys.readouterr().err
    assert set_pin("24680a") == 2 and set_pin("1" * 13) == 2
    assert set_pin("246801") == 0 and check_pin("246801", KioskConfig.load(path).pin_hash)
    assert main(["kiosk", "--config", str(path), "--allow-short-pin"]) == 2
    assert "--allow-short-pin and --pin-file go with --set-pin" in capsys.readouterr().err
