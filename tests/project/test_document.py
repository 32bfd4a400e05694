"""Project ↔ painting.Document: save a painted document, open it again, maps bit-exact."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bench.fuzz import sample_project, tiny_material, write_tiny_head
from project.document import document_from_project, project_from_document
from project.errors import ProjectError
from project.heads import make_head_ref
from project.io import new_project, open_project, save_project


def _document(tmp_path: Path):
    from painting.document import Document
    from painting.head import load_head
    from project.document import project_library

    mesh = write_tiny_head(tmp_path / "head")
    base = sample_project(64, 2, embedded=False)
    base.head = make_head_ref(mesh)
    doc = Document(load_head(mesh), library=project_library(base), resolution=64, cache=False)
    return doc, base


def test_document_round_trip_is_bit_exact(tmp_path: Path) -> None:
    doc, base = _document(tmp_path)
    a = doc.add_layer("Foundation F", name="base")
    doc.fill(a, 12.5)
    b = doc.add_layer("Blush B", name="cheeks", resolution=128, max_thickness=30.0)
    doc.fill(b, 7.25)
    doc.set_layer(b, opacity=0.4, visible=False)
    project = project_from_document(doc, name="painted", lights=base.lights, camera=base.camera)
    assert project.layout is not None and project.layout["source"] == doc.layout.source
    assert set(project.materials) == {"Foundation F", "Blush B"}
    path = tmp_path / "painted.sheer"
    save_project(project, path)
    reopened = open_project(path)
    assert reopened.same_as(project)
    doc2 = document_from_project(reopened, cache=False)
    assert [(x.name, x.material, x.resolution, x.visible, x.opacity, x.max_thickness_um) for x in doc2.layers] == \
        [(x.name, x.material, x.resolution, x.visible, x.opacity, x.max_thickness_um) for x in doc.layers]
    for x, y in zip(doc.layers, doc2.layers):
        assert x.thickness.dtype == y.thickness.dtype == np.float32
        assert np.array_equal(x.thickness.view(np.uint32), y.thickness.view(np.uint32))
    assert not doc2.can_undo  # opening is not an edit
    again = project_from_document(doc2, base=reopened)
    assert again.same_as(reopened) and again.camera == base.camera


def test_a_changed_paint_layout_is_refused(tmp_path: Path) -> None:
    doc, _ = _document(tmp_path)
    doc.fill(doc.add_layer("Foundation F"), 5.0)
    project = project_from_document(doc)
    project.layout = {"source": "xatlas", "sha256": "0" * 64}
    save_project(project, tmp_path / "p.sheer")
    with pytest.raises(ProjectError, match="paint layout changed"):
        document_from_project(open_project(tmp_path / "p.sheer"), cache=False)


def test_self_contained_sample_head_document(tmp_path: Path) -> None:
    """The sample head embedded: the document is rebuilt from the zip alone."""
    from core.assets import AssetNotFoundError

    try:
        project = new_project("portable", resolution=64)
    except AssetNotFoundError:
        pytest.skip("sample assets not available")
    project.materials["Foundation F"] = tiny_material()
    path = tmp_path / "portable.sheer"
    save_project(project, path, self_contained=True)
    doc = document_from_project(open_project(path), cache=False)
    assert doc.head.path == Path("<embedded>") / "head.glb" and doc.head.albedo is not None
    doc.fill(doc.add_layer("Foundation F"), 3.0)
    painted = project_from_document(doc, base=open_project(path))
    assert painted.head.embedded
    save_project(painted, path)
    again = document_from_project(open_project(path), cache=False)
    assert np.array_equal(again.layers[0].thickness, doc.layers[0].thickness)


def test_autosaver_watches_the_document(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from project.recovery import Autosaver, find_recovery, recover

    monkeypatch.setenv("SHEER_RECOVERY_DIR", str(tmp_path / "recovery"))
    doc, base = _document(tmp_path)
    now = [0.0]
    path = tmp_path / "p.sheer"
    saver = Autosaver(lambda: project_from_document(doc, base=base), path, interval_s=60, clock=lambda: now[0])
    unsubscribe = saver.watch(doc)
    now[0] = 100.0
    assert saver.tick() is None  # nothing painted yet
    layer = doc.add_layer("Foundation F")
    doc.fill(layer, 4.0)
    assert saver.dirty
    written = saver.tick()
    assert written is not None and find_recovery(path) is not None
    recovered = recover(find_recovery(path))
    assert np.array_equal(recovered.layers[0].thickness, layer.thickness)
    unsubscribe()
    saver.close()
    assert find_recovery(path) is None
