"""Migrations: every step, the roll-back on failure, the backup of the original, newer versions refused."""

from __future__ import annotations

import copy
import hashlib
import io
import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bench.fuzz import tiny_material
from painting.maps_io import encode_exr
from project.container import container_bytes
from project.errors import MigrationError, ProjectVersionError
from project.io import open_project, project_version, read_project, save_project
from project.migrations import MIGRATIONS, SCHEMA_VERSION, migrate
from project.schema import validate_json

DATA = Path(__file__).resolve().parents[1] / "data" / "project"


def v1_document(mesh_digest: str) -> dict[str, Any]:
    """A schema_version 1 (draft) project.json."""
    return {
        "schema_version": 1,
        "name": "Draft look",
        "head": "v1-head/head.obj",
        "head_sha256": mesh_digest,
        "resolution": 64,
        "layers": [{"name": "Base", "material": "Foundation F", "visible": True, "max_thickness_um": 40.0,
                    "map": "layers/000.exr"}],
        # materials as Sheer wrote them before they stated their coverage (schema_version 4)
        "materials": {"Foundation F": {k: v for k, v in tiny_material().items() if k != "coverage"}},
        "lights": [],
        "camera": None,
    }


def v1_thickness() -> np.ndarray:
    return (np.arange(4096, dtype=np.float32).reshape(64, 64) / 64).astype(np.float32)


def v1_bytes(doc: dict[str, Any]) -> bytes:
    return container_bytes([("project.json", json.dumps(doc).encode(), True),
                            ("layers/000.exr", encode_exr(v1_thickness()), False)])


def _mesh_digest() -> str:
    return hashlib.sha256((DATA / "v1-head" / "head.obj").read_bytes()).hexdigest()


def test_the_committed_v1_fixture_is_what_the_generator_makes() -> None:
    """tests/data/project/v1-draft.sheer was written by v1_bytes(v1_document(...)): regenerate if needed."""
    import zipfile

    with zipfile.ZipFile(DATA / "v1-draft.sheer") as zf:  # compare contents: EXR bytes may vary by version
        assert json.loads(zf.read("project.json")) == v1_document(_mesh_digest())
        assert sorted(zf.namelist()) == ["layers/000.exr", "project.json"]


def test_v1_file_opens_migrated(tmp_path: Path) -> None:
    project = open_project(DATA / "v1-draft.sheer")
    assert project.source_schema_version == 1
    assert project.resolution == 64 and project.layers[0].resolution == 64
    assert project.head.files == {"head.obj": _mesh_digest()} and project.head.mesh == "head.obj"
    assert project.head.mesh_path == (DATA / "v1-head" / "head.obj").absolute()
    layer = project.layers[0]
    assert layer.opacity == 1.0 and layer.encoding == "exr-float32" and layer.max_thickness_um == 40.0
    assert np.array_equal(layer.thickness, v1_thickness())
    assert project.look is None


def test_step_1_to_2_gives_a_valid_current_document() -> None:
    doc = v1_document("a" * 64)
    before = copy.deepcopy(doc)
    out = MIGRATIONS[1](copy.deepcopy(doc))
    assert out["schema_version"] == 2
    # 2 → 3 adds only the layers' masks, 3 → 4 the materials' coverage
    validate_json(MIGRATIONS[3](MIGRATIONS[2](copy.deepcopy(out))), "migrated")
    assert out["resolution"] == 64 and out["layers"][0]["resolution"] == 64 and out["layout"] is None
    assert out["head"] == {"name": "head", "path": "v1-head/head.obj", "asset": None, "mesh": "head.obj",
                           "files": {"head.obj": "a" * 64}, "embedded": False}
    assert doc == before


def test_every_registered_step_is_contiguous() -> None:
    assert sorted(MIGRATIONS) == list(range(1, SCHEMA_VERSION))


def test_a_failing_step_rolls_back_and_names_the_step() -> None:
    doc = v1_document("a" * 64)
    before = copy.deepcopy(doc)

    def breaks_halfway(data: dict[str, Any]) -> dict[str, Any]:
        data["layers"].clear()  # damage the copy, then fail
        raise KeyError("boom")

    with pytest.raises(MigrationError, match="migration from schema_version 1 to 2 failed .*boom.*unchanged"):
        migrate(doc, "p.sheer", registry={1: breaks_halfway})
    assert doc == before
    with pytest.raises(MigrationError, match="did not produce version 2"):
        migrate(doc, "p.sheer", registry={1: lambda d: d})
    with pytest.raises(MigrationError, match="no migration from schema_version 1"):
        migrate(doc, "p.sheer", registry={})
    # a v3 world: the chain runs 1 -> 2 -> 3 in order
    chain = {1: MIGRATIONS[1], 2: lambda d: {**d, "schema_version": 3}}
    out, steps = migrate(doc, "p.sheer", registry=chain, target=3)
    assert steps == [1, 2] and out["schema_version"] == 3 and doc == before


def test_a_malformed_v1_file_is_a_migration_error() -> None:
    doc = v1_document("a" * 64)
    doc["head"] = 42
    with pytest.raises(MigrationError, match="p.sheer: project.json: migration from schema_version 1"):
        read_project(io.BytesIO(v1_bytes(doc)), name="p.sheer", verify_head=False)
    doc = v1_document("a" * 64)
    doc["surprise"] = 1
    with pytest.raises(MigrationError, match="unknown field"):
        read_project(io.BytesIO(v1_bytes(doc)), name="p.sheer", verify_head=False)


def test_saving_a_migrated_project_backs_up_the_original(tmp_path: Path) -> None:
    shutil.copytree(DATA, tmp_path / "d")
    path = tmp_path / "d" / "v1-draft.sheer"
    original = path.read_bytes()
    project = open_project(path)
    save_project(project, path)
    assert project_version(path) == SCHEMA_VERSION
    assert (tmp_path / "d" / "v1-draft.sheer.v1.bak").read_bytes() == original
    again = open_project(path)
    assert again.source_schema_version == SCHEMA_VERSION and np.array_equal(again.layers[0].thickness, v1_thickness())
    save_project(again, path)  # the v1 backup is kept, not overwritten by later saves
    assert (tmp_path / "d" / "v1-draft.sheer.v1.bak").read_bytes() == original


def test_newer_file_is_refused() -> None:
    doc = v1_document("a" * 64)
    doc["schema_version"] = SCHEMA_VERSION + 1
    with pytest.raises(ProjectVersionError, match=f"newer Sheer \\(schema_version {SCHEMA_VERSION + 1}"):
        read_project(io.BytesIO(v1_bytes(doc)), name="p.sheer", verify_head=False)


def test_cli_upgrade(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main

    shutil.copytree(DATA, tmp_path / "d")
    path = tmp_path / "d" / "v1-draft.sheer"
    assert main(["project", "upgrade", str(path)]) == 0
    assert f"upgraded from schema_version 1 to {SCHEMA_VERSION}" in capsys.readouterr().out
    assert project_version(path) == SCHEMA_VERSION and (tmp_path / "d" / "v1-draft.sheer.v1.bak").is_file()
    assert main(["project", "upgrade", str(path)]) == 0
    assert "nothing to do" in capsys.readouterr().out
