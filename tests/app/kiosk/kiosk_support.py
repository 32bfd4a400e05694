"""Shared set-up of the kiosk tests: the administrator PIN's stored hash, made once per test process.

``app.kiosk.config.hash_pin`` runs the production PBKDF2 (200,000 rounds, a random salt): a kiosk window or
configuration file in a test needs a valid stored hash, not a fresh one each time, so each PIN is hashed
once and its hash reused. The hashing itself (its salt, its rounds, the PIN not in the stored text) is
tested on fresh hashes in tests/app/kiosk/test_kiosk_pin.py and tests/app/kiosk/test_kiosk_config.py.
"""

from __future__ import annotations

from functools import cache


@cache
def pin_hash(pin: str) -> str:
    """``hash_pin(pin)``, computed once per process (the same salt for every use of this PIN)."""
    from app.kiosk.config import hash_pin

    return hash_pin(pin)
