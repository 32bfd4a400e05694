"""The kiosk's "Try it on me" on a real window, end to end, with no camera on this machine.

The camera is a real ``cv2.VideoCapture`` on a video file of a portrait written here (the kiosk
configuration's ``camera`` names the file, as it would name ``/dev/video0``): the preview, the quality
gate on the live frames, the countdown, the shutter, the capture (MediaPipe, the person's head, the Paris
fit), then her face with the looks, product swaps, light presets and before/after in both views, Save
Photo, and Done. Privacy: nothing of hers is left anywhere after the session, except the saved photo.
Also: a watched folder instead of a camera, a camera that disappears mid-preview, and a photo the quality
gate refuses (back to the camera screen with its message).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from app.qt_compat import pin_singletons

if TYPE_CHECKING:
    import contextlib
    from collections.abc import Iterator

    from app.kiosk.window import KioskWindow

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]
#: the tests that run a capture (~10 s each on this machine: MediaPipe, the person's head, the Paris fit)
capturing = pytest.mark.slow

def portrait_path() -> Path:
    """Grace Hopper's portrait, from the sample assets' search path (core.assets)."""
    from core.assets import find_asset

    return find_asset("photos/grace_hopper.jpg")


def portrait() -> np.ndarray:
    from PIL import Image

    with Image.open(portrait_path()) as im:
        return np.asarray(im.convert("RGB"), dtype=np.uint8)


def write_camera(path: Path, rgb: np.ndarray, frames: int) -> Path:
    """A video 'camera' of ``frames`` frames of ``rgb`` (MJPG), for ``cv2.VideoCapture``."""
    import cv2

    h, w = rgb.shape[:2]
    out = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (w, h))
    bgr = np.ascontiguousarray(rgb[:, :, ::-1])
    for _ in range(frames):
        out.write(bgr)
    out.release()
    return path


def private_folders() -> set[str]:
    return {p.name for p in Path(tempfile.gettempdir()).glob("sheer-private-cache-*")}


def tree(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")} if folder.exists() else set()


def tryon_kiosk(qapp: object, folder: Path, **config: Any) -> contextlib.AbstractContextManager[KioskWindow]:
    """A 1280×800 kiosk (PIN 2468, snapshots under ``folder``/photos) with ``config`` fields set."""
    from tests.app.kiosk.test_kiosk_pin import open_kiosk

    return open_kiosk(qapp, folder, (1280, 800), **config)


@pytest.fixture(scope="module")
def shopper(qapp: object, tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    """One shopper's try-on, recorded as it happened (a capture costs seconds): the kiosk, and what was
    seen at each step."""
    from pytestqt.qtbot import QtBot

    from app.kiosk import camera_page as kiosk_camera_page

    qtbot = QtBot(qapp)
    folder = tmp_path_factory.mktemp("tryon")
    shared_cache = folder / "shared-cache"
    old_env = os.environ.get("SHEER_CACHE_DIR")
    os.environ["SHEER_CACHE_DIR"] = str(shared_cache)
    camera = write_camera(folder / "camera.avi", portrait(), frames=400)
    seen: dict[str, Any] = {"private_before": private_folders()}
    with tryon_kiosk(qapp, folder, camera=str(camera)) as kiosk:
        qtbot.waitUntil(lambda: kiosk.viewport.frames > 0, timeout=60000)
        seen["shared_before"] = tree(shared_cache)
        assert kiosk.tryon_button.isVisible()
        kiosk.tryon_button.click()
        page = kiosk.tryon.camera_page
        seen["camera_screen"] = kiosk.screen_name
        seen["privacy_on_camera_screen"] = page.privacy.text()
        seen["private_root"] = kiosk.private_cache.root
        qtbot.waitUntil(lambda: page.preview.pixmap() is not None and not page.preview.pixmap().isNull(),
                        timeout=10000)
        qtbot.waitUntil(lambda: page.countdown is not None, timeout=30000)
        seen["prompt_when_ok"] = page.prompt.text()
        seen["countdown_shown"] = page.count_label.text()
        qtbot.waitUntil(lambda: kiosk.screen_name == "busy", timeout=10000)
        qtbot.waitUntil(lambda: kiosk.tryon.shopper_view.image is not None, timeout=120000)
        seen["timings"] = dict(kiosk.tryon.timings)
        seen["screen_with_her_face"] = kiosk.screen_name
        seen["her_face_shown"] = kiosk.face_stack.currentWidget() is kiosk.tryon.shopper_view
        seen["privacy_on_tryon"] = kiosk.privacy_label.isVisible()
        seen["face_folder_private"] = Path(kiosk.tryon.shopper.folder).is_relative_to(kiosk.private_cache.root)
        seen["mirror_natural"] = kiosk.tryon.shopper_view.image.copy()
        seen["photo"] = kiosk.tryon.shopper.photo.copy()
        yield {"kiosk": kiosk, "seen": seen, "folder": folder, "qtbot": qtbot, "shared_cache": shared_cache,
               "camera": camera, "page_module": kiosk_camera_page}
    if old_env is None:
        os.environ.pop("SHEER_CACHE_DIR", None)
    else:
        os.environ["SHEER_CACHE_DIR"] = old_env


def next_frame(shopper: dict[str, Any], act: Any) -> np.ndarray:
    """Do ``act`` and wait for the frame it asks for."""
    kiosk, qtbot = shopper["kiosk"], shopper["qtbot"]
    before = kiosk.tryon.renderer.frames
    act()
    qtbot.waitUntil(lambda: kiosk.tryon.renderer.frames > before, timeout=30000)
    qtbot.wait(50)
    return kiosk.tryon.shopper_view.image.copy()


def mean_diff(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a.astype(np.float64) - b.astype(np.float64)).mean())


@capturing
def test_the_camera_screen_guides_counts_down_and_says_what_happens_to_the_photo(shopper: dict[str, Any]) -> None:
    seen = shopper["seen"]
    assert seen["camera_screen"] == "camera"
    assert "deleted" in seen["privacy_on_camera_screen"] and "Save Photo" in seen["privacy_on_camera_screen"]
    assert seen["prompt_when_ok"] == shopper["page_module"].HOLD_STILL
    assert seen["countdown_shown"] in {"3", "2", "1"}


@capturing
def test_her_own_face_with_the_look_in_the_mirror_view(shopper: dict[str, Any]) -> None:
    seen = shopper["seen"]
    assert seen["screen_with_her_face"] == "tryon" and seen["her_face_shown"] and seen["privacy_on_tryon"]
    assert seen["face_folder_private"]
    img, photo = seen["mirror_natural"], seen["photo"]
    assert img.shape == photo.shape  # the mirror view: her photograph's size and pose
    # the look changes her face somewhere, and the background of her photograph stays as it was
    assert np.abs(img.astype(int) - photo.astype(int)).max() > 20
    h, w = photo.shape[:2]
    corner = (slice(0, h // 10), slice(0, w // 10))
    assert mean_diff(img[corner], photo[:, ::-1][corner]) < 1.0  # shown as a mirror shows her: flipped
    t = seen["timings"]
    assert t["tryon_first_frame_s"] > 0 and t["capture_s"] > 0  # the figure itself is measured in bench.kiosk_tryon


@capturing
def test_looks_products_lights_and_before_after_on_her_face(shopper: dict[str, Any]) -> None:
    kiosk = shopper["kiosk"]
    photo = shopper["seen"]["photo"]
    natural = next_frame(shopper, lambda: kiosk.set_view("mirror"))
    red = next_frame(shopper, lambda: kiosk.look_buttons["red-lip"].click())
    assert kiosk.look == "red-lip" and mean_diff(red, natural) > 0.05
    label = kiosk.product_labels["lipstick"].text()
    swapped = next_frame(shopper, lambda: kiosk.swap_product("lipstick", +1))
    assert kiosk.product_labels["lipstick"].text() != label and mean_diff(swapped, red) > 0.01
    # before/after: the left half is her photograph untouched (flipped, as the mirror view shows her)
    split = next_frame(shopper, lambda: kiosk.split.setValue(50))
    w = photo.shape[1]
    assert mean_diff(split[:, : w // 2 - 2], photo[:, ::-1][:, : w // 2 - 2]) < 0.5
    assert mean_diff(split[:, w // 2 + 2:], swapped[:, w // 2 + 2:]) < 0.5
    kiosk.split.setValue(0)
    # a light preset turns to the relit view; the presets differ; dragging turns her face
    warm = next_frame(shopper, lambda: kiosk.light_buttons["warm indoor"].click())
    assert kiosk.tryon.view == "relight" and kiosk.view_buttons["relight"].isChecked()
    other = next(n for n in kiosk.light_buttons if n != "warm indoor")
    lit = next_frame(shopper, lambda: kiosk.light_buttons[other].click())
    assert mean_diff(warm, lit) > 0.5
    view = kiosk.tryon.shopper_view
    turned = next_frame(shopper, lambda: (setattr(view, "yaw", 20.0), kiosk.tryon.refresh(layers=False)))
    assert mean_diff(turned, lit) > 0.5
    mirror = next_frame(shopper, lambda: kiosk.view_buttons["mirror"].click())
    assert kiosk.tryon.view == "mirror" and mirror.shape == photo.shape


@capturing
def test_her_foundation_from_her_photograph_on_her_face(shopper: dict[str, Any]) -> None:
    """#17 in the kiosk: "Find my foundation" after "Try it on me" reads her skin from her photograph
    (her cheeks, shade.photo), shows the three best shades on her face, and a tap puts one on."""
    from km.skin import fit_skin
    from shade.match import ShadeBank, foundations, match_shades
    from shade.photo import skin_from_photo

    kiosk, qtbot = shopper["kiosk"], shopper["qtbot"]
    kiosk.set_look("natural")
    finder = kiosk.foundation_finder
    assert finder.doc is kiosk.doc and kiosk.doc is not kiosk.stock_doc
    face = kiosk.tryon.shopper.face
    finder.find_button.click()
    qtbot.waitUntil(lambda: len(finder.shades) == 3, timeout=60000)
    assert all(b.isVisible() for b in finder.shade_buttons)
    # her skin is her photograph's cheeks (the band between her cheek landmarks), as shade.photo reads it
    std = face.data["landmarks"]["standard"]
    (lx, ly), (rx, ry) = std["left_cheek"], std["right_cheek"]
    read = kiosk.tryon.shopper.skin
    assert read and "sRGB camera" in read[1] and finder.note == read[1]
    cheeks = np.array([skin_from_photo(face.photo_path, region=(int(x) - 6, int(y) - 6, 12, 12)).linear_rgb
                       for x, y in ((lx, ly), (rx, ry))])  # her lit and her shaded cheek
    assert np.all(read[0] >= cheeks.min(axis=0) - 0.05) and np.all(read[0] <= cheeks.max(axis=0) + 0.05), (
        read[0], cheeks)
    assert not np.allclose(read[0], np.asarray(face.params.diffuse), atol=1e-3)  # not the fitted diffuse
    fit = fit_skin(linear_rgb=read[0])
    expected = match_shades(fit.reflectance, fit.reflectance, ShadeBank.from_materials(foundations(kiosk.library)))
    assert [s.name for s in finder.shades] == [s.name for s in expected[:3]]
    # each shade on her face: a picture of her face on its button
    qtbot.waitUntil(lambda: kiosk.tryon.previews_shown == 3, timeout=30000)
    assert all(not b.icon().isNull() for b in finder.shade_buttons)
    worn = kiosk.product_labels["foundation"].text()
    pick = next(i for i, s in enumerate(finder.shades) if s.name != worn)
    choice = finder.shades[pick].name
    before = kiosk.tryon.shopper_view.image.copy()
    after = next_frame(shopper, lambda: finder.shade_buttons[pick].click())
    assert kiosk.product_labels["foundation"].text() == choice
    assert mean_diff(before, after) > 0.01


@capturing
def test_save_photo_writes_only_her_rendered_image_and_done_leaves_nothing(shopper: dict[str, Any]) -> None:
    kiosk, seen, folder = shopper["kiosk"], shopper["seen"], shopper["folder"]
    shown = kiosk.tryon.shopper_view.image.copy()
    path = kiosk.snapshot()
    from PIL import Image

    with Image.open(path) as im:
        assert np.array_equal(np.asarray(im.convert("RGB")), shown[:, ::-1])  # as a camera shows her
    root = seen["private_root"]
    assert root is not None and Path(root).is_dir()
    kiosk.done_button.click()
    assert kiosk.screen_name == "start" and kiosk.attract
    assert kiosk.tryon.shopper is None and kiosk.tryon.renderer is None and kiosk.tryon.shopper_view.image is None
    assert kiosk.doc is kiosk.stock_doc and kiosk.face_stack.currentWidget() is kiosk.viewport
    assert not Path(root).exists() and private_folders() <= seen["private_before"]
    # the shared cache has nothing of hers; the only file written is the saved photo
    assert tree(shopper["shared_cache"]) == seen["shared_before"]
    assert tree(folder / "photos") == {Path(path).name}
    assert tree(folder) - tree(shopper["shared_cache"]) - {"shared-cache"} == {
        "camera.avi", "photos", f"photos/{Path(path).name}"} | {f"shared-cache/{p}" for p in seen["shared_before"]}


def test_a_camera_that_disappears_mid_preview(qapp: object, qtbot: Any, tmp_path: Path) -> None:
    from app.kiosk.tryon import CAMERA_TROUBLE

    camera = write_camera(tmp_path / "short.avi", portrait(), frames=4)
    before = private_folders()
    with tryon_kiosk(qapp, tmp_path, camera=str(camera)) as kiosk:
        kiosk.tryon_button.click()
        assert kiosk.screen_name == "camera"
        qtbot.waitUntil(lambda: kiosk.screen_name == "start", timeout=10000)
        assert kiosk.start_message.text() == CAMERA_TROUBLE and "stopped giving pictures" in kiosk.last_error
        assert not kiosk.private_cache.is_open and private_folders() <= before


@capturing
def test_a_kiosk_without_a_camera_takes_the_photo_from_its_watched_folder(qapp: object, qtbot: Any,
                                                                         tmp_path: Path) -> None:
    """And a refused photo (a blank wall: no face) brings the camera screen back with the gate's words; the
    kiosk's calibrated light (``sheer kiosk --calibrate-light``) is the capture's light."""
    from PIL import Image

    from app.cli import main
    from app.kiosk.config import KioskConfig
    from tests.app.kiosk.test_kiosk_light import _write_probe

    light = np.array([0.2, -0.3, -1.0])
    light /= np.linalg.norm(light)
    _write_probe(tmp_path / "ball.png", light, np.array([1.0, 0.92, 0.8]))
    assert main(["kiosk", "--config", str(tmp_path / "kiosk.json"), "--calibrate-light", str(tmp_path / "ball.png")]) == 0
    stored = KioskConfig.load(tmp_path / "kiosk.json").light
    drop = tmp_path / "drop"
    with tryon_kiosk(qapp, tmp_path, camera="off", watch_dir=str(drop), light=stored) as kiosk:
        assert kiosk.tryon_button.isVisible()
        kiosk.tryon_button.click()
        assert kiosk.screen_name == "camera" and "appears here" in kiosk.tryon.camera_page.prompt.text()
        Image.new("RGB", (640, 480), (120, 110, 100)).save(drop / "wall.jpg")
        qtbot.waitUntil(lambda: kiosk.tryon.last_refusal != "", timeout=60000)
        assert kiosk.screen_name == "camera" and kiosk.tryon.camera_page.prompt.text() == kiosk.tryon.last_refusal
        assert not (drop / "wall.jpg").exists()
        Image.fromarray(portrait()).save(drop / "shopper.jpg")
        qtbot.waitUntil(lambda: kiosk.tryon.shopper_view.image is not None, timeout=120000)
        assert not (drop / "shopper.jpg").exists() and kiosk.screen_name == "tryon"
        used = kiosk.tryon.shopper.face.data["probe"]
        assert used is not None and np.allclose(used["light_dir_camera"], stored["light_dir_camera"])
        root = kiosk.private_cache.root
        kiosk.start_attract()  # she walks away: the idle timeout
        assert not Path(root).exists() and kiosk.tryon.shopper is None


def test_a_truncated_photo_in_the_watched_folder(qapp: object, qtbot: Any, tmp_path: Path) -> None:
    """A clear message, the start screen, nothing kept (the file is the shopper's: deleted too)."""
    from app.kiosk.tryon import PHOTO_TROUBLE

    drop = tmp_path / "drop"
    before = private_folders()
    with tryon_kiosk(qapp, tmp_path, camera="off", watch_dir=str(drop)) as kiosk:
        kiosk.tryon_button.click()
        data = portrait_path().read_bytes()
        (drop / "cut.jpg").write_bytes(data[: len(data) // 3])
        qtbot.waitUntil(lambda: kiosk.screen_name == "start", timeout=10000)
        assert kiosk.start_message.text() == PHOTO_TROUBLE and "cut.jpg: not a readable photo" in kiosk.last_error
        assert not (drop / "cut.jpg").exists() and not kiosk.private_cache.is_open
        assert private_folders() <= before


def test_a_kiosk_with_no_camera_and_no_folder_offers_no_try_on(qapp: object, tmp_path: Path) -> None:
    with tryon_kiosk(qapp, tmp_path, camera="off") as kiosk:
        assert not kiosk.tryon_button.isVisible() and kiosk.start_button.isVisible()
    with tryon_kiosk(qapp, tmp_path, camera=str(tmp_path / "unplugged")) as kiosk:
        assert not kiosk.tryon_button.isVisible() and kiosk.start_button.isVisible()
