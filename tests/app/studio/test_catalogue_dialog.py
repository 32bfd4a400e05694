"""File → Render Catalogue…: the dialog checks a spec, renders it in the background on a real LocalCluster,
and its progress dialog's Cancel stops the run (what was rendered stays; Render again finishes it)."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import pytest

from app.qt_compat import pin_singletons
from tests.catalogue.conftest import SMALL

if TYPE_CHECKING:
    from pathlib import Path

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl]


def test_render_catalogue_action_is_in_the_file_menu() -> None:
    from app.actions import STUDIO_ACTIONS

    spec = next(s for s in STUDIO_ACTIONS if s.id == "file.render_catalogue")
    assert (spec.menu, spec.title) == ("File", "Render &Catalogue…")


def test_dialog_checks_renders_and_cancels(qtbot: object, tmp_path: Path) -> None:
    from PySide6.QtWidgets import QApplication, QProgressDialog, QPushButton

    from app.studio.catalogue_dialog import CatalogueDialog

    dialog = CatalogueDialog()
    qtbot.addWidget(dialog)  # type: ignore[attr-defined]
    bad = tmp_path / "bad.toml"
    bad.write_text(SMALL.replace("{extra}", "").replace("{lights}", "").replace("red-lip", "nope"))
    dialog.spec_edit.setText(str(bad))
    assert not dialog.check()
    assert "looks[0].look: unknown look 'nope'" in dialog.status.text()

    spec = tmp_path / "spec.toml"
    views = "\n".join(f"[[views]]\nname = \"v{k}\"\nyaw = {k * 10}" for k in range(4))
    spec.write_text(SMALL.replace("{extra}", "").replace("{lights}", "").replace("[[views]]\nname = \"front\"", views))
    out = tmp_path / "out"
    dialog.spec_edit.setText(str(spec))
    dialog.out_edit.setText(str(out))
    dialog.workers.setValue(1)
    assert dialog.check() and "16 outputs (48×48, fast), 0 already rendered" in dialog.status.text()

    def cancel_when_shown() -> bool:  # the user presses the progress dialog's Cancel
        boxes = [w for w in QApplication.topLevelWidgets() if isinstance(w, QProgressDialog) and w.isVisible()]
        for box in boxes:
            box.findChild(QPushButton).click()
        return bool(boxes)

    dialog.start()
    qtbot.waitUntil(cancel_when_shown, timeout=60000)  # type: ignore[attr-defined]
    qtbot.waitUntil(lambda: dialog.render_button.isEnabled(), timeout=60000)  # type: ignore[attr-defined]
    assert dialog.status.text().startswith("Cancelled"), dialog.status.text()
    assert dialog.result is None
    dialog.start()
    qtbot.waitUntil(lambda: dialog.result is not None, timeout=60000)  # type: ignore[attr-defined]
    result = dialog.result
    assert result.failed == [] and result.rendered + result.skipped == 16
    assert "rendered" in dialog.status.text() and "manifest.json" in dialog.status.text()
    manifest = json.loads((out / "manifest.json").read_text())
    assert len(manifest["images"]) == 16 and all((out / e["file"]).is_file() for e in manifest["images"])
