"""The .sheer format: round trips (maps bit-exact), self-contained projects, the schema, the commands."""

from __future__ import annotations

import json
import shutil
import zipfile
from typing import TYPE_CHECKING

import numpy as np
import pytest

from bench.fuzz import sample_project, write_tiny_head
from project.container import SafeZipReader
from project.errors import HeadChecksumError, HeadMissingError, ProjectError
from project.heads import make_head_ref
from project.io import open_project, project_bytes, project_json, save_project
from project.model import MIMETYPE, ProjectLayer
from project.schema import schema, validate_json

if TYPE_CHECKING:
    from pathlib import Path


def _on_disk_project(tmp_path: Path, side: int = 64):
    """A project whose head is a real (tiny) file in tmp_path/headdir."""
    mesh = write_tiny_head(tmp_path / "headdir")
    project = sample_project(side, 3, seed=3, embedded=False)
    project.head = make_head_ref(mesh)
    return project


def test_round_trip_is_identical_and_maps_bit_exact(tmp_path: Path) -> None:
    project = _on_disk_project(tmp_path)
    # awkward float32 values must survive exactly: denormals, the largest allowed value, tiny steps
    project.layers[0].thickness[0, :4] = [np.float32(1e-45), np.float32(9999.999), np.float32(0.1), 0.0]
    path = tmp_path / "look.sheer"
    save_project(project, path)
    loaded = open_project(path)
    exr = [(a, b) for a, b in zip(project.layers, loaded.layers) if a.encoding == "exr-float32"]
    assert exr and all(a.same_as(b) for a, b in exr)
    for a, b in zip(project.layers, loaded.layers):
        assert b.thickness.dtype == np.float32 and b.thickness.shape == (64, 64)
        if a.encoding == "png16":  # quantised: within half a step of the scale
            step = float(a.thickness.max()) / 65535
            assert np.max(np.abs(a.thickness - b.thickness)) <= step * 0.5 + 1e-6
    assert loaded.materials == project.materials and loaded.lights == project.lights
    assert loaded.camera == project.camera and loaded.look == project.look
    assert loaded.head.files == project.head.files and loaded.head.mesh_path == project.head.mesh_path
    # a second round trip of the loaded project is bit-identical to the first file
    save_project(loaded, tmp_path / "again.sheer")
    assert open_project(tmp_path / "again.sheer").same_as(loaded)


def test_all_exr_project_round_trips_exactly(tmp_path: Path) -> None:
    project = _on_disk_project(tmp_path)
    for layer in project.layers:
        layer.encoding = "exr-float32"
    save_project(project, tmp_path / "a.sheer")
    assert open_project(tmp_path / "a.sheer").same_as(project)


def test_saving_is_deterministic_and_mimetype_first() -> None:
    project = sample_project(64, 2)
    a = project_bytes(project, self_contained=True)
    assert a == project_bytes(project, self_contained=True)
    import io

    with zipfile.ZipFile(io.BytesIO(a)) as zf:
        first = zf.infolist()[0]
        assert first.filename == "mimetype" and first.compress_type == zipfile.ZIP_STORED
        assert zf.read("mimetype") == MIMETYPE.encode()
        names = zf.namelist()
    assert names[1] == "project.json" and "layers/000.exr" in names and "layers/001.png" in names
    assert "head/head.obj" in names


def test_self_contained_project_opens_without_the_original_head(tmp_path: Path) -> None:
    project = _on_disk_project(tmp_path)
    path = tmp_path / "portable.sheer"
    save_project(project, path, self_contained=True)
    shutil.rmtree(tmp_path / "headdir")  # "another machine": the head is gone
    moved = tmp_path / "elsewhere" / "portable.sheer"
    moved.parent.mkdir()
    path.rename(moved)
    loaded = open_project(moved)
    assert loaded.head.embedded and loaded.head.mesh_path is None
    assert set(loaded.head.data or {}) == {"head.obj", "head.obj.sheer-head.json"}
    assert all(a.encoding != "exr-float32" or a.same_as(b) for a, b in zip(project.layers, loaded.layers))
    # saving it again keeps it self-contained
    save_project(loaded, moved)
    assert open_project(moved).head.embedded


def test_self_contained_sample_head_loads_in_memory(tmp_path: Path) -> None:
    from core.assets import AssetNotFoundError

    try:
        ref = make_head_ref(None, embed=True)
    except AssetNotFoundError:
        pytest.skip("sample assets not available")
    from painting.head import load_head_from_bytes

    assert ref.data is not None
    head = load_head_from_bytes(ref.data, ref.mesh)
    assert head.faces.shape[1] == 3 and head.uv.shape == (len(head.vertices), 2)
    assert head.albedo is not None and head.mm_per_unit > 0


def test_referenced_head_changed_or_missing_is_a_relinkable_error(tmp_path: Path) -> None:
    project = _on_disk_project(tmp_path)
    path = tmp_path / "p.sheer"
    save_project(project, path)
    mesh = tmp_path / "headdir" / "head.obj"
    mesh.write_bytes(mesh.read_bytes() + b"# edited\n")
    with pytest.raises(HeadChecksumError) as info:
        open_project(path)
    assert "head.obj" in str(info.value) and "changed" in str(info.value)
    assert info.value.file == "head.obj" and info.value.expected != info.value.actual
    accepted = open_project(path, accept_head_change=True)
    assert accepted.head.files["head.obj"] == info.value.actual
    # relink to a copy elsewhere (with the original bytes)
    other = write_tiny_head(tmp_path / "moved", "face.obj")
    relinked = open_project(path, head_path=other)
    assert relinked.head.mesh_path == other and relinked.head.mesh == "face.obj"
    shutil.rmtree(tmp_path / "headdir")
    with pytest.raises(HeadMissingError, match="not found"):
        open_project(path)


def test_head_path_is_stored_relative_to_the_project(tmp_path: Path) -> None:
    project = _on_disk_project(tmp_path)
    save_project(project, tmp_path / "p.sheer")
    with SafeZipReader(tmp_path / "p.sheer") as zf:
        doc = json.loads(zf.read("project.json"))
    assert doc["head"]["path"] == "headdir/head.obj"
    # moving project and head together keeps it working
    shutil.move(tmp_path, tmp_path.parent / (tmp_path.name + "-moved"))
    moved = tmp_path.parent / (tmp_path.name + "-moved")
    assert open_project(moved / "p.sheer").head.mesh_path == (moved / "headdir" / "head.obj").absolute()


def test_schema_agrees_with_what_is_written_and_refused() -> None:
    import jsonschema

    jsonschema.Draft202012Validator.check_schema(schema())
    doc = project_json(sample_project(64, 2), None, True)
    validate_json(doc, "x")  # what we write is valid
    assert set(doc) == set(schema()["required"])
    layer_keys = set(schema()["properties"]["layers"]["items"]["required"])
    assert all(set(layer) == layer_keys for layer in doc["layers"])


def test_save_refuses_a_project_it_could_not_open(tmp_path: Path) -> None:
    project = sample_project(64, 2)
    project.layers[0].thickness[0, 0] = np.nan
    with pytest.raises(ProjectError, match="NaN"):
        save_project(project, tmp_path / "bad.sheer", self_contained=True)
    assert not (tmp_path / "bad.sheer").exists()
    project = sample_project(64, 2)
    project.layers.append(ProjectLayer("x", "No Such Material", np.zeros((64, 64), np.float32)))
    with pytest.raises(ProjectError, match="unknown material 'No Such Material'"):
        save_project(project, tmp_path / "bad.sheer", self_contained=True)
    assert list(tmp_path.iterdir()) == []  # not even a temporary file is left


def test_save_keeps_a_backup(tmp_path: Path) -> None:
    path = tmp_path / "p.sheer"
    first = sample_project(64, 2, name="first")
    save_project(first, path, self_contained=True)
    second = sample_project(64, 2, name="second")
    save_project(second, path, self_contained=True)
    assert open_project(path).name == "second"
    assert open_project(path.with_name("p.sheer.bak")).name == "first"


# ---------------------------------------------------------------------------------------------- commands


def test_cli_new_info_validate_export(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main

    mesh = write_tiny_head(tmp_path / "h")
    out = tmp_path / "new.sheer"
    assert main(["project", "new", "--out", str(out), "--head", str(mesh), "--resolution", "64"]) == 0
    project = open_project(out)
    assert project.look is None and project.layers == [] and project.resolution == 64
    assert main(["project", "new", "--out", str(out), "--head", str(mesh)]) == 2  # exists
    assert main(["project", "validate", str(out)]) == 0
    assert "valid" in capsys.readouterr().out

    full = tmp_path / "full.sheer"
    save_project(sample_project(64, 3), full, self_contained=True)
    assert main(["project", "info", str(full)]) == 0
    text = capsys.readouterr().out
    assert "Layer 0" in text and "Foundation F" in text
    assert main(["project", "info", "--json", str(full)]) == 0
    assert json.loads(capsys.readouterr().out)["resolution"] == 64

    dest = tmp_path / "exported"
    assert main(["project", "export", str(full), "--out", str(dest), "--ora"]) == 0
    manifest = json.loads((dest / "manifest.json").read_text())
    assert len(manifest["layers"]) == 3
    import OpenEXR

    layer0 = manifest["layers"][0]
    px = OpenEXR.File(str(dest / layer0["exr"]), separate_channels=True).channels()["Y"].pixels
    assert np.array_equal(px, open_project(full).layers[0].thickness)
    with zipfile.ZipFile(dest / "layers.ora") as zf:
        assert zf.namelist()[0] == "mimetype" and zf.read("mimetype") == b"image/openraster"
        assert "stack.xml" in zf.namelist() and "mergedimage.png" in zf.namelist()


def test_cli_validate_reports_one_line_without_traceback(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main

    bad = tmp_path / "bad.sheer"
    bad.write_bytes(b"PK\x03\x04 definitely not a zip")
    assert main(["project", "validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err and "bad.sheer" in err
    assert main(["project", "validate", str(tmp_path / "missing.sheer")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no such project file" in err


def test_cli_new_with_a_look_paints_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main
    from core.assets import AssetNotFoundError, find_asset

    try:
        find_asset("heads/lee-perry-smith/head.glb")
    except AssetNotFoundError:
        pytest.skip("sample assets not available")
    out = tmp_path / "natural.sheer"
    assert main(["project", "new", "--out", str(out), "--look", "natural", "--resolution", "64"]) == 0
    project = open_project(out)
    assert project.look is not None and project.look["name"] == "natural"
    assert len(project.layers) >= 2 and all(layer.thickness.max() > 0 for layer in project.layers)
    assert all(layer.material in project.materials for layer in project.layers)
    assert main(["project", "new", "--out", str(tmp_path / "x.sheer"), "--look", "no-such-look"]) == 2
    assert "unknown look" in capsys.readouterr().err
