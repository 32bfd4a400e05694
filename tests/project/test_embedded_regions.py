"""A self-contained project of the sample head (its files embedded) paints with the very region masks of
the same project with the head by path (issue #16): the shipped region file records its mesh's digest and
an embedded head of that mesh reads it, instead of deriving its own (slightly different) regions."""

from __future__ import annotations

import io

import numpy as np
import pytest

from painting import Document, LayerMask
from painting.region_shapes import regions_for, shipped_regions_file
from painting.regions import mesh_digest, regions_file, stored_mesh
from project.document import document_from_project, project_from_document
from project.heads import make_head_ref
from project.io import project_bytes, read_project
from tests.project.layers import masked_lipstick


@pytest.fixture(scope="module")
def doc() -> Document:
    return Document.from_head(None, resolution=256)


def test_embedded_sample_head_masks_equal_the_head_by_path(doc: Document) -> None:
    from painting.head import find_sidecar

    lay = masked_lipstick(doc, LayerMask((("union", "lips"), ("union", "lash_line")), feather_mm=0.5))
    try:
        by_path = project_from_document(doc, name="by path")
        embedded = project_from_document(doc, name="embedded", head=make_head_ref(None, embed=True))
        docs = [document_from_project(read_project(io.BytesIO(project_bytes(p, self_contained=contained)),
                                                   name=f"{p.name}.sheer"))
                for p, contained in ((by_path, False), (embedded, True))]
        a, b = docs
        assert a.head.path.parent.name != "<embedded>" and b.head.path.parent.name == "<embedded>"
        # the same mesh: the embedded head finds the shipped file by its digest
        digest = mesh_digest(b.head.vertices, b.head.faces, b.head.uv)
        assert digest == mesh_digest(a.head.vertices, a.head.faces, a.head.uv)
        shipped = regions_file(find_sidecar(a.head.path))
        assert shipped_regions_file(digest) == shipped and stored_mesh(shipped) == digest
        assert b.regions.names() == a.regions.names()
        for name in a.regions.names():
            assert np.array_equal(a.regions.get(name).mask, b.regions.get(name).mask), name
        ma, mb = a.mask_values(a.layers[0]), b.mask_values(b.layers[0])
        assert ma is not None and mb is not None
        assert np.array_equal(ma.view(np.uint32), mb.view(np.uint32))
        assert np.array_equal(mb.view(np.uint32), doc.mask_values(lay).view(np.uint32))
    finally:
        doc.remove_layer(lay)


def test_an_embedded_head_of_another_mesh_derives_its_own(doc: Document) -> None:
    """A changed mesh (one vertex moved) matches no shipped file: its regions are derived (on the atlas)."""
    from dataclasses import replace

    from painting.head import EMBEDDED_FOLDER

    v = np.array(doc.head.vertices)
    v[0, 0] += 1e-3
    other = replace(doc.head, vertices=v, path=EMBEDDED_FOLDER / doc.head.path.name)
    assert shipped_regions_file(mesh_digest(other.vertices, other.faces, other.uv)) is None
    regions = regions_for(other)  # without an atlas nothing can be derived: said per region
    assert not regions.regions and set(regions.missing.values()) == {"no atlas to derive them on"}
