"""The inner mouth is never painted, whichever path moved the look (issue "A designer's first hour").

A smiling capture: the canonical face mesh (MediaPipe's topology, the one every captured face has) with its
mouth opened 8 mm, written as a face folder's head by ``capture.person.write_person_head`` (mesh, sidecar,
albedo and the canonical regions). The triangles across its mouth's opening then span the teeth. Before,
the red-lip look transferred from the sample head (``painting.transfer``: ``sheer look transfer``, the
studio's New from Photo, the kiosk) put lipstick on them, where the built-in look replayed on the same
capture (region fills) did not. Now the inner mouth is a region (``inner_mouth``: on a face mesh those
triangles) that no transferred layer paints, and the skin region leaves it out.
"""

from __future__ import annotations

import contextlib
import io
import json
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from painting import Document
from painting.looks import apply_look
from painting.region_shapes import CONTOURS, mouth_opening_faces, mouth_opening_texels
from painting.transfer import transfer_document

if TYPE_CHECKING:
    from pathlib import Path

    from painting.head import Head

RES = 256
OPEN_MM = 8.0


def open_mouth(head: Head, open_mm: float = OPEN_MM) -> Head:
    """``head`` (a face mesh) with its jaw dropped ``open_mm``: the lower lip's inner contour and what lies
    below the mouth move down, fading out 45 mm from the mouth; the landmarks move with the surface."""
    v = np.asarray(head.vertices, float)
    mm = head.mm_per_unit
    lower_inner = v[CONTOURS["lipsLowerInner"]]
    upper_inner = v[CONTOURS["lipsUpperInner"]]
    centre = 0.5 * (upper_inner.mean(axis=0) + lower_inner.mean(axis=0))
    split = 0.5 * (upper_inner[:, 1].mean() + lower_inner[:, 1].mean())

    def drop(p: np.ndarray) -> np.ndarray:
        r = np.linalg.norm((p - centre)[:, :2], axis=1) * mm
        w = np.clip(1.0 - r / 45.0, 0.0, 1.0) ** 0.5 * (p[:, 1] < split)
        out = p.copy()
        out[:, 1] -= w * open_mm / mm
        return out

    moved = drop(v)
    moved[CONTOURS["lipsLowerInner"][1:-1]] = v[CONTOURS["lipsLowerInner"][1:-1]] - [0.0, open_mm / mm, 0.0]
    lms = {k: tuple(float(x) for x in drop(np.asarray([p], float))[0]) for k, p in head.metadata.landmarks.items()}
    return replace(head, vertices=moved, metadata=replace(head.metadata, name="smiling capture", landmarks=lms))


@pytest.fixture(scope="module")
def capture(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A face folder's head whose mouth is open (see the module docstring): its mesh file."""
    from capture.person import CANONICAL_FACE, write_person_head
    from core.assets import find_asset
    from painting.head import load_head

    head = open_mouth(load_head(find_asset(CANONICAL_FACE)))
    folder = tmp_path_factory.mktemp("smiling")
    files = write_person_head(head, folder, np.full((64, 64, 3), (200, 150, 130), np.uint8))
    return files[0]


@pytest.fixture(scope="module")
def red_lip() -> Document:
    doc = Document.from_head(resolution=RES)
    apply_look(doc, "red-lip")
    return doc


def test_the_inner_mouth_is_the_mouth_openings_triangles(capture: Path) -> None:
    doc = Document.from_head(capture, resolution=RES)
    head = doc.head
    faces = mouth_opening_faces(head)
    assert len(faces) == 18
    # the mouth is open: the opening is 8 mm taller at its middle than the canonical face's
    from capture.person import CANONICAL_FACE
    from core.assets import find_asset
    from painting.head import load_head

    v, c = np.asarray(head.vertices), np.asarray(load_head(find_asset(CANONICAL_FACE)).vertices)
    assert ((v[13, 1] - v[14, 1]) - (c[13, 1] - c[14, 1])) * head.mm_per_unit == pytest.approx(OPEN_MM, abs=0.5)
    inner = doc.region_values("inner_mouth", RES) >= 0.5
    opening = mouth_opening_texels(head, (RES, RES)) & doc.atlas_at(RES).coverage
    assert opening.sum() > 20 and np.mean(inner[opening]) >= 0.8  # its edge texels are partly the lips'
    from painting.transfer import inner_mouth_texels

    kept_clear = inner_mouth_texels(doc, RES)  # what a transfer keeps clear
    assert kept_clear is not None and np.array_equal(kept_clear, inner)
    assert "lipsUpperInner" in doc.regions.get("inner_mouth").source
    # the skin region leaves it out (a foundation filled on the skin never covers the teeth)
    assert float(doc.region_values("skin", RES)[inner].max()) <= 0.1  # at most its soft edge


def inner_paint(doc: Document) -> dict[str, float]:
    """Per layer: the largest thickness (µm) on the head's inner mouth."""
    inner = doc.region_values("inner_mouth", RES) >= 0.5
    return {lay.name: float(np.asarray(lay.thickness)[inner].max()) for lay in doc.layers}


def test_a_transferred_look_never_paints_the_inner_mouth(red_lip: Document, capture: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    from painting.head import load_head

    head = load_head(capture)
    moved, report = transfer_document(red_lip, head)
    assert [lay.name for lay in moved.layers] == ["Foundation", "Lipstick"]
    assert inner_paint(moved) == {"Foundation": 0.0, "Lipstick": 0.0}
    # the lipstick still covers her lips as much as without the inner mouth kept clear (86 % of them at 256²:
    # her lower lip dropped 8 mm, the landmarks' warp follows it only in part)
    lips = moved.region_values("lips", RES) >= 0.95
    covered = float(np.mean(np.asarray(moved.layers[1].thickness)[lips] > 0))
    assert covered >= 0.8
    # the built-in look replayed on the same capture: no paint there either
    # but the lips fill's soft edge (0.5 mm, resampled to 256²): at most a tenth of its 20 µm
    replayed = Document(head, resolution=RES)
    apply_look(replayed, "red-lip")
    assert max(inner_paint(replayed).values()) <= 4.0
    inside = replayed.region_values("inner_mouth", RES) >= 0.95
    assert inside.sum() > 10
    assert max(float(np.asarray(lay.thickness)[inside].max()) for lay in replayed.layers) <= 2.0
    # the defect this guards against: without the inner mouth, the correspondence puts lipstick on the teeth
    import painting.transfer as transfer

    monkeypatch.setattr(transfer, "inner_mouth_texels", lambda target, resolution: None)
    before, _ = transfer_document(red_lip, head)
    print("lipstick on the inner mouth: without the region", inner_paint(before)["Lipstick"], "µm, with it 0")
    assert inner_paint(before)["Lipstick"] >= 5.0
    assert float(np.mean(np.asarray(before.layers[1].thickness)[lips] > 0)) == pytest.approx(covered, abs=0.01)


def test_a_face_folder_from_before_the_region_is_protected_too(red_lip: Document, capture: Path,
                                                              tmp_path: Path) -> None:
    """A face folder captured before the region existed (its regions file without ``inner_mouth``): the
    mouth opening's triangles, from the topology, are kept clear all the same."""
    import shutil

    from painting.head import load_head
    from painting.regions import decode_regions, encode_regions, regions_file

    folder = tmp_path / "old-face"
    shutil.copytree(capture.parent, folder)
    sidecar = folder / (capture.name + ".sheer-head.json")
    path = regions_file(sidecar)
    old = decode_regions(path.read_bytes(), str(path))
    del old.regions["inner_mouth"]
    path.write_bytes(encode_regions(old))
    moved, _ = transfer_document(red_lip, load_head(folder / capture.name))
    assert "inner_mouth" not in moved.regions.names()
    opening = mouth_opening_texels(moved.head, (RES, RES))
    assert float(np.asarray(moved.layers[1].thickness)[opening].max()) == 0.0


def test_sheer_look_transfer_keeps_the_inner_mouth_clear(capture: Path, tmp_path: Path) -> None:
    """The command line's path: ``sheer project new --look red-lip``, then ``sheer look transfer`` onto the
    smiling capture's head; the saved project's layers are clear on its inner mouth."""
    from app.cli import main
    from project import document_from_project, open_project

    def sheer(*args: str) -> tuple[int, str]:
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(list(args))
        return code, out.getvalue() + err.getvalue()

    src, dst = tmp_path / "red-lip.sheer", tmp_path / "on-her.sheer"
    code, text = sheer("project", "new", "--out", str(src), "--look", "red-lip", "--resolution", str(RES))
    assert code == 0, text
    code, text = sheer("look", "transfer", "--project", str(src), "--head", str(capture), "--out", str(dst))
    assert code == 0, text
    doc: Any = document_from_project(open_project(dst))
    assert max(inner_paint(doc).values()) == 0.0
    assert json.loads(json.dumps(inner_paint(doc))) == {"Foundation": 0.0, "Lipstick": 0.0}
