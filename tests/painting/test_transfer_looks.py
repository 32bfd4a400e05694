"""Built-in looks on another head: strokes at landmarks and regions replay on any head with a sidecar.

The canonical face-mesh head is what a captured face is (same topology, same UVs, its own shape): every
built-in look must replay on it, paint every layer, and keep the lipstick on its lips — with its
regions read from the shipped file, and derived from its contours when there is no file.
"""

from __future__ import annotations

import shutil
from typing import TYPE_CHECKING

import numpy as np
import pytest

from painting.document import Document
from painting.looks import BUILTIN_LOOKS, apply_look, load_look

if TYPE_CHECKING:
    from pathlib import Path

RES = 256


def _canonical_mesh() -> Path:
    from core.assets import find_asset

    return find_asset("heads/canonical-face/canonical_face_model.obj")


@pytest.fixture(scope="module", params=["shipped regions", "derived regions"])
def face_head(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> object:
    from core.assets import resource_path
    from painting.head import load_head

    if request.param == "shipped regions":
        return load_head(_canonical_mesh())
    folder = tmp_path_factory.mktemp("face")  # the same mesh and sidecar, no regions file beside it
    mesh = folder / "face.obj"
    shutil.copyfile(_canonical_mesh(), mesh)
    shutil.copyfile(resource_path("heads", "canonical-face.json"), folder / "face.obj.sheer-head.json")
    return load_head(mesh)


@pytest.mark.parametrize("name", [n for n in BUILTIN_LOOKS if n != "bare"])
def test_every_builtin_look_replays_on_a_face_mesh_head(face_head: object, name: str) -> None:
    import km

    doc = Document(face_head, library=km.default_library(), resolution=RES)  # type: ignore[arg-type]
    look = load_look(name)
    layers = apply_look(doc, look)
    assert [lay.name for lay in layers] == [lay.name or lay.material for lay in look.layers]
    cov = doc.atlas_at(RES).coverage
    for lay in layers:
        painted = np.asarray(lay.effective_thickness() if lay.has_mask else lay.thickness)
        assert float(painted[cov].max()) > 0.5, (name, lay.name)  # every layer paints something
    lips = doc.region_values("lips", RES) > 0
    for lay in layers:
        if lay.name == "Lipstick":
            t = np.asarray(lay.effective_thickness())
            assert float(t[lips].sum() / t.sum()) > 0.95, name  # the lipstick stays on the lips
