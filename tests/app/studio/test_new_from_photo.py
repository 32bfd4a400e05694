"""File → New from Photo… in the real studio window (xcb under Xvfb, Mesa GL): a refused photograph says
why in the quality gate's words and changes nothing; a portrait is captured (real MediaPipe, the real
capture pipeline) in a worker with progress, and a new window opens on her own full head with the studio's
layers transferred onto it (the lipstick on her lips), while the old window closes."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from app.qt_compat import pin_singletons
from tests.app.studio_support import DialogDriver, open_studio_window

if TYPE_CHECKING:
    from collections.abc import Iterator
    from pathlib import Path

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]


@pytest.fixture(scope="module")
def studio(qapp: object, tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Any, DialogDriver]]:
    with open_studio_window(qapp, tmp_path_factory, wait_full_quality=False) as pair:
        yield pair


class ProgressWatcher:
    """Records the label texts of every progress dialog (polled every 20 ms)."""

    def __init__(self) -> None:
        from PySide6.QtCore import QTimer

        self.labels: list[str] = []
        self.timer = QTimer()
        self.timer.setInterval(20)
        self.timer.timeout.connect(self._poll)
        self.timer.start()

    def _poll(self) -> None:
        from PySide6.QtWidgets import QApplication, QProgressDialog

        for w in QApplication.topLevelWidgets():
            # (also while it waits for its minimum duration before showing: a quick first step is recorded too)
            if isinstance(w, QProgressDialog) and (not self.labels or self.labels[-1] != w.labelText()):
                self.labels.append(w.labelText())


def _choose(monkeypatch: pytest.MonkeyPatch, photo: Path, faces: Path) -> list[str]:
    """The file dialog picks ``photo``; captured faces go to ``faces``. Returns the dialogs' titles asked."""
    from app.studio import new_from_photo

    asked: list[str] = []

    def pick(*args: Any, **kwargs: Any) -> tuple[str, str]:
        asked.append(str(args[1]) if len(args) > 1 else "")
        return str(photo), ""

    monkeypatch.setattr(new_from_photo.QFileDialog, "getOpenFileName", pick)
    monkeypatch.setenv("SHEER_FACES_DIR", str(faces))
    return asked


def _studio_windows() -> list[Any]:
    from PySide6.QtWidgets import QApplication

    from app.studio.main_window import StudioWindow

    return [w for w in QApplication.topLevelWidgets() if isinstance(w, StudioWindow) and w.isVisible()]


def test_a_refused_photo_says_why_and_changes_nothing(studio: tuple[Any, DialogDriver], qtbot: Any, tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    from PIL import Image

    win, driver = studio
    driver.shown.clear()
    photo = tmp_path / "wall.png"  # a real photograph file with no face in it
    rng = np.random.default_rng(3)
    Image.fromarray((120 + rng.integers(0, 40, (480, 640, 3))).astype(np.uint8)).save(photo)
    faces = tmp_path / "faces"
    before = [(lay.name, np.array(lay.thickness)) for lay in win.doc.layers]
    asked = _choose(monkeypatch, photo, faces)
    win.actions_by_id["file.new_from_photo"].trigger()
    qtbot.waitUntil(lambda: any(s.kind == "error" for s in driver.shown), timeout=60000)
    error = next(s for s in driver.shown if s.kind == "error")
    assert asked and error.title == "New from Photo"
    assert "This photograph cannot be used" in error.text and "No face found" in error.text
    assert _studio_windows() == [win] and win.isVisible()
    assert [(lay.name, np.array(lay.thickness)) for lay in win.doc.layers][0][0] == before[0][0]
    assert all(np.array_equal(a[1], b[1]) for a, b in zip(before, [(lay.name, lay.thickness) for lay in win.doc.layers],
                                                             strict=True))
    assert not faces.exists() or not any(faces.iterdir())  # nothing written


def test_cancel_stops_the_capture_and_keeps_nothing(studio: tuple[Any, DialogDriver], qtbot: Any, tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    import threading

    from PySide6.QtWidgets import QApplication, QProgressDialog

    from app import workers
    from app.studio import new_from_photo
    from core.assets import find_asset

    win, driver = studio
    driver.shown.clear()
    faces = tmp_path / "faces"
    _choose(monkeypatch, find_asset("photos/grace_hopper.jpg"), faces)
    # every progress message as the worker reports it (polling the dialog misses steps quicker than a poll,
    # e.g. the gate's once MediaPipe is warm); the worker waits at the gate's step until Cancel was clicked,
    # so the capture cannot finish first on a quick machine
    messages: list[str] = []
    clicked = threading.Event()
    real = new_from_photo.capture_and_transfer

    def recording(photo: Any, folder: Any, source: Any, progress: Any, cancelled: Any) -> Any:
        def report(fraction: float, message: str) -> None:
            messages.append(message)
            progress(fraction, message)
            if "quality gate passed" in message:
                clicked.wait(120)

        return real(photo, folder, source, report, cancelled)

    monkeypatch.setattr(new_from_photo, "capture_and_transfer", recording)
    watcher = ProgressWatcher()
    win.actions_by_id["file.new_from_photo"].trigger()
    qtbot.waitUntil(lambda: any("quality gate passed" in m for m in messages), timeout=120000)

    def progress_dialog() -> Any:
        return next((w for w in QApplication.topLevelWidgets() if isinstance(w, QProgressDialog) and w.isVisible()),
                    None)

    qtbot.waitUntil(lambda: progress_dialog() is not None, timeout=60000)
    dialog = progress_dialog()
    from PySide6.QtWidgets import QPushButton

    next(b for b in dialog.findChildren(QPushButton) if b.text().replace("&", "") == "Cancel").click()
    clicked.set()
    qtbot.waitUntil(lambda: not workers._RUNNING, timeout=120000)  # the job stopped at its next step
    watcher.timer.stop()
    assert _studio_windows() == [win] and not driver.shown  # no window, no message: the user cancelled
    assert not faces.exists() or not any(faces.iterdir()), list(faces.iterdir())  # nothing kept


def test_a_portrait_opens_her_own_head_with_the_layers(studio: tuple[Any, DialogDriver], qtbot: Any,
                                                       tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """On a window of its own (New from Photo closes the window it came from, and deletes it); the module's
    driver answers the dialogs (one driver: two would race for the same box)."""
    from PySide6.QtCore import QSettings

    from app.session import Session
    from app.studio.main_window import StudioWindow
    from core.assets import find_asset

    monkeypatch.setenv("SHEER_RECOVERY_DIR", str(tmp_path / "recovery"))
    driver = studio[1]
    driver.shown.clear()
    win = StudioWindow(Session.open(resolution=512, look="natural"),
                       qsettings=QSettings(str(tmp_path / "studio.ini"), QSettings.Format.IniFormat))
    win.resize(800, 600)
    win.show()
    qtbot.waitUntil(lambda: win.viewport.frames > 0, timeout=60000)
    layers = [(lay.name, lay.material) for lay in win.doc.layers]
    assert "Lipstick" in [name for name, _ in layers]  # the natural look
    faces = tmp_path / "faces"
    _choose(monkeypatch, find_asset("photos/grace_hopper.jpg"), faces)
    watcher = ProgressWatcher()
    before = set(_studio_windows())
    win.actions_by_id["file.new_from_photo"].trigger()
    qtbot.waitUntil(lambda: bool(set(_studio_windows()) - before), timeout=240000)
    watcher.timer.stop()
    (new,) = set(_studio_windows()) - before
    try:
        old_viewport = win.viewport
        qtbot.waitUntil(lambda: old_viewport.gl_error_at_release is not None, timeout=10000)
        assert old_viewport.gl_error_at_release == "GL_NO_ERROR"  # the window it came from closed, GL released
        # progress followed the capture's steps, then the transfer
        text = "\n".join(watcher.labels)
        # (polled: a quick step can come and go between two polls)
        steps = ("reading grace_hopper.jpg", "face found", "camera from", "skin mask", "reflectance map", "specular",
                 "detail texture")
        assert "moving the layers onto the captured face" in text
        assert sum(step in text for step in steps) >= 2, watcher.labels
        # the quality report and the transfer's summary, in one message
        info = [s for s in driver.shown if s.kind == "info" and s.title == "New from Photo"]
        assert len(info) == 1 and "Quality gate passed" in info[0].text and "face height" in info[0].text
        assert "to 'Captured head'" in info[0].text
        # her own full head (her face on the sample head's skull, ears and neck: as the kiosk captures) is the
        # document's head, in a face folder under the faces folder
        head = new.doc.head
        assert head.name == "Captured head" and head.path.parent.parent == faces
        assert new.viewport.face.data["head_kind"] == "full"
        assert len(head.vertices) > 468 + 1000  # more than the face mesh (468 landmarks, its few extra points)
        assert (head.path.parent / "face.json").is_file() and new.viewport.face is not None
        assert new.face_path == head.path.parent
        assert [(lay.name, lay.material) for lay in new.doc.layers] == layers
        assert new.isWindowModified() and "on Captured head" in new.windowTitle()
        # the lipstick is on her lips
        lipstick = next(lay for lay in new.doc.layers if lay.name == "Lipstick")
        t = np.asarray(lipstick.effective_thickness())
        lips = new.doc.region_values("lips", lipstick.resolution) > 0
        assert t.sum() > 0 and float(t[lips].sum() / t.sum()) > 0.9
        qtbot.waitUntil(lambda: new.viewport.frames > 0, timeout=60000)  # and the window draws it
    finally:
        driver.answers[:] = ["Discard"]
        new.close()
    assert not new.isVisible() and new.viewport.gl_error_at_release == "GL_NO_ERROR"
    new.deleteLater()
