"""Soak: shoppers one after another at a real kiosk window (Xvfb, Mesa GL) through its watched-folder
camera — a saved photo and Done, a refused photo, one who walks away, an unreadable photo, one left for
the idle timeout, and a kiosk killed (SIGKILL) mid-session and restarted — leave no GL objects, threads or
open files behind, no private folder, and nothing in the snapshot folder but the saved photos.

The suite's size (6 shoppers, two of them captured); the full size (50 shoppers) is ``sheer bench soak``
(bench/soak.py, figures in docs/BENCHMARKS.md); the bounds are ``bench.soak.KIOSK_BOUNDS``. Memory is
measured there only: over 6 shoppers, one of them a restart, the resident set's and the Python heap's slopes
are within their noise (in one process that ran other tests, freed pages are reused unseen), so no bound on
them would be a test; over 24 (``sheer bench soak --studio-strokes 0 --kiosk-shoppers 24``) the Python heap
is flat and the resident set still grows (docs/BENCHMARKS.md, soak).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from app.qt_compat import pin_singletons

if TYPE_CHECKING:
    from collections.abc import Iterator

pin_singletons()

pytestmark = [pytest.mark.qt, pytest.mark.gl, pytest.mark.slow]

#: GL objects the kiosk may hold at the end beyond the most its first window held before the restart (the
#: new window's first frames made two more); one shopper's views kept would be ~35
GL_SLACK = 5


def private_folders(mine: bool = False) -> set[str]:
    """The private folders in the temporary directory (``mine``: this process's only)."""
    pattern = f"sheer-private-cache-{os.getpid()}-*" if mine else "sheer-private-cache-*"
    return {p.name for p in Path(tempfile.gettempdir()).glob(pattern)}


@pytest.fixture(scope="module")
def soak(qapp: object, tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    """Six shoppers in a row (one of them the killed kiosk and its restart), sampled after each."""
    from bench.soak import kiosk_soak, sampling
    from core.assets import find_asset

    folder = tmp_path_factory.mktemp("kiosk-soak")
    others = private_folders()
    with sampling() as sampler:
        tally = kiosk_soak(folder, 6, sampler, find_asset("photos/grace_hopper.jpg"))
    yield {"sampler": sampler, "tally": tally, "folder": folder, "others": others,
           "trends": sampler.trends()}


def test_shoppers_in_a_row_leave_nothing_behind(soak: dict[str, Any]) -> None:
    from bench.soak import KIOSK_BOUNDS, leaks

    sampler, tally, folder = soak["sampler"], soak["tally"], soak["folder"]
    assert tally.kinds == {"saves": 1, "refused": 1, "walks away": 1, "killed and restarted": 1, "error": 1,
                           "idle after": 1}
    counts = {k: v for k, v in soak["trends"].items() if k in ("threads", "tasks", "fds")}
    assert leaks(counts, KIOSK_BOUNDS) == [], counts
    gl = sampler.values["gl_objects"]
    before_restart = gl[: len(gl) // 2 + 1]  # (the kiosk is killed and restarted as shopper 4 of 6)
    assert gl[-1] <= max(before_restart) + GL_SLACK, (gl, sampler.ledger.sites())
    assert sampler.ledger.alive().get("contexts", 0) == 0  # her views' standalone GL contexts released
    assert tally.killed_folder and tally.swept_at_restart  # the restart swept the killed kiosk's folder
    assert private_folders(mine=True) == set() and private_folders() <= soak["others"]
    assert sorted(p.name for p in (folder / "photos").iterdir()) == sorted(tally.saved)
    assert len(tally.saved) == 1 and not list((folder / "drop").iterdir())
