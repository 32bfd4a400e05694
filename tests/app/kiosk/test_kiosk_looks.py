"""A brand's project is the kiosk's look: ``sheer kiosk --project brand.sheer`` (the real command, the real
window) shows it on a button of its own, first and selected, keeps it in the attract mode's cycle and lets a
shopper choose it again, on the sample face and on hers; ``--looks`` stores projects and built-in looks in
the configuration; a project that cannot be used is one line and exit status 2 before any window (and
before the display check)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from app.cli import main
from app.kiosk.config import KioskConfig, kiosk_looks, open_look_projects
from app.qt_compat import pin_singletons
from tests.app.kiosk.kiosk_support import pin_hash

pin_singletons()

PIN = "2468"
BRAND = "Brand Glow"


@pytest.fixture(scope="module")
def brand(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A brand's project, made with the real ``sheer project new`` (soft glam, 512², named "Brand Glow")."""
    path = tmp_path_factory.mktemp("brand") / "brand.sheer"
    assert main(["project", "new", "--out", str(path), "--look", "soft-glam", "--resolution", "512",
                 "--name", BRAND]) == 0
    return path


def write_config(path: Path, **fields: Any) -> Path:
    data = {"pin_hash": pin_hash(PIN), "snapshot_dir": str(path.parent / "photos"), "resolution": 512,
            "fullscreen": False, **fields}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def sheer_without_display(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """``sheer ARGS`` in a real process with no display at all (no DISPLAY, WAYLAND_DISPLAY or Qt platform)."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM")}
    repo = str(Path(__file__).resolve().parents[3])
    env["PYTHONPATH"] = repo + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.run([sys.executable, "-m", "app.cli", *args], capture_output=True, text=True, timeout=120,
                          env=env, cwd=cwd, stdin=subprocess.DEVNULL)


def test_looks_lists_projects_and_built_in_looks_in_the_configuration(
        brand: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    config = tmp_path / "kiosk.json"
    monkeypatch.chdir(brand.parent)
    assert main(["kiosk", "--config", str(config), "--looks", "brand.sheer, natural,red-lip"]) == 0
    assert KioskConfig.load(config).looks == [str(brand), "natural", "red-lip"]  # the project found from anywhere
    looks = kiosk_looks(KioskConfig.load(config))
    open_look_projects(looks)
    assert [(k.key, k.label) for k in looks] == [("project", BRAND), ("natural", "Natural"), ("red-lip", "Red Lip")]
    assert main(["kiosk", "--config", str(config), "--looks", ""]) == 0
    assert [k.key for k in kiosk_looks(KioskConfig.load(config))] == ["natural", "evening", "red-lip", "bare"]
    capsys.readouterr()
    assert main(["kiosk", "--config", str(config), "--looks", "natural,glitter"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "'glitter' is neither a built-in look" in err, err
    assert KioskConfig.load(config).looks == []  # nothing changed


def test_a_corrupt_project_is_one_line_and_status_2_before_the_kiosk_starts(brand: Path, tmp_path: Path) -> None:
    """``--project``, a project listed in the configuration, and ``--looks``: the file and what is wrong, exit 2,
    before the display check (this process has no display: the line is about the project, not the display)."""
    text = tmp_path / "brand-notes.sheer"
    text.write_text("this is not a project\n", encoding="utf-8")
    config = write_config(tmp_path / "kiosk.json")
    done = sheer_without_display("kiosk", "--config", str(config), "--project", text.name, cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and str(text) in lines[0] and "not a Sheer project" in lines[0], done.stderr
    assert "display" not in done.stderr and "Traceback" not in done.stderr

    listed = write_config(tmp_path / "listed.json", looks=["natural", str(text)])
    done = sheer_without_display("kiosk", "--config", str(listed), cwd=tmp_path)
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1, done.stderr
    assert f"{listed}: looks[1]: {text}: not a Sheer project" in lines[0], lines[0]

    missing = write_config(tmp_path / "missing.json", looks=["gone.sheer"])
    done = sheer_without_display("kiosk", "--config", str(missing), cwd=tmp_path)
    assert done.returncode == 2 and f"{tmp_path / 'gone.sheer'}: no such project file" in done.stderr, done.stderr

    done = sheer_without_display("kiosk", "--config", str(config), "--looks", f"{brand},{text}", cwd=tmp_path)
    assert done.returncode == 2 and f"--looks[1]: {text}: not a Sheer project" in done.stderr, done.stderr
    assert "looks" not in json.loads(config.read_text(encoding="utf-8"))  # nothing was saved

    # the same configuration without the bad project gets as far as the display check
    done = sheer_without_display("kiosk", "--config", str(config), "--project", str(brand), cwd=tmp_path)
    assert done.returncode == 2 and "no display" in done.stderr, done.stderr


def _drive(kiosk: Any, qtbot: Any, project: Any, seen: dict[str, Any]) -> None:
    """What the test looks at on the running kiosk, recorded in ``seen``."""
    from app.session import Session

    qtbot.waitUntil(lambda: kiosk.isVisible() and kiosk.viewport.frames > 0, timeout=60000)
    bar = kiosk.looks_bar.layout()
    seen["buttons"] = [bar.itemAt(i).widget().text() for i in range(bar.count())]
    seen["checked"] = [b.text() for b in kiosk.look_buttons.values() if b.isChecked()]
    seen["first_look"] = kiosk.look
    seen["layers"] = [(lay.name, lay.material) for lay in kiosk.doc.layers]
    seen["maps_equal"] = all(np.array_equal(lay.thickness, pl.thickness)
                             for lay, pl in zip(kiosk.doc.layers, project.layers, strict=True))
    # the attract mode's cycle: the brand's look, the configured one, and the brand's again
    cycle = [kiosk.look]
    for _ in range(2):
        qtbot.waitUntil(lambda: kiosk.look != cycle[-1], timeout=10000)
        cycle.append(kiosk.look)
    seen["cycle"] = cycle
    # a shopper chooses it again after another look
    kiosk.show_main()
    kiosk.look_buttons["red-lip"].click()
    seen["after_red_lip"] = [lay.name for lay in kiosk.doc.layers]
    kiosk.look_buttons["project"].click()
    seen["chosen_again"] = (kiosk.look, [(lay.name, lay.material) for lay in kiosk.doc.layers],
                            all(np.array_equal(lay.thickness, pl.thickness)
                                for lay, pl in zip(kiosk.doc.layers, project.layers, strict=True)))
    # on her face (a face of her own: here a second document of the sample head) the look is carried over
    stock_layers = [np.array(lay.thickness) for lay in kiosk.stock_doc.layers]
    kiosk.wear_shopper(Session.open(resolution=512, look="red-lip", library=kiosk.library))
    kiosk.look_buttons["red-lip"].click()
    kiosk.look_buttons["project"].click()
    seen["her_face"] = (kiosk.doc is not kiosk.stock_doc, [(lay.name, lay.material) for lay in kiosk.doc.layers],
                        min(float(lay.thickness.max()) for lay in kiosk.doc.layers))
    seen["stock_unchanged"] = all(np.array_equal(a, lay.thickness)
                                  for a, lay in zip(stock_layers, kiosk.stock_doc.layers, strict=True))
    kiosk.unwear_shopper()
    kiosk.close_without_pin()


@pytest.mark.qt
@pytest.mark.gl
def test_sheer_kiosk_project_is_the_first_look_in_the_attract_cycle_and_can_be_chosen_again(
        qapp: object, qtbot: Any, brand: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication

    from app.kiosk.window import KioskWindow
    from project.io import open_project

    project = open_project(brand)
    config = write_config(tmp_path / "kiosk.json", looks=["red-lip"], look_seconds=2.0, idle_seconds=600)
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    monkeypatch.delenv("SHEER_KIOSK_LOG", raising=False)
    monkeypatch.setattr(sys, "excepthook", sys.excepthook)  # the kiosk installs its own
    seen: dict[str, Any] = {}
    failures: list[BaseException] = []

    def run() -> None:
        kiosk = next(w for w in QApplication.topLevelWidgets() if isinstance(w, KioskWindow) and w.isVisible())
        try:
            _drive(kiosk, qtbot, project, seen)
        except BaseException as exc:  # reported after the event loop; the kiosk must still close
            failures.append(exc)
            kiosk.close_without_pin()

    QTimer.singleShot(0, run)
    status = main(["kiosk", "--config", str(config), "--project", str(brand), "--windowed"])
    if failures:
        raise failures[0]
    assert status == 0
    names = [(pl.name, pl.material) for pl in project.layers]
    assert seen["buttons"] == [BRAND, "Red Lip"] and seen["checked"] == [BRAND]
    assert seen["first_look"] == "project" and seen["layers"] == names and seen["maps_equal"]
    assert seen["cycle"] == ["project", "red-lip", "project"]
    assert seen["after_red_lip"] != [n for n, _ in names]
    assert seen["chosen_again"] == ("project", names, True)
    hers, her_layers, faintest = seen["her_face"]
    assert hers and her_layers == names and faintest > 0 and seen["stock_unchanged"]
    # where it logs: said as it starts, and the file is there
    log = tmp_path / "state" / "sheer" / "kiosk.log"
    assert f"sheer kiosk: logging to {log}" in capsys.readouterr().out
    text = log.read_text(encoding="utf-8")
    assert "kiosk: starting" in text and f"looks {BRAND}, Red Lip" in text
