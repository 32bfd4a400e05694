"""Studio Open/Save on the real project API (issue 6): a real window (xcb under Xvfb, Mesa GL) saves and
opens ``.sheer`` projects bit-exactly with their lights and camera, offers to relink a missing or changed
head, saves self-contained projects, and offers to recover the autosave of a session that was killed. The
questions are the real message boxes, answered by clicking their buttons (``DialogDriver``)."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from app.qt_compat import pin_singletons
from tests.app.studio_support import driver_fixture, studio_fixture, window_fixture

if TYPE_CHECKING:
    from tests.app.studio_support import DialogDriver

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]


studio = studio_fixture(wait_full_quality=False, check_gl_release=False)
#: the module's window as it opened: an untitled, unmodified document, whatever project the tests before
#: opened, saved or recovered
window = window_fixture()
driver = driver_fixture()


RELINK_MISSING = {"Locate head…", "Cancel"}
RELINK_CHANGED = {"Locate head…", "Use it anyway", "Cancel"}


def _paint(window: Any, seed: int) -> list[np.ndarray]:
    """Two layers of random (not quantisable) maps; returns copies of every layer's map."""
    rng = np.random.default_rng(seed)
    from painting.looks import apply_look

    apply_look(window.doc, "bare")
    for material in ("Blush Peach", "Foundation Light"):
        if material not in window.library:
            material = next(iter(window.library.names()))
        window.add_layer(material)
        lay = window.doc.layers[-1]
        res = lay.thickness.shape[0]
        window.doc.set_thickness(lay, (rng.random((res, res)) * 0.5 * lay.max_thickness).astype(np.float32))
    window.doc.set_layer(0, opacity=0.625)
    return [np.array(lay.thickness, copy=True) for lay in window.doc.layers]


def _state(window: Any) -> tuple[list[tuple[Any, ...]], list[np.ndarray]]:
    layers = [(lay.name, lay.material, bool(lay.visible), float(lay.opacity), float(lay.max_thickness))
              for lay in window.doc.layers]
    return layers, [np.array(lay.thickness, copy=True) for lay in window.doc.layers]


def _head_copy(folder: Path) -> Path:
    """The sample head's files copied to ``folder`` (keyed as a project records them); the mesh's path."""
    from project.heads import head_file_set, make_head_ref

    ref = make_head_ref(None)
    folder.mkdir(parents=True)

    for key, src in head_file_set(ref.mesh_path).items():
        (folder / key).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, folder / key)
    return folder / ref.mesh


def _project_on(window: Any, mesh: Path, path: Path) -> Path:
    """Save the window's document as a project referencing the head at ``mesh``."""
    from project.document import project_from_document
    from project.heads import make_head_ref
    from project.io import save_project

    project = project_from_document(window.doc, name=path.stem, head=make_head_ref(mesh),
                                    **vars(window.files.view_state()))
    return save_project(project, path)


def test_save_open_round_trip_restores_layers_lights_and_camera(window: Any, tmp_path: Path) -> None:
    from project.io import open_project

    maps = _paint(window, 1)
    layers, _ = _state(window)
    cam = window.viewport.camera
    cam.yaw, cam.pitch, cam.distance = 31.0, 12.0, 7.5
    cam.target = np.array([0.1, 1.4, 0.2])
    window.change_settings(light_preset="evening", light_azimuth=-42.0, light_elevation=18.0, environment="studio")
    path = tmp_path / "evening.sheer"
    assert window.files.save_project(path=path)
    assert not window.isWindowModified() and window.files.name == "evening"

    saved = open_project(path)
    assert saved.look is not None and saved.camera is not None
    kinds = [light["type"] for light in saved.lights]
    assert kinds == ["directional", "ambient", "environment"]
    assert saved.lights[2]["environment"] == "environments/studio.exr"
    assert np.allclose(saved.camera["target"], [0.1, 1.4, 0.2])

    # change everything, then open
    window.add_layer("Blush Peach" if "Blush Peach" in window.library else next(iter(window.library.names())))
    cam.yaw, cam.pitch, cam.distance = -60.0, 0.0, 12.0
    cam.target = np.array([0.0, 0.0, 0.0])
    window.change_settings(light_preset="office", light_azimuth=0.0, light_elevation=60.0, environment="none")
    assert window.files.open_project(path)
    got_layers, got_maps = _state(window)
    assert got_layers == layers
    for got, want in zip(got_maps, maps, strict=True):
        assert got.dtype == np.float32 and np.array_equal(got, want)  # bit-exact
    assert (cam.yaw, cam.pitch, cam.distance) == pytest.approx((31.0, 12.0, 7.5), abs=1e-6)
    assert np.allclose(cam.target, [0.1, 1.4, 0.2])
    s = window.settings
    assert (s.light_preset, s.environment) == ("evening", "studio")
    assert (s.light_azimuth, s.light_elevation) == pytest.approx((-42.0, 18.0), abs=1e-5)
    assert window.viewport.lighting.azimuth == pytest.approx(-42.0, abs=1e-5)
    assert not window.isWindowModified() and window.files.path == path

    # saving again uses the opened project as the base: same head reference, maps, lights and camera
    assert window.files.save_project()
    again = open_project(path)
    assert again.head == saved.head and again.look == saved.look and again.lights == saved.lights
    assert all(a.same_as(b) for a, b in zip(again.layers, saved.layers, strict=True))
    for key in ("position", "target", "up", "fov_deg", "near", "far"):
        assert np.allclose(again.camera[key], saved.camera[key], rtol=1e-9), key


def _project_on_retouched_head(window: Any, tmp_path: Path, seed: int) -> tuple[list[Any], Path, Path]:
    """A project saved with the maps painted from ``seed`` on a copy of the head, whose albedo is then
    retouched (its hash no longer matches), and the window painted on (``seed + 1``) so that opening
    the project must bring the saved maps back: (saved maps, the copy's mesh, the project)."""
    maps = _paint(window, seed)
    mesh = _head_copy(tmp_path / "head")
    path = _project_on(window, mesh, tmp_path / "changed.sheer")
    with (mesh.parent / "albedo.jpg").open("ab") as fh:
        fh.write(b"retouched")
    _paint(window, seed + 1)
    return maps, mesh, path


def _project_on_moved_head(window: Any, tmp_path: Path, seed: int, retouch: bool = False
                           ) -> tuple[list[Any], Path, Path]:
    """A project saved with the maps painted from ``seed`` on a copy of the head, whose folder is then
    moved (and its albedo retouched if ``retouch``), and the window painted on (``seed + 1``): (saved maps,
    the project, the moved mesh)."""
    maps = _paint(window, seed)
    mesh = _head_copy(tmp_path / "head")
    path = _project_on(window, mesh, tmp_path / "moved.sheer")
    shutil.move(str(mesh.parent), str(tmp_path / "elsewhere"))
    moved = tmp_path / "elsewhere" / mesh.name
    if retouch:
        with (moved.parent / "albedo.jpg").open("ab") as fh:
            fh.write(b"retouched")
    _paint(window, seed + 1)
    return maps, path, moved


def test_changed_head_offers_relink_and_opens_with_use_it_anyway(window: Any, driver: DialogDriver,
                                                                  tmp_path: Path) -> None:
    from project.heads import sha256_file

    maps, mesh, path = _project_on_retouched_head(window, tmp_path, 2)
    driver.answer("Use it anyway")
    assert window.files.open_project(path)
    asked = driver.questions()
    assert [q.title for q in asked] == ["Relink head"]
    assert set(asked[0].buttons) == RELINK_CHANGED and "changed since the project was saved" in asked[0].text
    for got, want in zip(_state(window)[1], maps, strict=True):
        assert np.array_equal(got, want)
    assert window.files.project.head.files["albedo.jpg"] == sha256_file(mesh.parent / "albedo.jpg")


def test_changed_head_relink_in_the_background(window: Any, qtbot: Any, driver: DialogDriver,
                                               tmp_path: Path) -> None:
    maps, mesh, path = _project_on_retouched_head(window, tmp_path, 4)
    driver.answer("Use it anyway")
    window.files.open_project(path, background=True)
    qtbot.waitUntil(lambda: window.files.path == path, timeout=60000)
    assert len(driver.questions()) == 1
    for got, want in zip(_state(window)[1], maps, strict=True):
        assert np.array_equal(got, want)


def test_missing_head_locate_head(window: Any, driver: DialogDriver, tmp_path: Path,
                                  monkeypatch: pytest.MonkeyPatch) -> None:
    from app.studio import project_files

    maps, path, moved = _project_on_moved_head(window, tmp_path, 6)
    driver.answer("Locate head…")
    located: list[str] = []

    def pick(*args: Any, **kwargs: Any) -> tuple[str, str]:
        located.append(args[1] if len(args) > 1 else "")
        return str(moved), ""

    monkeypatch.setattr(project_files.QFileDialog, "getOpenFileName", pick)
    assert window.files.open_project(path)
    asked = driver.questions()
    assert len(asked) == 1 and set(asked[0].buttons) == RELINK_MISSING and len(located) == 1
    assert "was not found" in asked[0].text
    for got, want in zip(_state(window)[1], maps, strict=True):
        assert np.array_equal(got, want)
    assert window.files.project.head.mesh_path == moved.absolute()
    # the relinked head is what the next save records
    assert window.files.save_project(path=tmp_path / "relinked.sheer")
    from project.io import open_project

    assert open_project(tmp_path / "relinked.sheer").head.mesh_path == moved.absolute()


def test_located_head_that_changed_then_use_it_anyway(window: Any, driver: DialogDriver, tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    from app.studio import project_files

    maps, path, moved = _project_on_moved_head(window, tmp_path, 12, retouch=True)
    driver.answer("Locate head…", "Use it anyway")
    monkeypatch.setattr(project_files.QFileDialog, "getOpenFileName", lambda *a, **k: (str(moved), ""))
    assert window.files.open_project(path)
    assert [set(q.buttons) for q in driver.questions()] == [RELINK_MISSING, RELINK_CHANGED]
    for got, want in zip(_state(window)[1], maps, strict=True):
        assert np.array_equal(got, want)
    assert window.files.project.head.mesh_path == moved.absolute()


def test_cancel_leaves_the_document_untouched(window: Any, driver: DialogDriver, tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    from app.studio import project_files

    _paint(window, 8)
    mesh = _head_copy(tmp_path / "head")
    path = _project_on(window, mesh, tmp_path / "gone.sheer")
    shutil.rmtree(mesh.parent)
    _paint(window, 9)
    window.setWindowModified(True)
    before_layers, before_maps = _state(window)
    before = (window.files.project, window.files.path, window.files.name)
    driver.answer("Cancel")
    assert not window.files.open_project(path)
    # "Locate head…" then closing the file dialog is a cancel too
    driver.answer("Locate head…")
    monkeypatch.setattr(project_files.QFileDialog, "getOpenFileName", lambda *a, **k: ("", ""))
    assert not window.files.open_project(path)
    assert [q.clicked for q in driver.questions()] == ["Cancel", "Locate head…"]
    layers, maps = _state(window)
    assert layers == before_layers
    for got, want in zip(maps, before_maps, strict=True):
        assert np.array_equal(got, want)
    assert (window.files.project, window.files.path, window.files.name) == before
    assert window.isWindowModified()


def test_save_self_contained_opens_without_the_head(window: Any, tmp_path: Path) -> None:
    from project.io import open_project

    maps = _paint(window, 10)
    mesh = _head_copy(tmp_path / "head")
    path = _project_on(window, mesh, tmp_path / "on-copy.sheer")
    assert window.files.open_project(path)
    assert window.files.save_self_contained(tmp_path / "packed.sheer")
    shutil.rmtree(mesh.parent)
    packed = open_project(tmp_path / "packed.sheer")
    assert packed.head.embedded
    _paint(window, 11)
    assert window.files.open_project(tmp_path / "packed.sheer")
    for got, want in zip(_state(window)[1], maps, strict=True):
        assert np.array_equal(got, want)
    assert window.actions_by_id["file.save_self_contained"].isEnabled()


def test_project_at_another_resolution_is_resampled_on_request(window: Any, qtbot: Any, driver: DialogDriver,
                                                                tmp_path: Path) -> None:
    """A project painted at another resolution: Cancel leaves the document as it was; Resample installs
    its maps at the studio's resolution (same paint where it was, none outside the charts)."""
    from app import project_io
    from app.session import Session

    want = int(window.doc.resolution)
    other = 256 if want != 256 else 512
    doc2 = Session.open(resolution=other, look="red-lip", library=window.library).document
    path = project_io.save_document(doc2, tmp_path / "other.sheer", "other")
    src = np.array(doc2.layers[0].thickness)
    before = _state(window)

    driver.answer("Cancel")
    assert not window.files.open_project(path)
    assert _state(window)[0] == before[0]
    assert all(np.array_equal(a, b) for a, b in zip(_state(window)[1], before[1], strict=True))

    driver.answer("Resample")
    assert window.files.open_project(path)
    qtbot.waitUntil(lambda: window.files.path == path, timeout=60000)
    asked = driver.questions()
    assert [q.clicked for q in asked] == ["Cancel", "Resample"] and set(asked[1].buttons) == {"Resample", "Cancel"}
    assert f"{other}×{other}" in asked[1].text
    assert [lay.name for lay in window.doc.layers] == [lay.name for lay in doc2.layers]
    got = np.array(window.doc.layers[0].thickness)
    assert got.shape == (want, want) and got.dtype == np.float32
    # the same paint: coverage-weighted amount within 10 %, peak within 25 %, nothing off the charts
    atlas = window.doc.atlas_at(want)
    src_atlas = doc2.atlas_at(other)
    amount_src = float(src[src_atlas.coverage].sum()) / other ** 2
    amount_got = float(got[atlas.coverage].sum()) / want ** 2
    assert amount_got == pytest.approx(amount_src, rel=0.10)
    assert got.max() == pytest.approx(float(src.max()), rel=0.25)
    assert not np.any(got[~(atlas.coverage | atlas.padded)])


CRASHED_SESSION = textwrap.dedent("""
    import os, signal, sys
    import numpy as np
    from app import project_io
    from app.session import Session

    doc = Session.open(resolution=512, look="red-lip").document
    lay = doc.layers[0]
    rng = np.random.default_rng(5)
    doc.set_thickness(lay, (rng.random(lay.thickness.shape) * 0.5 * lay.max_thickness).astype(np.float32))
    saver = project_io.make_autosaver(lambda: project_io.snapshot(doc, "crashed"), None, 0.01)
    path = saver.autosave_now()
    np.save(sys.argv[1], np.stack([np.asarray(layer.thickness) for layer in doc.layers]))
    print(path, flush=True)
    os.kill(os.getpid(), signal.SIGKILL)
""")


def test_recovery_offer_restores_the_autosave_of_a_killed_session(window: Any, driver: DialogDriver,
                                                                 tmp_path: Path) -> None:
    """A session killed after an autosave leaves its recovery file. The studio's offer (``offer_recovery``,
    also run at start-up) answered Later keeps it; answered Recover it brings the session's layers and
    maps back bit-exactly, as unsaved work (the window shows it modified), and removes the file."""
    proc = subprocess.run([sys.executable, "-c", CRASHED_SESSION, str(tmp_path / "maps.npy")],
                          capture_output=True, text=True, timeout=300, env=dict(os.environ))
    assert proc.returncode == -signal.SIGKILL, proc.stderr[-2000:]
    recovery = Path(proc.stdout.strip())
    assert recovery.is_file() and recovery.parent == Path(os.environ["SHEER_RECOVERY_DIR"])
    want = np.load(tmp_path / "maps.npy")
    _paint(window, 20)
    window.files.save_project(path=tmp_path / "mine.sheer")
    before = _state(window)

    driver.answer("Later")
    window.files.offer_recovery()
    asked = driver.questions()
    assert [q.title for q in asked] == ["Recover unsaved work"]
    assert set(asked[0].buttons) == {"Recover", "Discard", "Later"} and "untitled work" in asked[0].text
    assert recovery.is_file() and _state(window)[0] == before[0] and not window.isWindowModified()

    driver.answer("Recover")
    window.files.offer_recovery()
    got = np.stack([np.asarray(layer.thickness) for layer in window.doc.layers])
    assert got.shape == want.shape and np.array_equal(got, want)
    assert window.files.name == "crashed" and window.files.path is None
    assert window.isWindowModified() and "crashed" in window.windowTitle()
    assert not recovery.exists()
    window.files.offer_recovery()  # nothing left to offer
    assert len(driver.questions()) == 2


def test_file_new_offers_to_save_unsaved_work_first(window: Any, driver: DialogDriver, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    from app.studio import project_files

    maps = _paint(window, 21)
    window.setWindowModified(True)
    new = window.actions_by_id["file.new"]
    driver.answer("Cancel")
    new.trigger()
    asked = driver.questions()
    assert [(q.title, q.clicked) for q in asked] == [("Unsaved changes", "Cancel")]
    for got, want in zip(_state(window)[1], maps, strict=True):
        assert np.array_equal(got, want)
    assert window.isWindowModified()
    # Save: the work goes to a file first, then File -> New starts the bare look
    target = tmp_path / "kept.sheer"
    monkeypatch.setattr(project_files.QFileDialog, "getSaveFileName", lambda *a, **k: (str(target), ""))
    driver.answer("Save")
    new.trigger()
    assert [q.clicked for q in driver.questions()] == ["Cancel", "Save"]
    assert target.is_file() and window.files.name == "Untitled" and not window.isWindowModified()
    from project.io import open_project

    saved = open_project(target)
    for layer, want in zip(saved.layers, maps, strict=True):
        assert np.array_equal(layer.thickness, want)
    # File -> Open asks nothing of an unmodified window (the open is then cancelled in its file dialog)
    monkeypatch.setattr(project_files.QFileDialog, "getOpenFileName", lambda *a, **k: ("", ""))
    window.actions_by_id["file.open"].trigger()
    assert len(driver.questions()) == 2
