"""``sheer catalogue`` end to end: its own LocalCluster, a scheduler and a worker started with the ``dask``
command line as separate processes, and output folders it cannot use."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from app.cli import main
from tests import disk_support

if TYPE_CHECKING:
    from collections.abc import Iterator

pytestmark = pytest.mark.gl
tiny_tmpfs = disk_support.tiny_tmpfs  # the fixture: a tmpfs mounted for the test
DASK = str(Path(sys.executable).with_name("dask"))


def test_cli_on_its_own_local_cluster_then_a_noop_rerun(write_spec, tmp_path, capsys) -> None:
    spec, out = write_spec(), tmp_path / "out"
    assert main(["catalogue", str(spec), "--out", str(out), "--workers", "2"]) == 0
    captured = capsys.readouterr()
    assert "small: 4 outputs: 4 rendered, 0 already there, 0 failed" in captured.out
    assert "4/4" in captured.err  # the progress bar
    manifest = json.loads((out / "manifest.json").read_text())
    assert len(manifest["images"]) == 4 and len({e["worker"] for e in manifest["images"]}) == 2
    t0 = time.perf_counter()
    assert main(["catalogue", str(spec), "--out", str(out)]) == 0
    assert time.perf_counter() - t0 < 3.0  # nothing to do: no cluster is started
    assert "0 rendered, 4 already there" in capsys.readouterr().out


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture
def dask_processes(tmp_path: Path) -> Iterator[str]:
    """A ``dask scheduler`` and one ``dask worker`` (1 thread) on 127.0.0.1, as separate processes."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    log = tmp_path / "dask.log"
    procs: list[subprocess.Popen[bytes]] = []
    with log.open("wb") as fh:
        try:
            procs.append(subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                                           "--no-dashboard"], stdout=fh, stderr=fh, start_new_session=True))
            procs.append(subprocess.Popen([DASK, "worker", address, "--host", "127.0.0.1", "--nworkers", "1",
                                           "--nthreads", "1", "--no-dashboard", "--local-directory", str(tmp_path),
                                           "--preload", "catalogue.warmup"],
                                          stdout=fh, stderr=fh, start_new_session=True))
            from distributed import Client

            with Client(address, timeout="20s") as client:
                client.wait_for_workers(1, timeout=60)
            yield address
        finally:
            for p in reversed(procs):  # always: the worker (and its nanny's child), then the scheduler
                os.killpg(p.pid, 9)
                p.wait(timeout=20)


def test_cli_on_a_scheduler_and_worker_started_as_separate_processes(dask_processes, write_spec, tmp_path,
                                                                     capsys) -> None:
    out = tmp_path / "out"
    assert main(["catalogue", str(write_spec()), "--out", str(out), "--scheduler", dask_processes]) == 0
    assert "4 rendered" in capsys.readouterr().out
    manifest = json.loads((out / "manifest.json").read_text())
    workers = {e["worker"] for e in manifest["images"]}
    assert len(workers) == 1 and int(next(iter(workers)).split(":")[1]) != os.getpid()


def test_unreachable_scheduler_is_a_clear_error(write_spec, tmp_path, capsys) -> None:
    address = f"tcp://127.0.0.1:{_free_port()}"
    assert main(["catalogue", str(write_spec()), "--out", str(tmp_path / "o"), "--scheduler", address]) == 2
    assert f"cannot reach the Dask scheduler at {address}" in capsys.readouterr().err


def test_bad_output_folders_are_refused_before_work(write_spec, tmp_path, tiny_tmpfs, capsys) -> None:
    spec = str(write_spec())
    (tmp_path / "a-file").write_text("in the way")
    assert main(["catalogue", spec, "--out", str(tmp_path / "a-file")]) == 2
    assert "a-file: not a folder (a file is in the way)" in capsys.readouterr().err
    full, ro = tiny_tmpfs("full", "size=32k"), tiny_tmpfs("ro", "ro,size=32k")
    assert main(["catalogue", spec, "--out", str(full / "cat")]) == 2
    err = capsys.readouterr().err
    assert "cannot write the catalogue here: No space left on device" in err and err.count("\n") == 1
    assert [p.name for p in (full / "cat").iterdir()] == []  # nothing half-written
    assert main(["catalogue", spec, "--out", str(ro / "cat")]) == 2
    assert "cannot write the catalogue here: Read-only file system" in capsys.readouterr().err
