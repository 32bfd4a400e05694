"""Her photograph on the kiosk at its own resolution: the mirror view and Save Photo.

Grace Hopper's portrait (the sample assets) at twice its size, 1024×1200, comes from the watched folder: her
face is then taller than ``capture.auto.MAX_FACE_PX``, so the capture fits it on a reduced copy (face.json
``downscale``), and the kiosk still draws her mirror view, and saves her photo, at 1024×1200. On screen the
mirror view shows her as a mirror does (flipped left–right); Save Photo as a camera does (not flipped), with
no before/after line, whichever view is on screen, and with the before/after slider on, the pair side by
side in a second file.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from app.qt_compat import pin_singletons
from tests.app.kiosk.test_kiosk_tryon import next_frame, portrait, tryon_kiosk

if TYPE_CHECKING:
    from collections.abc import Iterator
    from pathlib import Path

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl, pytest.mark.slow]
#: Her photograph's size: Grace Hopper's 512×600 portrait, doubled.
SIZE = (1024, 1200)


def _read(path: Path) -> np.ndarray:
    from PIL import Image

    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"))


def _outside_face(face: Any, shape: tuple[int, ...]) -> np.ndarray:
    """Bool (H, W): pixels of her photograph (its own size) more than 3 px outside her projected head."""
    from scipy.ndimage import binary_dilation
    from scipy.spatial import Delaunay

    from render.mirror import photo_camera_at

    h, w = shape[:2]
    px, _ = photo_camera_at(face, w, h).project(face.load_head().vertices)
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    inside = Delaunay(px).find_simplex(np.c_[xx.ravel(), yy.ravel()]) >= 0
    return ~binary_dilation(inside.reshape(h, w), iterations=3)


def _white_columns(img: np.ndarray) -> int:
    """Columns of ``img`` whose every pixel is near white (a before/after line)."""
    return int(np.all(img.min(axis=2) >= 240, axis=0).sum())


@pytest.fixture(scope="module")
def her(qapp: object, tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    """A kiosk with her try-on on screen (the mirror view, the look on her face), from the watched folder."""
    from PIL import Image
    from pytestqt.qtbot import QtBot

    qtbot = QtBot(qapp)
    folder = tmp_path_factory.mktemp("her-photo")
    drop = folder / "drop"
    photo = np.asarray(Image.fromarray(portrait()).resize(SIZE, Image.Resampling.BICUBIC))
    with tryon_kiosk(qapp, folder, camera="off", watch_dir=str(drop)) as kiosk:
        kiosk.tryon_button.click()
        Image.fromarray(photo).save(drop / "shopper.png")
        qtbot.waitUntil(lambda: kiosk.tryon.shopper_view.image is not None, timeout=120000)
        yield {"kiosk": kiosk, "qtbot": qtbot, "photo": photo, "folder": folder}


def test_her_mirror_is_drawn_at_her_photographs_resolution(her: dict[str, Any]) -> None:
    kiosk, photo = her["kiosk"], her["photo"]
    shopper = kiosk.tryon.shopper
    small = shopper.face.camera()
    assert shopper.face.data["downscale"]["from"] == list(SIZE) and (small.width, small.height) != SIZE
    assert np.array_equal(shopper.photo, photo)  # her photograph itself, not the capture's reduced copy
    shown = next_frame(her, lambda: kiosk.set_view("mirror"))
    assert shown.shape == photo.shape


def test_save_photo_is_her_made_up_photograph_and_the_screen_is_its_mirror_image(her: dict[str, Any]) -> None:
    kiosk, photo = her["kiosk"], her["photo"]
    shown = next_frame(her, lambda: kiosk.set_look("red-lip"))
    saved = _read(kiosk.snapshot())
    assert saved.shape == photo.shape  # her photograph's full resolution, not the screen's
    assert "as a camera sees you" in kiosk.toast.text()
    assert np.array_equal(shown, saved[:, ::-1])  # the mirror view on screen: the saved photo flipped
    outside = _outside_face(kiosk.tryon.shopper.face, photo.shape)
    assert outside.mean() > 0.5 and np.array_equal(saved[outside], photo[outside])
    assert np.abs(saved.astype(int) - photo.astype(int)).max() > 40  # the look is on her face
    # with the before/after slider on: the screen splits, the saved photo does not; the pair is a second file
    split = next_frame(her, lambda: kiosk.split.setValue(50))
    assert _white_columns(split) >= 1
    main = kiosk.snapshot()
    pair = main.with_name(f"{main.stem}-before-after.png")
    assert np.array_equal(_read(main), saved) and _white_columns(saved) == 0
    both = _read(pair)
    assert both.shape == (photo.shape[0], 2 * photo.shape[1], 3)
    assert np.array_equal(both[:, : photo.shape[1]], photo) and np.array_equal(both[:, photo.shape[1]:], saved)
    kiosk.split.setValue(0)
    # in Turn and relight, Save Photo is still her made-up photograph
    next_frame(her, lambda: kiosk.set_view("relight"))
    assert np.array_equal(_read(kiosk.snapshot()), saved)
    assert {p.name for p in (her["folder"] / "photos").iterdir()} == {p.name for p in kiosk.snapshots}
