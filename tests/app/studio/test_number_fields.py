"""The studio's number fields under a decimal-comma locale (German, set with ``QLocale.setDefault``: no system
locale needed), with real widgets under Xvfb: what the user types is the number saved."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest
from PySide6.QtCore import QLocale

from tests.app.studio.studio_input import type_into

if TYPE_CHECKING:
    from collections.abc import Iterator

pytestmark = [pytest.mark.qt]


@pytest.fixture
def german(qapp: Any) -> Iterator[QLocale]:
    """German as the default locale of the widgets made in the test (decimal comma, "." between thousands)."""
    before = QLocale()
    QLocale.setDefault(QLocale(QLocale.Language.German, QLocale.Country.Germany))
    yield QLocale()
    QLocale.setDefault(before)


def _typed(qtbot: Any, field: Any, text: str) -> None:
    """Select the field's text, type ``text`` as it is (no decimal point translated) and press Enter."""
    from PySide6.QtCore import Qt

    field.lineEdit().selectAll()
    qtbot.keyClicks(field.lineEdit(), text)
    qtbot.keyClick(field, Qt.Key.Key_Return)


@pytest.mark.parametrize(("typed", "value", "shown"), [
    ("0,35", 0.35, "0,35 µm"),          # the locale's own decimal comma
    ("0.35", 0.35, "0,35 µm"),          # a decimal point: before, 35 (read as a thousands separator)
    ("12.5", 12.5, "12,50 µm"),
    ("1.234,5", 1234.5, "1234,50 µm"),  # a German number with its thousands separator
    ("1.500", 1500.0, "1500,00 µm"),
    ("0.3.5", 0.35, "0,35 µm"),         # the second "." is refused as it is typed (before: 35)
])
def test_a_number_field_reads_what_a_german_user_types(german: QLocale, qtbot: Any, typed: str, value: float,
                                                       shown: str) -> None:
    from app.studio.number_fields import NumberField

    field = NumberField()
    field.setRange(0.1, 10000.0)
    field.setSuffix(" µm")
    qtbot.addWidget(field)
    field.show()
    assert field.locale().decimalPoint() == ","
    _typed(qtbot, field, typed)
    assert field.value() == pytest.approx(value) and field.text() == shown


def test_the_library_dock_saves_the_number_typed_in_a_german_locale(german: QLocale, qtbot: Any,
                                                                     tmp_path: Path) -> None:
    import km
    from app.studio.library_dock import LibraryDock
    from painting import Document
    from tests.painting.helpers import sample_head, sample_layout

    doc = Document(sample_head(), sample_layout(), library=km.default_library(), resolution=256)
    dock = LibraryDock(doc, (0.5, 0.4, 0.3))
    qtbot.addWidget(dock)
    dock.show()
    dock.select("Lipstick Nude")
    type_into(qtbot, dock.spins["roughness"], "0.35")  # typed with the locale's comma: "0,35"
    assert doc.library.get("Lipstick Nude").roughness == pytest.approx(0.35)
    _typed(qtbot, dock.spins["ior"], "1.45")  # typed with a point (before: 145, the field's maximum 3)
    assert doc.library.get("Lipstick Nude").ior == pytest.approx(1.45)
    saved = dock.save(tmp_path / "library.json")
    assert saved is not None
    data = json.loads(Path(saved).read_text(encoding="utf-8"))
    nude = next(m for m in data["materials"] if m["name"] == "Lipstick Nude")
    assert (nude["roughness"], nude["ior"]) == (0.35, 1.45)  # the same floats in every locale


def test_every_studio_number_field_is_a_number_field() -> None:
    studio = Path(__file__).resolve().parents[3] / "app" / "studio"
    plain = [f"{p.name}:{n}" for p in sorted(studio.glob("*.py")) if p.name != "number_fields.py"
             for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
             if re.search(r"QDoubleSpinBox\(", line)]
    assert plain == []  # a plain QDoubleSpinBox reads "0.35" as 35 in German
