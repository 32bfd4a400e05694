"""Each catalogue worker's EGL device: its index from its Dask name, the round robin, a bad SHEER_EGL_DEVICE."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pytest

from catalogue import worker as worker_mod
from catalogue.worker import WorkerState, worker_index

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path


@pytest.mark.parametrize(("name", "index"), [
    (0, 0), (5, 5), ("3", 3), ("render-2", 2), ("gpu-box-12", 12),  # LocalCluster; dask worker --name render
    ("tcp://127.0.0.1:40575", None), ("render", None), ("render-", None), (-1, None), (True, None),
])
def test_a_workers_index_comes_from_its_dask_name(name: Any, index: int | None) -> None:
    assert worker_index(name) == index


def test_outside_a_dask_worker_there_is_no_index() -> None:
    assert worker_index() is None


def test_the_preload_notes_the_index_before_the_warm_up(monkeypatch: pytest.MonkeyPatch) -> None:
    from catalogue.warmup import dask_setup

    monkeypatch.setattr(worker_mod, "_STATE", None)  # a fresh state for this process; the real one after

    class FakeWorker:
        name = 3
        executors: dict[str, Any] = {}  # no task thread: nothing is queued

    dask_setup(FakeWorker())
    assert worker_mod.worker_state().index == 3


def _fake_gl(monkeypatch: pytest.MonkeyPatch, device: int | None, broken: set[int | None]) -> list[int | None]:
    """render.context with ``device`` chosen by the round robin and contexts failing on ``broken``."""
    import render.context as rc

    made: list[int | None] = []

    def make(device: int | None = None, require: int = 450) -> object:
        made.append(device)
        if device in broken:
            raise RuntimeError(f"eglInitialize failed on device {device}")
        return object()

    monkeypatch.setattr(rc, "round_robin_device", lambda index, devices=None: device)
    monkeypatch.setattr(rc, "standalone_context", make)
    return made


def test_a_worker_makes_its_context_on_its_own_device_once(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("SHEER_EGL_DEVICE", raising=False)
    made = _fake_gl(monkeypatch, 1, set())
    state = WorkerState()
    state.index = 5
    ctx = state.context()
    assert state.context() is ctx and made == [1] and state.device == 1


def test_a_device_that_fails_falls_back_to_the_default_one(monkeypatch: pytest.MonkeyPatch,
                                                          caplog: pytest.LogCaptureFixture) -> None:
    monkeypatch.delenv("SHEER_EGL_DEVICE", raising=False)
    made = _fake_gl(monkeypatch, 1, {1})
    state = WorkerState()
    state.index = 1
    assert state.context() is not None and made == [1, None] and state.device is None
    assert "EGL device 1 failed" in caplog.text


def test_a_pinned_device_that_fails_is_an_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SHEER_EGL_DEVICE", "0")
    made = _fake_gl(monkeypatch, 0, {0})
    with pytest.raises(RuntimeError, match="device 0"):
        WorkerState().context()
    assert made == [0]


def test_sheer_catalogue_refuses_a_bad_variable_in_one_line_before_starting_workers(
        monkeypatch: pytest.MonkeyPatch, write_spec: Callable[..., Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main as sheer

    monkeypatch.setenv("SHEER_EGL_DEVICE", "first")
    assert sheer(["catalogue", str(write_spec()), "--out", str(tmp_path / "out"), "--workers", "2"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "SHEER_EGL_DEVICE='first' is not an integer" in err, err
