"""Private session folders an older Sheer named without their process (``sheer-private-cache-XXXXXXXX``,
``tempfile.mkdtemp``'s name) are swept once nothing in them was written for a day; a fresher one is kept
(its kiosk may still run), and so is one of another user."""

from __future__ import annotations

import os
import time
from typing import TYPE_CHECKING

import pytest

from core.cache import PRIVATE_PREFIX, UNOWNED_PRIVATE_MAX_AGE_S, sweep_private_caches

if TYPE_CHECKING:
    from pathlib import Path


def _older_folder(base: Path, suffix: str, age_s: float, newest_file_age_s: float | None = None) -> Path:
    """A private folder in the older naming holding ``face/photo.png``, every time set ``age_s`` seconds ago
    (the photo's ``newest_file_age_s`` when given)."""
    folder = base / f"{PRIVATE_PREFIX}{suffix}"
    (folder / "face").mkdir(parents=True)
    photo = folder / "face" / "photo.png"
    photo.write_bytes(b"her photo")
    then = time.time() - age_s
    for path in (photo, folder / "face", folder):
        os.utime(path, (then, then))
    if newest_file_age_s is not None:
        recent = time.time() - newest_file_age_s
        os.utime(photo, (recent, recent))
    return folder


def test_an_older_sheers_folder_is_swept_after_a_day(tmp_path: Path) -> None:
    day = UNOWNED_PRIVATE_MAX_AGE_S
    stale = _older_folder(tmp_path, "k2b_x9q1", day + 60)
    fresh = _older_folder(tmp_path, "a0c3mzt7", day - 600)
    in_use = _older_folder(tmp_path, "z8y7w6v5", 3 * day, newest_file_age_s=60)  # written a minute ago
    assert sweep_private_caches(tmp_path) == [stale]
    assert not stale.exists()
    assert (fresh / "face" / "photo.png").is_file() and (in_use / "face" / "photo.png").is_file()


def test_another_users_older_folder_is_kept(tmp_path: Path) -> None:
    if os.getuid() != 0:
        pytest.skip("needs root to give a folder to another user")
    stale = _older_folder(tmp_path, "q1w2e3r4", UNOWNED_PRIVATE_MAX_AGE_S * 2)
    os.chown(stale, 65534, 65534)  # nobody's
    assert sweep_private_caches(tmp_path) == []
    assert (stale / "face" / "photo.png").is_file()
