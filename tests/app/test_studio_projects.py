"""Studio Open/Save on the real project API (issue 6): a real window (xcb under Xvfb, Mesa GL) saves and
opens ``.sheer`` projects bit-exactly with their lights and camera, offers to relink a missing or changed
head, and saves self-contained projects. The relink dialog is driven by replacing ``dialogs.ask``."""

from __future__ import annotations

import shutil
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from app.qt_compat import pin_singletons
from tests.app.studio_support import open_studio_window

if TYPE_CHECKING:
    from collections.abc import Iterator
    from pathlib import Path

pin_singletons()

pytest.importorskip("pytestqt")
pytestmark = [pytest.mark.qt, pytest.mark.gl]


@pytest.fixture(scope="module")
def window(qapp: object, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    with open_studio_window(qapp, tmp_path_factory, wait_full_quality=False, check_gl_release=False) as win:
        yield win


class Answers:
    """Stands in for ``dialogs.ask``: records each question and gives the next prepared answer."""

    def __init__(self, *answers: str) -> None:
        self.answers = list(answers)
        self.asked: list[tuple[str, dict[str, str]]] = []

    def __call__(self, parent: object, title: str, text: str, choices: dict[str, str], default: str) -> str:
        self.asked.append((title, dict(choices)))
        return self.answers.pop(0)


def _paint(window: Any, seed: int) -> list[np.ndarray]:
    """Two layers of random (not quantisable) maps; returns copies of every layer's map."""
    rng = np.random.default_rng(seed)
    from app import seams

    seams.apply_look(window.doc, window.library, "bare")
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
    from project.io import make_head_ref

    ref = make_head_ref(None)
    folder.mkdir(parents=True)
    from project.io import head_file_set

    for key, src in head_file_set(ref.mesh_path).items():
        (folder / key).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, folder / key)
    return folder / ref.mesh


def _project_on(window: Any, mesh: Path, path: Path) -> Path:
    """Save the window's document as a project referencing the head at ``mesh``."""
    from project.io import Project, make_head_ref, save_project

    project = Project.from_document(window.doc.doc, name=path.stem, head=make_head_ref(mesh),
                                    **vars(window.view_state()))
    return save_project(project, path)


def test_save_open_round_trip_restores_layers_lights_and_camera(window: Any, tmp_path: Path) -> None:
    from project.io import open_project

    maps = _paint(window, 1)
    layers, _ = _state(window)
    cam = window.viewport.camera
    cam.yaw, cam.pitch, cam.distance = 31.0, 12.0, 7.5
    cam.target = np.array([0.1, 1.4, 0.2])
    window._set(light_preset="evening", light_azimuth=-42.0, light_elevation=18.0, environment="studio")
    path = tmp_path / "evening.sheer"
    assert window.save_project(path=path)
    assert not window.isWindowModified() and window.project_name == "evening"

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
    window._set(light_preset="office", light_azimuth=0.0, light_elevation=60.0, environment="none")
    assert window.open_project(path)
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
    assert not window.isWindowModified() and window.project_path == path

    # saving again uses the opened project as the base: same head reference, maps, lights and camera
    assert window.save_project()
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


def test_changed_head_offers_relink_and_opens_with_use_it_anyway(window: Any, tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    from app import dialogs
    from project.io import sha256_file

    maps, mesh, path = _project_on_retouched_head(window, tmp_path, 2)
    answers = Answers("accept")
    monkeypatch.setattr(dialogs, "ask", answers)
    assert window.open_project(path)
    assert [t for t, _ in answers.asked] == ["Relink head"]
    assert set(answers.asked[0][1]) == {"locate", "accept", "cancel"}
    for got, want in zip(_state(window)[1], maps, strict=True):
        assert np.array_equal(got, want)
    assert window.project.head.files["albedo.jpg"] == sha256_file(mesh.parent / "albedo.jpg")


def test_changed_head_relink_in_the_background(window: Any, qtbot: Any, tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    from app import dialogs

    maps, mesh, path = _project_on_retouched_head(window, tmp_path, 4)
    answers = Answers("accept")
    monkeypatch.setattr(dialogs, "ask", answers)
    window.open_project(path, background=True)
    qtbot.waitUntil(lambda: window.project_path == path, timeout=60000)
    assert len(answers.asked) == 1
    for got, want in zip(_state(window)[1], maps, strict=True):
        assert np.array_equal(got, want)


def test_missing_head_locate_head(window: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from app import dialogs, main_window

    maps = _paint(window, 6)
    mesh = _head_copy(tmp_path / "head")
    path = _project_on(window, mesh, tmp_path / "moved.sheer")
    shutil.move(str(mesh.parent), str(tmp_path / "elsewhere"))
    moved = tmp_path / "elsewhere" / mesh.name
    _paint(window, 7)
    answers = Answers("locate")
    monkeypatch.setattr(dialogs, "ask", answers)
    located: list[str] = []

    def pick(*args: Any, **kwargs: Any) -> tuple[str, str]:
        located.append(args[1] if len(args) > 1 else "")
        return str(moved), ""

    monkeypatch.setattr(main_window.QFileDialog, "getOpenFileName", pick)
    assert window.open_project(path)
    assert set(answers.asked[0][1]) == {"locate", "cancel"} and len(located) == 1
    for got, want in zip(_state(window)[1], maps, strict=True):
        assert np.array_equal(got, want)
    assert window.project.head.mesh_path == moved.absolute()
    # the relinked head is what the next save records
    assert window.save_project(path=tmp_path / "relinked.sheer")
    from project.io import open_project

    assert open_project(tmp_path / "relinked.sheer").head.mesh_path == moved.absolute()


def test_located_head_that_changed_then_use_it_anyway(window: Any, tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    from app import dialogs, main_window

    maps = _paint(window, 12)
    mesh = _head_copy(tmp_path / "head")
    path = _project_on(window, mesh, tmp_path / "moved.sheer")
    shutil.move(str(mesh.parent), str(tmp_path / "elsewhere"))
    moved = tmp_path / "elsewhere" / mesh.name
    with (moved.parent / "albedo.jpg").open("ab") as fh:
        fh.write(b"retouched")
    _paint(window, 13)
    answers = Answers("locate", "accept")
    monkeypatch.setattr(dialogs, "ask", answers)
    monkeypatch.setattr(main_window.QFileDialog, "getOpenFileName", lambda *a, **k: (str(moved), ""))
    assert window.open_project(path)
    assert [set(c) for _, c in answers.asked] == [{"locate", "cancel"}, {"locate", "accept", "cancel"}]
    for got, want in zip(_state(window)[1], maps, strict=True):
        assert np.array_equal(got, want)
    assert window.project.head.mesh_path == moved.absolute()


def test_cancel_leaves_the_document_untouched(window: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from app import dialogs, main_window

    _paint(window, 8)
    mesh = _head_copy(tmp_path / "head")
    path = _project_on(window, mesh, tmp_path / "gone.sheer")
    shutil.rmtree(mesh.parent)
    _paint(window, 9)
    window.setWindowModified(True)
    before_layers, before_maps = _state(window)
    before = (window.project, window.project_path, window.project_name)
    monkeypatch.setattr(dialogs, "ask", Answers("cancel"))
    assert not window.open_project(path)
    # "Locate head…" then closing the file dialog is a cancel too
    monkeypatch.setattr(dialogs, "ask", Answers("locate"))
    monkeypatch.setattr(main_window.QFileDialog, "getOpenFileName", lambda *a, **k: ("", ""))
    assert not window.open_project(path)
    layers, maps = _state(window)
    assert layers == before_layers
    for got, want in zip(maps, before_maps, strict=True):
        assert np.array_equal(got, want)
    assert (window.project, window.project_path, window.project_name) == before
    assert window.isWindowModified()


def test_save_self_contained_opens_without_the_head(window: Any, tmp_path: Path) -> None:
    from project.io import open_project

    maps = _paint(window, 10)
    mesh = _head_copy(tmp_path / "head")
    path = _project_on(window, mesh, tmp_path / "on-copy.sheer")
    assert window.open_project(path)
    assert window.save_self_contained(tmp_path / "packed.sheer")
    shutil.rmtree(mesh.parent)
    packed = open_project(tmp_path / "packed.sheer")
    assert packed.head.embedded
    _paint(window, 11)
    assert window.open_project(tmp_path / "packed.sheer")
    for got, want in zip(_state(window)[1], maps, strict=True):
        assert np.array_equal(got, want)
    assert window.actions_by_id["file.save_self_contained"].isEnabled()


def test_project_at_another_resolution_is_resampled_on_request(window: Any, qtbot: Any, tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """A project painted at another resolution: Cancel leaves the document as it was; Resample installs
    its maps at the studio's resolution (same paint where it was, none outside the charts)."""
    from app import dialogs, project_io, seams

    want = int(window.doc.resolution)
    other = 256 if want != 256 else 512
    doc2 = seams.open_document(None, other, window.library)
    seams.apply_look(doc2, window.library, "red-lip")
    path = project_io.save_document(doc2, window.library, tmp_path / "other.sheer", "other")
    src = np.array(doc2.layers[0].thickness)
    before = _state(window)

    monkeypatch.setattr(dialogs, "ask", Answers("cancel"))
    assert not window.open_project(path)
    assert _state(window)[0] == before[0]
    assert all(np.array_equal(a, b) for a, b in zip(_state(window)[1], before[1], strict=True))

    answers = Answers("resample")
    monkeypatch.setattr(dialogs, "ask", answers)
    assert window.open_project(path)
    qtbot.waitUntil(lambda: window.project_path == path, timeout=60000)
    assert answers.asked and "resample" in answers.asked[0][1]
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
