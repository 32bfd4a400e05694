"""Save Photo that cannot write (a full disk, a folder it cannot write in): the shopper stays on her try-on
screen, her session open, with a friendly line; the one-line reason goes to the log; she can try again or
press Done."""

from __future__ import annotations

import dataclasses
import logging
from typing import TYPE_CHECKING, Any

import pytest

from app.qt_compat import pin_singletons
from tests import disk_support
from tests.app.kiosk import test_kiosk_pin
from tests.disk_support import fill, listing

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]

tiny_tmpfs = disk_support.tiny_tmpfs  # the fixture: a tmpfs mounted for the test
shared_kiosk = test_kiosk_pin.shared_kiosk  # the fixture: one kiosk for the module, drawn once


@pytest.fixture
def kiosk(shared_kiosk: tuple[Any, Any]) -> Any:
    """The module's kiosk on its try-on screen (a shopper's session open), nothing said yet."""
    win, _config = shared_kiosk
    win.show_main()
    win.toast.setText("")
    win.last_error = None
    return win


def _save_fails_and_she_stays(kiosk: Any, folder: Path, caplog: pytest.LogCaptureFixture) -> None:
    from app.kiosk.window import PHOTO_NOT_SAVED

    kiosk.config = dataclasses.replace(kiosk.config, snapshot_dir=str(folder))
    saved = len(kiosk.snapshots)
    with caplog.at_level(logging.ERROR, logger="sheer.kiosk"):
        kiosk.snapshot_button.click()
    assert kiosk.screen_name == "tryon" and kiosk.private_cache.is_open  # her session goes on
    assert kiosk.toast.text() == PHOTO_NOT_SAVED
    assert len(kiosk.snapshots) == saved
    lines = [r.getMessage() for r in caplog.records if r.name == "sheer.kiosk"]
    assert len(lines) == 1 and "\n" not in lines[0] and str(folder) in lines[0], lines
    assert "Traceback" not in lines[0] and not any(r.exc_info for r in caplog.records)


def _try_again_then_done(kiosk: Any, folder: Path) -> None:
    kiosk.snapshot_button.click()
    assert kiosk.toast.text().startswith("Photo saved") and kiosk.snapshots[-1].parent == folder
    assert kiosk.snapshots[-1].read_bytes().startswith(b"\x89PNG")
    kiosk.done_button.click()
    assert kiosk.screen_name == "start"


def test_a_folder_it_cannot_write_in(kiosk: Any, tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    folder = tmp_path / "photos"
    folder.write_bytes(b"a file where the folder should be")
    _save_fails_and_she_stays(kiosk, folder, caplog)
    folder.unlink()
    _try_again_then_done(kiosk, folder)


def test_a_full_disk(kiosk: Any, tiny_tmpfs: Callable[..., Path], caplog: pytest.LogCaptureFixture) -> None:
    folder = tiny_tmpfs("photos", "size=2m")
    filler = fill(folder)
    _save_fails_and_she_stays(kiosk, folder, caplog)
    assert listing(folder) == {}  # no half-written photo
    filler.unlink()
    _try_again_then_done(kiosk, folder)
