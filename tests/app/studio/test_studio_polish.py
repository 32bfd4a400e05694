"""A designer's first hour in the real studio window (xcb under Xvfb, Mesa GL): ready-made looks from a
Looks menu and gallery (thumbnails, one undo step) and ``sheer --look NAME``; New from Photo framing her
whole face and keeping the dock in front; a hover read-out that never widens the library dock; a first
window within the screen; plots whose legends leave the curves alone, whose labels are whole and whose
axes read as they should; tooltips on the bars' controls, debug views under View → Developer, a status
bar without the renderer's class, Undo/Redo naming the step, Recent Projects above Quit; Export Rendered
Image refusing "abc" before any file dialog, with its title in full; File → Export OpenRaster."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest
from PySide6.QtCore import QPointF, QTimer
from PySide6.QtWidgets import QApplication, QDockWidget, QLabel, QToolBar

from app.qt_compat import pin_singletons
from tests.app.studio_support import reset_studio, studio_fixture

if TYPE_CHECKING:
    from tests.app.studio_support import DialogDriver

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]

studio = studio_fixture(wait_full_quality=False)
ROOT = Path(__file__).resolve().parents[3]


def settle() -> None:
    for _ in range(30):
        QApplication.processEvents()


def dock(win: Any, name: str) -> QDockWidget:
    return next(d for d in win.findChildren(QDockWidget) if d.objectName() == name)


def in_front(win: Any, name: str) -> bool:
    """The dock ``name`` is the tab shown (not hidden behind another tab)."""
    d = dock(win, name)
    return d.isVisible() and not d.visibleRegion().isEmpty()


def screen_of(win: Any, point: Any) -> tuple[float, float]:
    """Widget pixel (x, y) of a mesh point in the viewport's current view."""
    vp = win.viewport
    w, h = vp.pixel_size()
    c = vp.camera.view_projection(w / h) @ np.append(np.asarray(point, float), 1.0)
    ndc = c[:2] / c[3]
    r = vp.devicePixelRatioF()
    return (ndc[0] * 0.5 + 0.5) * w / r, (0.5 - ndc[1] * 0.5) * h / r


def face_in_view(win: Any) -> bool:
    """Forehead, chin and both cheeks inside the viewport, the face filling a fair share of it."""
    lm = win.doc.head.metadata.landmarks
    pts = np.array([screen_of(win, lm[k]) for k in ("forehead", "chin", "left_cheek", "right_cheek")])
    vp = win.viewport
    inside = (pts[:, 0] > 0).all() and (pts[:, 0] < vp.width()).all() and (pts[:, 1] > 0).all() and (
        pts[:, 1] < vp.height()).all()
    return bool(inside and np.ptp(pts[:, 1]) > 0.25 * vp.height())


# ------------------------------------------------------------------ looks
def test_the_looks_menu_adds_a_look_as_new_layers_in_one_undo_step(studio: tuple[Any, DialogDriver]) -> None:
    from painting.looks import load_look

    win, _driver = studio
    reset_studio(win)
    before = [lay.name for lay in win.doc.layers]
    menu = next(a.menu() for a in win.menuBar().actions() if a.text().replace("&", "") == "Looks")
    titles = [a.text() for a in menu.actions()]
    assert "Add Look: red-lip" in titles and "Add Look: evening" in titles and "Add Look: bare" not in titles
    win.looks.actions["red-lip"].trigger()
    look = load_look("red-lip")
    assert [lay.name for lay in win.doc.layers] == before + [lay.name for lay in look.layers]
    assert win.actions_by_id["edit.undo"].text() == "&Undo look red-lip"
    assert win.layers_panel.isVisible() and win.selected_layer == len(win.doc.layers) - 1
    win.actions_by_id["edit.undo"].trigger()  # one step takes the whole look off
    assert [lay.name for lay in win.doc.layers] == before
    assert win.actions_by_id["edit.redo"].text() == "&Redo look red-lip"
    win.actions_by_id["edit.redo"].trigger()
    assert len(win.doc.layers) == len(before) + len(look.layers)
    assert float(win.doc.layers[-1].effective_thickness().max()) > 0  # painted, not empty layers


def test_the_look_gallery_shows_rendered_thumbnails(studio: tuple[Any, DialogDriver], qtbot: Any) -> None:
    from app.studio.looks_menu import THUMB_SIZE, thumbnail_path

    win, _driver = studio
    reset_studio(win)
    gallery = win.looks.show_gallery()
    try:
        assert gallery.isVisible() and gallery.windowTitle() == "Look Gallery"
        names = [gallery.list.item(i).data(0x0100) for i in range(gallery.list.count())]
        assert "natural" in names and "red-lip" in names and "bare" not in names
        qtbot.waitUntil(lambda: set(names) <= set(win.looks.thumbnails), timeout=240000)
        red, bare_ish = win.looks.thumbnails["red-lip"], win.looks.thumbnails["no-makeup"]
        assert red.shape == (THUMB_SIZE, THUMB_SIZE, 3) and red.std() > 20  # a face, not a flat picture
        assert np.abs(red.astype(int) - bare_ish.astype(int)).max() > 40  # each look its own picture
        assert thumbnail_path(win.doc, "red-lip").is_file()  # cached for the next start
        assert not win.looks.actions["red-lip"].icon().isNull()
        item = next(gallery.list.item(i) for i in range(gallery.list.count()) if gallery.list.item(i).text() == "evening")
        gallery.list.setCurrentItem(item)
        n = len(win.doc.layers)
        gallery.add_button.click()  # Add to the Head
        assert not gallery.isVisible() and len(win.doc.layers) > n
    finally:
        gallery.close()


def test_sheer_look_starts_the_studio_with_that_look(monkeypatch: pytest.MonkeyPatch) -> None:
    from app import cli
    from app.studio import launch

    started: list[dict[str, Any]] = []
    monkeypatch.setattr(launch, "run_studio", lambda **kw: started.append(kw) or 0)
    assert cli.main(["--look", "red-lip"]) == 0
    assert started and started[0]["look"] == "red-lip"


# ------------------------------------------------------------------ the window and its docks
def test_hovering_a_plot_never_widens_the_library_dock(studio: tuple[Any, DialogDriver], qtbot: Any) -> None:
    win, _driver = studio
    win.resize(1280, 800)
    library = win.library_dock
    library.build_plots()
    dock(win, "material_library").raise_()
    settle()
    view_w, dock_w = win.viewport.width(), dock(win, "material_library").width()
    plot = library.refl_plot
    centre = plot.mapToScene(plot.viewport().rect().center())
    plot.scene().sigMouseMoved.emit(QPointF(centre))
    settle()
    assert "λ" in library.readout.text() and len(library.readout.text()) > 80  # the long read-out…
    assert dock(win, "material_library").width() == dock_w  # …wraps within the dock
    assert win.viewport.width() == view_w
    # the layout saved now is the one restored at the next start
    from app.studio.toolbars import WINDOW_STATE_VERSION

    state = win.saveState(WINDOW_STATE_VERSION)
    assert win.restoreState(state, WINDOW_STATE_VERSION)
    settle()
    assert win.viewport.width() == view_w


def test_the_first_window_fits_a_small_screen(tmp_path: Path) -> None:
    """As ``sheer studio`` opens it on a 1366×768 screen with no saved layout: within the screen, status bar
    included (it was 1280×978 at least, taller than the screen)."""
    script = tmp_path / "first.py"
    script.write_text(
        "import json, os, sys\n"
        f"sys.path.insert(0, {str(ROOT)!r})\n"
        "from app.application import make_application\n"
        "app = make_application()\n"
        "from PySide6.QtCore import QSettings\n"
        "from app.session import Session\n"
        "from app.studio.main_window import StudioWindow\n"
        "win = StudioWindow(Session.open(resolution=64, look=''), "
        f"qsettings=QSettings({str(tmp_path / 's.ini')!r}, QSettings.Format.IniFormat))\n"
        "win.show()\n"
        "for _ in range(50): app.processEvents()\n"
        "g, a = win.frameGeometry(), win.screen().availableGeometry()\n"
        "s = win.statusBar().mapTo(win, win.statusBar().rect().bottomLeft())\n"
        "print(json.dumps({'frame': [g.x(), g.y(), g.width(), g.height()], 'area': [a.x(), a.y(), a.width(), a.height()],"
        " 'status_bottom': win.y() + s.y(), 'min_h': win.minimumSizeHint().height()}))\n"
        "win.viewport.shutdown()\n"
        "os._exit(0)\n")
    env = {**os.environ, "SHEER_RECOVERY_DIR": str(tmp_path / "recovery")}
    env.pop("DISPLAY", None)
    out = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1366x768x24", sys.executable, str(script)],
                         capture_output=True, text=True, timeout=600, env=env, cwd=ROOT)
    line = next((ln for ln in out.stdout.splitlines() if ln.startswith("{")), None)
    assert line is not None, out.stdout[-2000:] + out.stderr[-2000:]
    got = json.loads(line)
    x, y, w, h = got["frame"]
    ax, ay, aw, ah = got["area"]
    assert (ax, ay, aw, ah) == (0, 0, 1366, 768)
    assert got["min_h"] < ah - 40, got
    assert x >= ax and y >= ay and x + w <= ax + aw and y + h + 32 <= ay + ah, got  # (32: a title bar)
    assert got["status_bottom"] <= ay + ah, got


def test_new_from_photo_frames_her_face_and_keeps_the_dock_in_front(studio: tuple[Any, DialogDriver], qtbot: Any,
                                                                     tmp_path: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    from PySide6.QtCore import QSettings

    from app.session import Session
    from app.studio.main_window import StudioWindow
    from app.studio.new_from_photo import NewFromPhoto
    from core.assets import find_asset

    monkeypatch.setenv("SHEER_RECOVERY_DIR", str(tmp_path / "recovery"))
    driver = studio[1]
    win = StudioWindow(Session.open(resolution=256, look="natural"),
                       qsettings=QSettings(str(tmp_path / "studio.ini"), QSettings.Format.IniFormat))
    win.resize(1000, 760)
    win.show()
    qtbot.waitUntil(lambda: win.viewport.frames > 0, timeout=60000)
    dock(win, "shade_finder").raise_()
    settle()
    assert in_front(win, "shade_finder") and not in_front(win, "material_library")
    size = win.size()
    action = NewFromPhoto(win)
    action.start(find_asset("photos/grace_hopper.jpg"), tmp_path / "faces" / "her")
    qtbot.waitUntil(lambda: action.opened is not None, timeout=300000)
    new = action.opened
    try:
        qtbot.waitUntil(lambda: new.viewport.frames > 0, timeout=60000)
        settle()
        assert in_front(new, "shade_finder"), "the right dock switched away from the Shade Finder"
        assert new.size() == size  # the window it came from, as it was
        assert face_in_view(new), "her face is cropped"
        new.viewport.camera.zoom(0.3)
        new.viewport.camera.orbit(30, 10)
        assert not face_in_view(new)
        new.actions_by_id["view.frame"].trigger()  # F frames her whole face again
        assert face_in_view(new)
    finally:
        driver.answers[:] = ["Discard"]
        new.close()
    assert not new.isVisible()
    new.deleteLater()


# ------------------------------------------------------------------ plots
def _legend_clear_of_curves(plot: Any) -> bool:
    item = plot.getPlotItem()
    legend = item.legend
    return legend is not None and not legend.sceneBoundingRect().intersects(item.vb.sceneBoundingRect())


def _label_whole(plot: Any, side: str = "left") -> bool:
    """The axis label fits along its axis (rotated on the left: its width against the axis' height)."""
    axis = plot.getPlotItem().getAxis(side)
    length = axis.height() if side == "left" else axis.width()
    return axis.label.boundingRect().width() <= length


def test_plots_keep_legends_off_the_curves_whole_labels_and_true_axes(studio: tuple[Any, DialogDriver]) -> None:
    win, _driver = studio
    win.resize(1280, 1000)
    win.library_dock.build_plots()
    dock(win, "shade_finder").raise_()
    finder = win.shade_finder
    finder.match_head()
    assert finder.coverage_plot is None  # no empty "hue angle" plot of 0.1–0.9 before a coverage exists
    dock(win, "material_library").raise_()
    settle()
    lib = win.library_dock
    for plot in (lib.refl_plot, lib.coef_plot):
        assert _legend_clear_of_curves(plot) and _label_whole(plot)
    assert len(lib.refl_plot.getPlotItem().legend.items) >= 3
    dock(win, "shade_finder").raise_()
    settle()
    spectra = finder.spectra_plot
    assert _legend_clear_of_curves(spectra) and _label_whole(spectra)
    left = spectra.getPlotItem().getAxis("left")
    assert left.autoSIPrefixScale == 1.0 and left.labelUnitPrefix == ""  # 0.2–0.6, not "200–600"
    low, high = spectra.getPlotItem().vb.viewRange()[1]
    assert 0.0 <= high <= 1.2
    pens = [c.opts["pen"].color().name() for c in spectra.getPlotItem().listDataItems()]
    assert len(pens) == 2 and pens[0] != pens[1]  # the skin and the made-up skin in two colours
    finder.show_coverage(finder.compute_coverage(skins=40))
    settle()
    cov = finder.coverage_plot
    x_low, x_high = cov.getPlotItem().vb.viewRange()[0]
    assert x_high > 10 and _label_whole(cov, "bottom")  # degrees of hue, not 0.1–0.9


# ------------------------------------------------------------------ controls, menus, status
def test_every_bar_control_has_a_tooltip_and_debug_views_are_for_developers(studio: tuple[Any, DialogDriver]) -> None:
    from render.view import debug_views

    win, _driver = studio
    reset_studio(win)
    controls = {"Radius": win.radius_spin, "Strength": win.strength_spin, "Hardness": win.hardness_spin,
                "brush Mode": win.mode_combo, "Mirror": win.mirror_check, "Light": win.light_combo,
                "HDR": win.env_combo, "render Mode": win.render_combo, "Before|After": win.split_slider}
    assert [name for name, w in controls.items() if len(w.toolTip()) < 15] == []
    labels = [w for tb in win.findChildren(QToolBar) for w in tb.findChildren(QLabel) if w.text().strip()]
    assert [lab.text() for lab in labels if not lab.toolTip()] == []
    # no toolbar offers the debug views; View → Developer does
    for tb in win.findChildren(QToolBar):
        for act in tb.actions():
            w = tb.widgetForAction(act)
            items = [w.itemText(i) for i in range(w.count())] if hasattr(w, "itemText") else []
            assert "albedo" not in items and "irradiance" not in items
    view = next(a.menu() for a in win.menuBar().actions() if a.text().replace("&", "") == "View")
    developer = next(a.menu() for a in view.actions() if a.menu() is not None and "Developer" in a.text())
    titles = [a.text() for a in developer.actions()]
    assert all(any(name in t for t in titles) for name in debug_views()[1:])
    thickness = next(a for a in developer.actions() if a.text().endswith("thickness"))
    thickness.trigger()
    assert win.viewport.debug == debug_views().index("thickness") and thickness.isChecked()
    developer.actions()[0].trigger()
    assert win.viewport.debug == 0
    assert "render.Renderer" not in win.status.text() and "renderer" not in win.status.text()


def test_undo_and_redo_name_the_step(studio: tuple[Any, DialogDriver]) -> None:
    win, _driver = studio
    reset_studio(win)
    assert win.actions_by_id["edit.undo"].text() == "&Undo" and not win.actions_by_id["edit.undo"].isEnabled()
    win.add_layer("Lipstick Classic Red")
    undo = win.actions_by_id["edit.undo"]
    assert undo.isEnabled() and undo.text() == "&Undo add layer Lipstick Classic Red"
    undo.trigger()
    assert win.actions_by_id["edit.redo"].text() == "&Redo add layer Lipstick Classic Red"
    assert win.actions_by_id["edit.undo"].text() == "&Undo"


def test_recent_projects_sits_above_quit(studio: tuple[Any, DialogDriver]) -> None:
    win, _driver = studio
    file_menu = next(a.menu() for a in win.menuBar().actions() if a.text().replace("&", "") == "File")
    acts = file_menu.actions()
    recent = next(i for i, a in enumerate(acts) if a.menu() is win.recent_menu)
    quit_ = acts.index(win.actions_by_id["file.quit"])
    assert recent < quit_ and acts[-1] is win.actions_by_id["file.quit"]


# ------------------------------------------------------------------ exports
def test_export_image_refuses_a_bad_size_before_asking_for_a_file(studio: tuple[Any, DialogDriver],
                                                                   monkeypatch: pytest.MonkeyPatch,
                                                                   tmp_path: Path) -> None:
    from app.studio import export_actions
    from app.studio.export_actions import ImageSizeDialog

    win, _driver = studio
    asked: list[str] = []
    exported: list[tuple[Any, Any]] = []
    monkeypatch.setattr(export_actions.QFileDialog, "getSaveFileName",
                        lambda *a, **k: (asked.append(a[1]) or str(tmp_path / "r.png"), ""))
    monkeypatch.setattr(win.exports, "export_image", lambda path, size, on_done=None: exported.append((path, size)))
    seen: dict[str, Any] = {}

    def answer() -> None:
        dialog = next(w for w in QApplication.topLevelWidgets() if isinstance(w, ImageSizeDialog) and w.isVisible())
        seen["title"] = dialog.windowTitle()
        seen["title_fits"] = dialog.width() >= dialog.fontMetrics().horizontalAdvance(dialog.windowTitle()) + 120
        dialog.combo.setEditText("abc")
        seen["ok_for_abc"] = dialog.buttons.button(dialog.buttons.StandardButton.Ok).isEnabled()
        seen["hint"] = dialog.hint.text()
        dialog.accept()  # (Enter in the field): refused, the dialog stays
        seen["still_open"] = dialog.isVisible()
        dialog.combo.setEditText("640 x 480")
        seen["ok_for_size"] = dialog.buttons.button(dialog.buttons.StandardButton.Ok).isEnabled()
        dialog.buttons.button(dialog.buttons.StandardButton.Ok).click()

    QTimer.singleShot(200, answer)
    win.actions_by_id["file.export_image"].trigger()
    assert seen["title"] == "Export Rendered Image" and seen["title_fits"]
    assert not seen["ok_for_abc"] and "1920x1080" in seen["hint"] and seen["still_open"]
    assert seen["ok_for_size"] and asked == ["Export rendered image"]
    assert exported == [(tmp_path / "r.png", (640, 480))]


def test_export_openraster_from_the_studio(studio: tuple[Any, DialogDriver], qtbot: Any, tmp_path: Path) -> None:
    from tests.project.test_openraster import composite, read_ora

    win, _driver = studio
    reset_studio(win, "red-lip")
    assert win.actions_by_id["file.export_ora"].isEnabled()
    done: list[object] = []
    win.exports.export_ora(tmp_path / "look.ora", on_done=done.append)
    qtbot.waitUntil(lambda: bool(done), timeout=120000)
    root, pngs, merged = read_ora(tmp_path / "look.ora")
    names = [e.get("name") for e in root.find("stack") if e.tag == "layer"]
    assert names[0].startswith(win.doc.layers[-1].name) and len(names) == len(win.doc.layers)
    assert np.abs(merged.astype(float) / 255 - composite(root, pngs)).max() < 2.5 / 255
    lips = win.doc.region_values("lips", win.doc.layers[-1].resolution) > 0.9
    assert np.median(merged[..., 3][lips]) > 200 and np.median(merged[..., 0][lips]) > np.median(merged[..., 1][lips]) + 60
