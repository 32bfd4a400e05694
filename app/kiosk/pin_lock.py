"""The kiosk PIN's lockout: wrong PINs slow a guesser down, across restarts (no Qt: testable headless).

After :data:`FREE_ATTEMPTS` wrong PINs in a row the PIN pad locks for :data:`FIRST_LOCK_S` seconds; every
further wrong PIN (once the lock has ended) doubles the lock, up to :data:`MAX_LOCK_S`. While locked no
PIN is checked at all, the right one included. The right PIN resets the count.

With a 4-digit PIN (10,000 values) that is about 96 guesses a day once the lock has reached 15 minutes,
so about 52 days to try half of them; a 6-digit PIN takes about 14 years (hence ``--set-pin``'s
6-digit minimum).

The count and the lock are kept in a small JSON file beside the kiosk's configuration
(``kiosk.json`` → ``kiosk-pin-lock.json``), written atomically after every attempt, readable by its owner
only (mode 0600, as the configuration), so restarting the kiosk (or the machine) resets nothing. Times are the wall clock (a lock must outlive the process); a
clock set back before the lock began restarts the lock from the new time. A lock file that cannot be
read locks the pad (fail closed) rather than forgetting the count. Each wrong attempt is logged with a
UTC timestamp and the count — never any digit of the PIN typed.
"""

from __future__ import annotations

import json
import logging
import math
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import TYPE_CHECKING

from app.kiosk.config import check_pin, write_private

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

    from app.kiosk.config import KioskConfig

log = logging.getLogger("sheer.kiosk")

#: Wrong PINs in a row allowed before the first lock.
FREE_ATTEMPTS = 5
#: The first lock, in seconds.
FIRST_LOCK_S = 30.0
#: The longest lock, in seconds (15 minutes).
MAX_LOCK_S = 900.0


def lock_seconds(failures: int) -> float:
    """The lock (s) after ``failures`` wrong PINs in a row: 0 below 5, then 30 s doubling up to 900 s."""
    if failures < FREE_ATTEMPTS:
        return 0.0
    return min(FIRST_LOCK_S * 2.0 ** min(failures - FREE_ATTEMPTS, 32), MAX_LOCK_S)


def lock_path_for(config_path: Path) -> Path:
    """The lock file beside the configuration file ``config_path`` (``kiosk.json`` → ``kiosk-pin-lock.json``)."""
    return config_path.with_name(f"{config_path.stem}-pin-lock.json")


@dataclass(frozen=True)
class Verdict:
    """What one PIN attempt gave.

    Attributes:
        accepted: the right PIN, checked (never while locked).
        locked_s: seconds the pad stays locked from now (0: not locked).
        failures: wrong PINs in a row so far.
    """

    accepted: bool
    locked_s: float
    failures: int


def _utc(t: float) -> str:
    return datetime.fromtimestamp(t, tz=UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


class PinGuard:
    """Checks administrator PINs with the lockout; the state lives in ``state_path`` (None: in memory only).

    Args:
        pin_hash: the stored PIN hash, or a callable giving it (read at each attempt).
        state_path: the lock file (see :func:`lock_path_for`); None keeps the state in this object only
            (a configuration that was not read from a file, as in tests).
        clock: seconds since the epoch (injectable so tests need not wait 30 s).
    """

    def __init__(self, pin_hash: str | Callable[[], str], state_path: Path | None = None,
                 clock: Callable[[], float] = time.time) -> None:
        self._hash = pin_hash
        self.state_path = state_path
        self.clock = clock
        self.failures = 0
        self.locked_at = 0.0
        self.lock_s = 0.0
        self._load()

    @classmethod
    def for_config(cls, config: KioskConfig, clock: Callable[[], float] = time.time) -> PinGuard:
        """The guard of ``config``: its PIN hash, its lock file beside the file it was read from."""
        state = lock_path_for(config.source) if config.source is not None else None
        return cls(lambda: config.pin_hash, state, clock)

    # ------------------------------------------------------------------ state
    def _load(self) -> None:
        if self.state_path is None:
            return
        try:
            raw = self.state_path.read_text(encoding="utf-8")
        except FileNotFoundError:
            return
        except OSError as exc:
            self._fail_closed(f"unreadable ({exc.strerror or exc})")
            return
        try:
            data = json.loads(raw)
            failures, locked_at, lock_s = int(data["failures"]), float(data["locked_at"]), float(data["lock_s"])
            if failures < 0 or not (math.isfinite(locked_at) and math.isfinite(lock_s)) or lock_s < 0:
                raise ValueError("out of range")
        except (ValueError, TypeError, KeyError, RecursionError) as exc:
            self._fail_closed(f"malformed ({exc})")
            return
        self.failures, self.locked_at, self.lock_s = failures, locked_at, min(lock_s, MAX_LOCK_S)

    def _fail_closed(self, why: str) -> None:
        log.warning("kiosk: PIN lock file %s %s; locking the PIN pad for %d s", self.state_path, why,
                    int(FIRST_LOCK_S))
        self.failures = max(self.failures, FREE_ATTEMPTS)
        self.locked_at, self.lock_s = self.clock(), FIRST_LOCK_S
        self._save()

    def _save(self) -> None:
        if self.state_path is None:
            return
        data = {"failures": self.failures, "locked_at": self.locked_at, "lock_s": self.lock_s,
                "locked_until_utc": _utc(self.locked_at + self.lock_s) if self.lock_s else None}
        try:
            write_private(self.state_path, json.dumps(data, indent=2))
        except OSError as exc:  # the lock still holds in this process
            log.error("kiosk: cannot write the PIN lock file %s (%s)", self.state_path, exc.strerror or exc)

    # ------------------------------------------------------------------ use
    def remaining(self) -> float:
        """Seconds the pad stays locked (0 when not locked)."""
        if self.lock_s <= 0:
            return 0.0
        now = self.clock()
        if now < self.locked_at:  # the clock was set back: the lock starts again from now
            self.locked_at = now
            self._save()
        return max(0.0, self.locked_at + self.lock_s - now)

    def attempt(self, pin: str) -> Verdict:
        """Check ``pin`` unless locked; count a wrong one (logged without digits) and lock after the fifth."""
        self._load()  # another kiosk process on the same configuration counts too
        left = self.remaining()
        if left > 0:
            log.warning("kiosk: PIN refused at %s: the pad is locked for %d s more", _utc(self.clock()),
                        math.ceil(left))
            return Verdict(False, left, self.failures)
        pin_hash = self._hash() if callable(self._hash) else self._hash
        if check_pin(pin, pin_hash):
            if self.failures:
                self.failures, self.locked_at, self.lock_s = 0, 0.0, 0.0
                self._save()
            return Verdict(True, 0.0, 0)
        self.failures += 1
        now = self.clock()
        self.locked_at, self.lock_s = now, lock_seconds(self.failures)
        self._save()
        locked = f"; the PIN pad is locked for {int(self.lock_s)} s" if self.lock_s else ""
        log.warning("kiosk: wrong PIN at %s (%d wrong in a row)%s", _utc(now), self.failures, locked)
        return Verdict(False, self.lock_s, self.failures)
