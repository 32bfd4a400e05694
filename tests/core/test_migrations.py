"""core.migrations.Migrations: registration, the steps in order, the roll-back and the refusals."""

from __future__ import annotations

import copy
from typing import Any

import pytest

from core.errors import SheerError
from core.migrations import Migrations


class _DocError(SheerError):
    pass


def _v1_to_v2(data: dict[str, Any]) -> dict[str, Any]:
    data["name"] = data.pop("title")
    data["schema_version"] = 2
    return data


def _v2_to_v3(data: dict[str, Any]) -> dict[str, Any]:
    data["tags"].append("v3")
    data["schema_version"] = 3
    return data


def _doc() -> dict[str, Any]:
    return {"schema_version": 1, "title": "t", "tags": ["a"]}


def test_register_is_a_decorator_and_refuses_a_second_step_from_one_version() -> None:
    steps = Migrations(_DocError)
    assert steps.register(1)(_v1_to_v2) is _v1_to_v2
    assert dict(steps) == {1: _v1_to_v2} and len(steps) == 1 and steps[1] is _v1_to_v2
    with pytest.raises(ValueError, match="a migration from schema_version 1 is already registered"):
        steps.register(1)(_v2_to_v3)
    assert steps[1] is _v1_to_v2


def test_the_steps_run_in_order_on_a_copy() -> None:
    doc = _doc()
    before = copy.deepcopy(doc)
    out = Migrations(_DocError, {2: _v2_to_v3, 1: _v1_to_v2}).upgrade(doc, version=1, target=3, source="d.json")
    assert out == {"schema_version": 3, "name": "t", "tags": ["a", "v3"]}
    assert doc == before  # nested lists too: the steps worked on a deep copy


def test_no_step_to_run_returns_an_independent_copy() -> None:
    doc = _doc()
    out = Migrations(_DocError).upgrade(doc, version=1, target=1, source="d.json")
    assert out == doc
    out["tags"].append("x")
    assert doc["tags"] == ["a"]


def test_a_failing_step_is_the_callers_error_naming_source_and_step_and_rolls_back() -> None:
    doc = _doc()
    before = copy.deepcopy(doc)

    def breaks_halfway(data: dict[str, Any]) -> dict[str, Any]:
        data["tags"].clear()  # damage the copy, then fail
        return {"n": 1 / 0}

    steps = Migrations(_DocError, {1: _v1_to_v2, 2: breaks_halfway})
    with pytest.raises(_DocError) as info:
        steps.upgrade(doc, version=1, target=3, source="d.json")
    assert str(info.value) == ("d.json: migration from schema_version 2 to 3 failed "
                               "(ZeroDivisionError: division by zero); the original is unchanged")
    assert info.value.__cause__ is None and info.value.__suppress_context__
    assert doc == before


def test_a_step_raising_the_callers_error_passes_through() -> None:
    def refuses(data: dict[str, Any]) -> dict[str, Any]:
        raise _DocError("d.json: title: cannot be upgraded")

    with pytest.raises(_DocError, match=r"^d.json: title: cannot be upgraded$"):
        Migrations(_DocError, {1: refuses}).upgrade(_doc(), version=1, target=2, source="d.json")


@pytest.mark.parametrize(("result", "got"), [(lambda d: d, "schema_version 1"),
                                             (lambda d: {**d, "schema_version": 3}, "schema_version 3"),
                                             (lambda d: {"title": "t"}, "schema_version None"),
                                             (lambda d: [d], "list")])
def test_a_step_must_return_an_object_at_the_next_version(result: Any, got: str) -> None:
    with pytest.raises(_DocError) as info:
        Migrations(_DocError, {1: result}).upgrade(_doc(), version=1, target=2, source="d.json")
    assert str(info.value) == f"d.json: migration from schema_version 1 did not produce version 2 (it returned {got})"


def test_a_missing_step_is_refused() -> None:
    steps = Migrations(_DocError, {1: _v1_to_v2})
    with pytest.raises(_DocError, match=r"^d.json: no migration from schema_version 2 to 3$"):
        steps.upgrade(_doc(), version=1, target=3, source="d.json")

