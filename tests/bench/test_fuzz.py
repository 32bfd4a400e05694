"""Fuzzing with hypothesis: damaged projects and libraries raise ProjectError / SheerError, nothing else.

The mutations (bit flips, truncations, byte runs, entry swaps/drops/duplicates/additions, project.json
value and text changes) are those of ``sheer bench fuzz`` (:mod:`bench.fuzz`), driven here
by hypothesis's random source; the benchmark runs 10,000+ of them.
"""

from __future__ import annotations

import io
import json
import random
import zipfile
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bench.fuzz import (
    MUTATIONS,
    classify,
    classify_library,
    mutate,
    mutate_library,
    run_fuzz,
    sample_library_text,
    sample_project,
)
from project.io import project_bytes, read_project

EMBEDDED = project_bytes(sample_project(64, 2, seed=0, embedded=True), self_contained=True)
REFERENCED = project_bytes(sample_project(64, 3, seed=1, embedded=False), self_contained=False)
LIBRARY = sample_library_text()
FUZZ = settings(max_examples=120, deadline=None, database=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])


def test_the_unmutated_samples_load() -> None:
    assert classify(EMBEDDED) == "ok" and classify(REFERENCED) == "ok"
    assert classify_library(LIBRARY) == "ok"


@FUZZ
@given(rng=st.randoms(use_true_random=False), kind=st.sampled_from(MUTATIONS), base=st.sampled_from([0, 1]))
def test_mutated_projects_raise_only_project_errors(rng: random.Random, kind: str, base: int) -> None:
    _, blob = mutate([EMBEDDED, REFERENCED][base], rng, kind)
    result = classify(blob)
    assert result in ("ok", "ProjectError"), result


@FUZZ
@given(rng=st.randoms(use_true_random=False))
def test_mutated_libraries_raise_only_sheer_errors(rng: random.Random) -> None:
    _, text = mutate_library(LIBRARY, rng)
    result = classify_library(text)
    assert result in ("ok", "SheerError"), result


@settings(max_examples=60, deadline=None, database=None, derandomize=True)
@given(data=st.binary(max_size=600))
def test_arbitrary_bytes_are_refused_cleanly(data: bytes) -> None:
    assert classify(data) == "ProjectError"
    assert classify(b"PK\x03\x04" + data) == "ProjectError"


def _decoded_independently(blob: bytes) -> tuple[dict[str, Any], list[np.ndarray], dict[str, bytes]]:
    """(project.json, each layer's map in µm, the embedded head's files) read with zipfile, json, OpenEXR
    and Pillow directly: none of Sheer's reading code.
    """
    import OpenEXR
    from PIL import Image

    maps = []
    with zipfile.ZipFile(io.BytesIO(blob)) as zf:
        doc = json.loads(zf.read("project.json"))
        for layer in doc["layers"]:
            data = zf.read(layer["map"])
            if layer["encoding"] == "exr-float32":
                maps.append(OpenEXR.File(io.BytesIO(data), separate_channels=True).channels()["Y"].pixels)
            else:
                counts = np.asarray(Image.open(io.BytesIO(data)), dtype=np.float64)
                maps.append((counts * layer["scale_um"]).astype(np.float32))
        head = {key: zf.read("head/" + key) for key in doc["head"]["files"]} if doc["head"]["embedded"] else {}
    return doc, maps, head


def test_accepted_mutants_load_as_their_bytes_say() -> None:
    """Whatever a mutation leaves loadable loads as its entries, decoded independently, say."""
    rng = random.Random(5)
    accepted = 0
    for _ in range(100):
        _, blob = mutate(EMBEDDED, rng)
        if classify(blob) != "ok":
            continue
        accepted += 1
        loaded = read_project(io.BytesIO(blob), name="a", verify_head=False)
        doc, maps, head = _decoded_independently(blob)
        assert (loaded.name, loaded.resolution, loaded.layout) == (doc["name"], doc["resolution"], doc["layout"])
        assert [(x.name, x.material, x.visible, x.opacity, x.max_thickness_um, x.encoding) for x in loaded.layers] \
            == [(x["name"], x["material"], x["visible"], x["opacity"], x["max_thickness_um"], x["encoding"])
                for x in doc["layers"]]
        for layer, values in zip(loaded.layers, maps, strict=True):
            assert layer.thickness.dtype == values.dtype == np.float32
            assert np.array_equal(layer.thickness.view(np.uint32), values.view(np.uint32))
        assert (loaded.materials, loaded.lights, loaded.camera, loaded.look) == \
            (doc["materials"], doc["lights"], doc["camera"], doc["look"])
        assert (loaded.head.name, loaded.head.mesh, loaded.head.files, loaded.head.data) == \
            (doc["head"]["name"], doc["head"]["mesh"], doc["head"]["files"], head)
    assert accepted >= 3  # the seed leaves harmless mutants to check (11 of 100)


@pytest.mark.parametrize("seed", [11])
def test_bench_driver_reports_zero_other_exceptions(seed: int) -> None:
    result = run_fuzz(300, seed)
    assert result["cases"] == 300 and result["outcomes"].get("other", 0) == 0, result["other_examples"]


def test_sheer_bench_fuzz_prints_one_json_object(capsys: pytest.CaptureFixture[str]) -> None:
    """A small run of the command: every key, each median with its p90 and maximum, and the pass condition."""
    from app.cli import main as sheer

    assert sheer(["bench", "fuzz", "--json", "--cases", "60", "--crash-runs", "3", "--seed", "2"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert set(result) == {"cases_run", "project_errors", "library_errors", "accepted", "other_exceptions",
                           "case_ms", "case_ms_p90", "case_ms_max", "fuzz", "crash_kill", "crash_at_every_step",
                           "pid"}
    assert result["cases_run"] == 60 and result["other_exceptions"] == 0
    assert result["project_errors"] + result["library_errors"] + result["accepted"] == 60
    assert 0 < result["case_ms"] <= result["case_ms_p90"] <= result["case_ms_max"]
    assert set(result["crash_kill"]) == {"runs", "file_loaded", "file_absent", "bak_loaded", "bak_absent",
                                         "temp_files_left", "failures", "failure_examples", "seconds"}
    crash = result["crash_kill"]
    assert crash["runs"] == crash["file_loaded"] == crash["bak_loaded"] == 3
    assert crash["file_absent"] == crash["bak_absent"] == crash["failures"] == 0
    assert result["crash_at_every_step"]["steps"] >= 8 and result["crash_at_every_step"]["failures"] == 0


_FLOATS = st.floats(min_value=0.0, max_value=10_000.0, allow_nan=False, allow_infinity=False, width=32)


@settings(max_examples=40, deadline=None, database=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(
    layers=st.lists(st.tuples(st.text(min_size=1, max_size=40), st.sampled_from(["Foundation F", "Blush B"]),
                              st.booleans(), st.floats(0.0, 1.0), st.floats(0.001, 10_000.0),
                              st.lists(_FLOATS, min_size=1, max_size=8), st.sampled_from([64, 128])),
                    max_size=3),
    name=st.text(min_size=1, max_size=60),
)
def test_any_valid_project_round_trips_exactly(layers: list, name: str) -> None:
    """Property: save → open gives back the same project, maps bit-exact (EXR layers)."""
    from project.model import ProjectLayer

    project = sample_project(64, 0, name=name, embedded=True)
    for lname, material, visible, opacity, max_um, values, side in layers:
        thickness = np.zeros((side, side), np.float32)
        flat = thickness.reshape(-1)
        flat[: len(values) * 97: 97] = np.asarray(values, np.float32)  # spread the drawn values
        project.layers.append(ProjectLayer(lname, material, thickness, visible, opacity, max_um))
    blob = project_bytes(project, self_contained=True)
    again = read_project(io.BytesIO(blob), name="p", verify_head=False)
    assert again.same_as(project)


@pytest.mark.parametrize("lost", ["file_absent", "bak_absent"])
def test_a_crash_that_loses_the_file_or_its_backup_fails_the_bench(lost: str, monkeypatch: pytest.MonkeyPatch,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    import bench.fuzz as fuzz

    counts = {"runs": 1, "file_loaded": 1, "file_absent": 0, "bak_loaded": 1, "bak_absent": 0, "failures": 0}
    monkeypatch.setattr(fuzz, "crash_runs", lambda runs, seed: {**counts, lost: 1})
    monkeypatch.setattr(fuzz, "crash_at_every_step", lambda: {"steps": 0, "failures": 0})
    assert fuzz.bench_main(["--cases", "5", "--crash-runs", "1"]) == 1
    assert json.loads(capsys.readouterr().out)["crash_kill"][lost] == 1
