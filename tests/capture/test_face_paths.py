"""face.json's files are relative to the face folder, for every reader, from any working directory.

A catalogue spec with ``face = "<folder written by sheer capture>"`` failed (``heads[0]: head.obj: head mesh not
found``) unless run from inside that folder: the catalogue resolved face.json's ``head`` against its own
working directory.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import OpenEXR

from capture.face import load_face, recorded_path
from capture.phong import PhongParams
from core.assets import find_asset

if TYPE_CHECKING:
    import pytest

SHEER = str(Path(sys.executable).with_name("sheer"))


def _face_folder(folder: Path) -> Path:
    """A face folder as the automatic capture writes it: the person's head inside it, named relatively."""
    folder.mkdir(parents=True)
    shutil.copy(find_asset("heads/canonical-face/canonical_face_model.obj"), folder / "head.obj")
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(hdr, {"RGB": np.ones((16, 16, 3), np.float32)}).write(str(folder / "detail.exr"))
    params = PhongParams(diffuse=np.array([0.4, 0.25, 0.18]), specular=0.1, exponent=20.0, ambient_scale=0.0)
    (folder / "face.json").write_text(json.dumps({"schema_version": 1, "phong": params.to_json(),
                                                  "head": "head.obj", "photo": "photo.png"}), "utf-8")
    return folder


def test_a_catalogue_reads_a_face_folder_from_another_working_directory(tmp_path: Path) -> None:
    work = tmp_path / "campaign"
    _face_folder(work / "faces" / "her")
    (work / "spec.toml").write_text('name = "t"\nsize = [64, 64]\n[[heads]]\nface = "faces/her"\n', "utf-8")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    done = subprocess.run([SHEER, "catalogue", str(work / "spec.toml"), "--dry-run", "--out", str(tmp_path / "out")],
                          cwd=elsewhere, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "1 output(s)" in done.stdout and "head mesh not found" not in done.stderr


def test_the_face_names_its_files_inside_its_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = _face_folder(tmp_path / "faces" / "her")
    monkeypatch.chdir(tmp_path / "faces")
    face = load_face("her")
    monkeypatch.chdir(tmp_path)  # a reader that moved on
    assert face.head_path is not None and face.head_path.resolve() == (folder / "head.obj").resolve()
    assert face.photo_path is not None and face.photo_path.resolve() == (folder / "photo.png").resolve()


def test_the_writer_records_inside_relative_and_outside_absolute(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """``sheer capture --head heads/x.obj`` (relative to where it ran) is recorded absolute; the person's own
    head, inside the folder, relative to it (the folder moves as one)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "heads").mkdir()
    folder = tmp_path / "faces" / "her"
    assert recorded_path("heads/x.obj", folder) == str(tmp_path / "heads" / "x.obj")
    assert recorded_path(folder / "head.obj", folder) == "head.obj"
    assert recorded_path("faces/her/sub/head.obj", "faces/her") == "sub/head.obj"
