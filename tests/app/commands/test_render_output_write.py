"""``sheer render``'s PNG goes through the one atomic writer (:mod:`core.atomicio`): the same bytes as
Pillow's PNG, no file of the user's overwritten on the way, one line naming the output when it fails."""

from __future__ import annotations

import io
from typing import TYPE_CHECKING

import numpy as np
import pytest
from PIL import Image

from app.commands.render import _write_png
from core.errors import SheerError
from tests import disk_support
from tests.disk_support import fill, listing

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

tiny_tmpfs = disk_support.tiny_tmpfs  # the fixture: a tmpfs mounted for the test


def _image() -> np.ndarray:
    """A small uint8 (H, W, 3) image with every channel varying."""
    rng = np.random.default_rng(7)
    return rng.integers(0, 256, size=(24, 32, 3), dtype=np.uint8)


def test_the_png_is_pillows_png_byte_for_byte(tmp_path: Path) -> None:
    image = _image()
    out = tmp_path / "portrait.png"
    _write_png(out, image)
    expected = io.BytesIO()
    Image.fromarray(image).save(expected, format="PNG")
    assert out.read_bytes() == expected.getvalue()
    assert [p.name for p in tmp_path.iterdir()] == ["portrait.png"]


def test_a_file_beside_the_output_is_never_overwritten(tmp_path: Path) -> None:
    """The old writer wrote ``<out>.tmp.png`` and renamed it: a user's file of that name was lost."""
    mine = tmp_path / "portrait.png.tmp.png"
    mine.write_bytes(b"the user's own file")
    _write_png(tmp_path / "portrait.png", _image())
    assert mine.read_bytes() == b"the user's own file"


def test_a_full_disk_is_one_line_naming_the_output_and_leaves_the_old_file(
        tiny_tmpfs: Callable[..., Path]) -> None:
    folder = tiny_tmpfs("disk")
    out = folder / "portrait.png"
    out.write_bytes(b"the previous render")
    fill(folder)
    with pytest.raises(SheerError) as caught:
        _write_png(out, _image())
    message = str(caught.value)
    assert "\n" not in message and message.startswith(f"{out}: cannot write the image: ")
    assert ".tmp" not in message
    assert listing(folder) == {"portrait.png": b"the previous render"}
