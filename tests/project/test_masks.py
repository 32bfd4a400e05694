"""Layer masks in the .sheer format (schema_version 3): saved and reopened identical, an old (version 2)
file written by the previous Sheer opens unchanged with no masks, and bad masks are refused by name."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

from painting import Brush, Document, LayerMask
from project.document import document_from_project, project_from_document
from project.errors import ProjectError
from project.io import open_project, project_bytes, read_project
from project.migrations import SCHEMA_VERSION
from tests.project.layers import masked_lipstick

DATA = Path(__file__).resolve().parents[1] / "data" / "project"


@pytest.fixture(scope="module")
def doc() -> Document:
    return Document.from_head(None, resolution=128)


def test_a_project_with_masks_reopens_identical(doc: Document) -> None:
    lay = masked_lipstick(doc, LayerMask((("union", "lips"), ("subtract", "lip_line")), feather_mm=0.5))
    with doc.mask_stroke(lay, Brush(radius_mm=5.0, mode="erase")) as s:
        s.dab(doc.head.metadata.landmarks["lower_lip"])
    plain = doc.add_layer("Foundation Beige", name="Foundation")
    project = project_from_document(doc, name="masks")
    blob = project_bytes(project)
    names = zipfile.ZipFile(io.BytesIO(blob)).namelist()
    assert "masks/000.exr" in names and not any(n.startswith("masks/001") for n in names)
    back = read_project(io.BytesIO(blob), name="masks.sheer")
    assert back.same_as(project)
    reopened = document_from_project(back)
    a, b = reopened.layers
    assert a.mask == lay.mask and b.mask is None and b.mask_channel is None
    assert np.array_equal(a.mask_channel.view(np.uint32), lay.mask_channel.view(np.uint32))
    assert np.array_equal(reopened.mask_values(a).view(np.uint32), doc.mask_values(lay).view(np.uint32))
    assert not reopened.can_undo  # opening is not an edit
    doc.remove_layer(plain)
    doc.remove_layer(lay)


def test_an_old_file_opens_unchanged_with_no_masks() -> None:
    path = DATA / "schema-v2.sheer"  # written by Sheer before masks (schema_version 2)
    raw = json.loads(zipfile.ZipFile(path).read("project.json"))
    assert raw["schema_version"] == 2 and "mask" not in raw["layers"][0]
    project = open_project(path)
    assert project.source_schema_version == 2 and SCHEMA_VERSION >= 3
    assert [layer.mask for layer in project.layers] == [None]
    assert project.layers[0].mask_channel is None and project.layers[0].thickness.max() > 10.0
    doc = document_from_project(project)
    assert not doc.layers[0].has_mask
    # saved again it is a version-3 file with "mask": null, and the same maps
    again = read_project(io.BytesIO(project_bytes(project)), name="again.sheer")
    assert again.same_as(project)


def _with_mask(blob: bytes, mask: object) -> bytes:
    src = zipfile.ZipFile(io.BytesIO(blob))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as dst:
        for info in src.infolist():
            data = src.read(info.filename)
            if info.filename == "project.json":
                doc = json.loads(data)
                doc["layers"][0]["mask"] = mask
                data = json.dumps(doc).encode()
            dst.writestr(info, data)
    return out.getvalue()


def test_bad_masks_are_refused_by_name(doc: Document) -> None:
    lay = doc.add_layer("Lipstick Classic Red", name="Lipstick")
    blob = project_bytes(project_from_document(doc, name="m"))
    doc.remove_layer(lay)
    bad_region = _with_mask(blob, {"regions": [["union", "lipz"]], "invert": False, "feather_mm": 0, "channel": None})
    project = read_project(io.BytesIO(bad_region), name="m.sheer")
    with pytest.raises(ProjectError, match="layer 'Lipstick'.*unknown region 'lipz'"):
        document_from_project(project)
    bad_op = _with_mask(blob, {"regions": [["xor", "lips"]], "invert": False, "feather_mm": 0, "channel": None})
    with pytest.raises(ProjectError, match=r"layers\[0\]\.mask\.regions\[0\]"):
        read_project(io.BytesIO(bad_op), name="m.sheer")
    missing = _with_mask(blob, {"regions": [], "invert": False, "feather_mm": 0,
                                "channel": {"map": "masks/000.exr", "sha256": "0" * 64}})
    with pytest.raises(ProjectError, match="missing entry 'masks/000.exr'"):
        read_project(io.BytesIO(missing), name="m.sheer")
