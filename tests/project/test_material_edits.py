"""One truth for a layer's material: a library edit through the document (painting.document_materials) is
worn by every layer of the material, is one undo step, is what a saved project embeds and what a project
opened into a studio's document wears again (app.project_io.install_layers); a layer edit to the value a
layer already has records nothing."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pytest

from bench.fuzz import sample_project, write_tiny_head
from painting import ChangeEvent, DocumentError

if TYPE_CHECKING:
    from pathlib import Path

    from painting import Document


def _document(tmp_path: Path) -> Document:
    """A document on a one-triangle head whose library (a km.Library) holds two materials."""
    from painting.document import Document
    from painting.head import load_head
    from project.document import project_library

    doc = Document(load_head(write_tiny_head(tmp_path / "head")), library=project_library(sample_project(64, 2)),
                   resolution=64, cache=False)
    doc.fill(doc.add_layer("Foundation F", name="base"), 10.0)
    doc.add_layer("Foundation F", name="second coat")
    doc.add_layer("Blush B", name="cheeks")
    doc.clear_history()
    return doc


def test_a_library_edit_is_worn_by_every_layer_of_it_and_is_one_undo_step(tmp_path: Path) -> None:
    doc = _document(tmp_path)
    events: list[ChangeEvent] = []
    doc.subscribe(events.append)
    old = doc.library.get("Foundation F")
    edited = old.replace(roughness=0.05, K=np.asarray(old.K) * 0.2, thickness_um=12.0)
    doc.replace_material("Foundation F", edited, "roughness of Foundation F")
    base, second, cheeks = doc.layers
    assert doc.library.get("Foundation F") is edited
    assert base.material_object is edited and second.material_object is edited and cheeks.material_object is not edited
    assert base.default_thickness == 12.0 and base.max_thickness == 100.0  # the layer's own maximum stays
    assert [(e.kind, e.layer, e.detail) for e in events] == [
        ("material", base.id, "edited"), ("material", second.id, "edited"), ("library", None, "Foundation F"),
        ("history", None, "")]
    assert len(doc.history) == 1
    doc.undo()
    assert doc.library.get("Foundation F") is old and base.material_object is old and base.default_thickness == 20.0
    doc.redo()
    assert doc.library.get("Foundation F") is edited and second.material_object is edited


def test_a_rename_is_followed_by_the_layers_and_undone(tmp_path: Path) -> None:
    doc = _document(tmp_path)
    names = doc.library.names()
    old = doc.library.get("Blush B")
    doc.replace_material("Blush B", old.replace(name="Rose"))
    assert doc.layers[2].material == "Rose" and doc.library.names() == [n if n != "Blush B" else "Rose" for n in names]
    with pytest.raises(DocumentError, match="already exists"):
        doc.replace_material("Rose", old.replace(name="Foundation F"))
    doc.undo()
    assert doc.layers[2].material == "Blush B" and doc.library.get("Blush B") is old
    assert doc.library.names() == names


def test_adding_and_removing_materials_are_undo_steps_and_a_used_one_stays(tmp_path: Path) -> None:
    doc = _document(tmp_path)
    names = doc.library.names()
    copy = doc.library.get("Blush B").replace(name="Blush B copy")
    doc.add_materials([copy])
    assert doc.library.names() == [*names, "Blush B copy"]
    with pytest.raises(DocumentError, match="already exists"):
        doc.add_materials([copy])
    with pytest.raises(DocumentError, match="used by the layer"):
        doc.remove_material("Blush B")
    doc.remove_material("Blush B copy")
    assert doc.library.names() == names
    doc.undo()
    doc.undo()
    assert doc.library.names() == names and "Blush B copy" not in doc.library


def test_the_saved_project_embeds_the_edited_material_and_opens_wearing_it(tmp_path: Path) -> None:
    from app import project_io
    from project.document import document_from_project, project_from_document
    from project.io import open_project, save_project

    doc = _document(tmp_path)
    old = doc.library.get("Foundation F")
    doc.replace_material("Foundation F", old.replace(roughness=0.05, K=np.asarray(old.K) * 0.2))
    save_project(project_from_document(doc, name="edited"), tmp_path / "edited.sheer")
    project = open_project(tmp_path / "edited.sheer")
    assert project.materials["Foundation F"]["roughness"] == pytest.approx(0.05)
    assert np.allclose(project.materials["Foundation F"]["K"], np.asarray(old.K) * 0.2)
    # what `sheer render --project` draws: the embedded copy
    assert document_from_project(project, cache=False).layers[0].material_object.roughness == pytest.approx(0.05)
    # a studio whose library has the unedited material opens the project wearing the saved one
    studio = _document(tmp_path)
    assert studio.library.get("Foundation F").roughness != pytest.approx(0.05)
    project_io.load_project_into(studio, studio.library, tmp_path / "edited.sheer")
    assert studio.library.get("Foundation F").roughness == pytest.approx(0.05)
    assert all(lay.material_object is studio.library.get(lay.material) for lay in studio.layers)
    assert studio.layers[0].material_object.roughness == pytest.approx(0.05)


def test_setting_a_layer_to_the_values_it_has_records_nothing(tmp_path: Path) -> None:
    doc = _document(tmp_path)
    events: list[ChangeEvent] = []
    doc.subscribe(events.append)
    lay = doc.layers[0]
    doc.set_layer(lay, max_thickness=lay.max_thickness, opacity=lay.opacity, material=lay.material, visible=True)
    assert not doc.can_undo and events == []
    doc.set_layer(lay, max_thickness=60.0, opacity=lay.opacity)
    assert len(doc.history) == 1 and [e.detail for e in events if e.kind == "layers"] == ["max_thickness"]
