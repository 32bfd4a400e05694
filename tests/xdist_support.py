"""The suite on pytest-xdist workers (``make test``: ``-n 2 --dist loadgroup``); tests/conftest.py's hooks
call these.

- **An X server and a temporary folder per worker.** Each worker starts its own Xvfb (on a display number
  Xvfb finds free, ``-displayfd``; it ends with the worker) and sets ``DISPLAY`` and ``TMPDIR`` before Qt
  or anything else reads them. Qt windows, real X input (xdotool), a window manager a test starts
  (openbox, tests/app/kiosk/test_kiosk_deploy.py) or its absence (tests/app/kiosk/test_kiosk_command.py),
  and checks of what is left in the temporary folder (the kiosk's private cache) never meet another
  worker's.
- **Groups.** ``--dist loadgroup`` sends each ``xdist_group`` to one worker as a whole. A test with no
  such mark joins its module's group, so a module's module-scoped fixtures (studio and kiosk windows,
  renderers, captures) are made once, as with ``--dist loadscope``; a mark on tests of several modules
  gathers them on one worker (a session-scoped capture or cluster made once), or one on parts of a module
  splits it (independent cases). The workers write each test's group to a file the controller's scheduler
  reads: pytest 9.2's node ids ignore the ``@group`` suffix xdist gives them (pytest-xdist#1386), so xdist's
  own loadgroup scheduler no longer sees the marks.
- **Threads.** Each worker's BLAS, OpenMP and llvmpipe threads are its share of the cores
  (:func:`start_controller`).
- **Longest first.** The groups are sent heaviest first (a ``slow`` test counts :data:`SLOW`, a GL or Qt
  one :data:`WINDOW`, any other one :data:`OTHER`), so the run does not end on one worker with a long
  group while the other waits.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from collections.abc import Sequence

#: The environment variable naming the folder where the workers write the tests' groups for the controller.
GROUPS_ENV = "SHEER_XDIST_GROUPS"
#: A test's weight when the groups are ordered (roughly seconds on a 2-core machine).
SLOW, WINDOW, OTHER = 8.0, 1.5, 0.3

#: The worker's own Xvfb and temporary folder; the controller's groups folder.
_XVFB: list[subprocess.Popen[bytes]] = []
_TMP: list[str] = []
_GROUPS: list[str] = []


def worker_id(config: pytest.Config) -> str | None:
    """The worker's id ("gw0", …) in an xdist worker, None in the controller or a run without workers."""
    workerinput = getattr(config, "workerinput", None)
    return None if workerinput is None else str(workerinput["workerid"])


def is_controller(config: pytest.Config) -> bool:
    """This process starts xdist workers (``-n N`` with N ≥ 1)."""
    return worker_id(config) is None and bool(getattr(config.option, "numprocesses", None))


# --- the worker's X server and temporary folder ---------------------------------------------------------


def _end_with_parent() -> None:
    """(In the child, before exec) SIGTERM when the worker's main thread, which starts it, ends."""
    import ctypes
    import signal

    ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def _start_xvfb() -> str:
    """Start an Xvfb on a free display number (Xvfb picks it and writes it to a pipe); return ``":N"``."""
    import select
    import time

    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        raise pytest.UsageError("the xdist workers start their own X server: install Xvfb (Debian package xvfb)")
    read_fd, write_fd = os.pipe()
    proc = subprocess.Popen([xvfb, "-displayfd", str(write_fd), "-screen", "0", "1920x1080x24", "-nolisten", "tcp"],
                            pass_fds=(write_fd,), stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, preexec_fn=_end_with_parent)
    os.close(write_fd)
    said = b""
    deadline = time.monotonic() + 30
    try:
        while not said.endswith(b"\n") and time.monotonic() < deadline:
            if select.select([read_fd], [], [], 0.5)[0]:
                chunk = os.read(read_fd, 32)
                if not chunk:
                    break
                said += chunk
    finally:
        os.close(read_fd)
    if not said.strip().isdigit():
        proc.kill()
        raise pytest.UsageError(f"Xvfb did not start (it wrote {said!r}, exit status {proc.poll()})")
    _XVFB.append(proc)
    return f":{said.strip().decode()}"


def isolate_worker(worker: str) -> None:
    """The worker's own X server (``DISPLAY``) and temporary folder (``TMPDIR``, inherited by the processes
    the tests start), set before Qt or anything else reads them."""
    tmp = tempfile.mkdtemp(prefix=f"sheer-tests-{worker}-")
    _TMP.append(tmp)
    os.environ["TMPDIR"] = tmp
    tempfile.tempdir = None  # tempfile reads TMPDIR again
    for name in ("WAYLAND_DISPLAY", "QT_QPA_PLATFORM", "XAUTHORITY"):
        os.environ.pop(name, None)  # the worker's X server asks for no cookie; never a desktop's compositor
    os.environ["DISPLAY"] = _start_xvfb()


def end_worker(stop_x: bool) -> None:
    """Remove the worker's temporary folder and, with ``stop_x``, stop its X server now; without, it ends
    with the worker (stopped while Qt's connection is open, Qt would abort)."""
    for tmp in _TMP:
        shutil.rmtree(tmp, ignore_errors=True)
    for proc in _XVFB if stop_x else ():
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()


# --- groups, heaviest first -------------------------------------------------------------------------------


#: The thread pools a worker's libraries start (OpenBLAS and other BLAS, OpenMP, llvmpipe's rasteriser).
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "LP_NUM_THREADS")


def start_controller(config: pytest.Config) -> None:
    """(The controller, before the workers start) the folder the workers write the tests' groups to, and the
    workers' share of the cores for their libraries' threads (unless set): OpenBLAS's threads wait for work
    spinning, so with every worker's pool as large as the machine the captures' fits took about 1.5 times the
    CPU time (measured on 2 cores, 2 workers)."""
    _GROUPS.append(tempfile.mkdtemp(prefix="sheer-xdist-groups-"))
    os.environ[GROUPS_ENV] = _GROUPS[-1]
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    workers = config.option.numprocesses
    share = max(1, cores // workers) if isinstance(workers, int) and workers > 0 else 1
    for name in THREAD_VARIABLES:
        os.environ.setdefault(name, str(share))


def end_controller() -> None:
    """(The controller) remove the groups' folder (the workers inherit its name, never remove it)."""
    for folder in _GROUPS:
        shutil.rmtree(folder, ignore_errors=True)


def _group(item: pytest.Item) -> str:
    """The test's ``xdist_group`` names joined (as xdist joins them), or its module's path."""
    names = sorted({str(m.args[0] if m.args else m.kwargs.get("name", "default"))
                    for m in item.iter_markers("xdist_group")})
    return "_".join(names) if names else item.nodeid.split("::", 1)[0]


def _weight(item: pytest.Item) -> float:
    if item.get_closest_marker("slow") is not None:
        return SLOW
    if item.get_closest_marker("gl") is not None or item.get_closest_marker("qt") is not None:
        return WINDOW
    return OTHER


def order_items(items: list[pytest.Item]) -> None:
    """(A worker) the tests in groups, the heaviest group first, each group's tests in collection order
    (every worker orders them the same way: xdist checks that they collected the same list)."""
    weight: dict[str, float] = {}
    first: dict[str, int] = {}
    for index, item in enumerate(items):
        group = _group(item)
        weight[group] = weight.get(group, 0.0) + _weight(item)
        first.setdefault(group, index)
    order = {id(item): (-weight[_group(item)], first[_group(item)], index) for index, item in enumerate(items)}
    items.sort(key=lambda item: order[id(item)])


def write_groups(worker: str, items: Sequence[pytest.Item]) -> None:
    """(A worker, its collection final) each test's group, by node id, for the controller's scheduler."""
    folder = os.environ.get(GROUPS_ENV)
    if not folder:
        return
    path = Path(folder) / f"{worker}.json"
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps({item.nodeid: _group(item) for item in items}), encoding="utf-8")
    tmp.replace(path)


def make_scheduler(config: pytest.Config, log: Any) -> Any:
    """``--dist loadgroup``'s scheduler: xdist's, with each test's group read from the workers' files."""
    from xdist.scheduler import LoadScopeScheduling

    class GroupScheduling(LoadScopeScheduling):  # type: ignore[misc]
        """Work units are the groups the workers wrote (the module's path for a test not in the files)."""

        def __init__(self, config: pytest.Config, log: Any) -> None:
            super().__init__(config, log)
            self._groups: dict[str, str] | None = None

        def _split_scope(self, nodeid: str) -> str:
            if self._groups is None:
                self._groups = {}
                folder = os.environ.get(GROUPS_ENV)
                for path in sorted(Path(folder).glob("*.json")) if folder else ():
                    self._groups.update(json.loads(path.read_text(encoding="utf-8")))
            return self._groups.get(nodeid) or nodeid.split("::", 1)[0]

    config.option.loadscopereorder = False  # the workers' order: heaviest group first
    return GroupScheduling(config, log)
