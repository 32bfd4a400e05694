"""Fuzzing with hypothesis: damaged projects and libraries raise ProjectError / SheerError, nothing else.

The mutations (bit flips, truncations, byte runs, entry swaps/drops/duplicates/additions, project.json
value and text changes) are those of ``sheer bench fuzz`` (:mod:`bench.fuzz`), driven here
by hypothesis's random source; the benchmark runs 10,000+ of them.
"""

from __future__ import annotations

import io
import random

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


def test_accepted_mutants_are_really_valid() -> None:
    """Whatever a mutation leaves loadable must load again identically (no half-validated state)."""
    rng = random.Random(5)
    for _ in range(100):
        _, blob = mutate(EMBEDDED, rng)
        if classify(blob) == "ok":
            a = read_project(io.BytesIO(blob), name="a", verify_head=False)
            b = read_project(io.BytesIO(blob), name="b", verify_head=False)
            assert a.same_as(b)


@pytest.mark.parametrize("seed", [11])
def test_bench_driver_reports_zero_other_exceptions(seed: int) -> None:
    result = run_fuzz(300, seed)
    assert result["cases"] == 300 and result["outcomes"].get("other", 0) == 0, result["other_examples"]


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
    import numpy as np

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
