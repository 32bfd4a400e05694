"""The catalogue's jobs are shared evenly between its workers: the shares (pure), then a real 2-worker run."""

from __future__ import annotations

import json
import math
from collections import Counter
from typing import TYPE_CHECKING, Any

import pytest

from catalogue.balance import Balancer

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

#: (with tests/catalogue/test_run.py: one worker starts the session's cluster, conftest's dask_client)
pytestmark = pytest.mark.xdist_group("dask-cluster")


def _runs(sizes: list[int]) -> list[list[int]]:
    """Runs of consecutive job numbers of the given lengths."""
    out, n = [], 0
    for s in sizes:
        out.append(list(range(n, n + s)))
        n += s
    return out


def test_each_worker_gets_a_contiguous_share_of_about_the_same_number_of_jobs() -> None:
    # the bench's 96 images on 8 workers: 3 lightings of 32 jobs, cut in runs of at most 2 (6 per worker)
    b = Balancer(_runs([2] * 48), [f"w{i}" for i in range(8)])
    assert [sum(map(len, q)) for q in b.queues.values()] == [12] * 8
    for q in b.queues.values():  # contiguous: a worker's runs follow each other (its caches stay warm)
        jobs = [j for run in q for j in run]
        assert jobs == list(range(jobs[0], jobs[0] + len(jobs)))
    # runs of unequal lengths (groups cut where they end): still within one run of the even share
    b = Balancer(_runs([3, 3, 1, 3, 3, 2, 1, 3, 3, 3, 1]), ["a", "b", "c"])
    shares = [sum(map(len, q)) for q in b.queues.values()]
    assert sum(shares) == 26 and max(shares) - min(shares) <= 3
    # fewer runs than workers: one each, nobody gets two
    assert sorted(len(q) for q in Balancer(_runs([1, 1]), ["a", "b", "c"]).queues.values()) == [0, 1, 1]


def test_a_worker_takes_its_own_share_first_then_the_last_run_of_the_longest_queue() -> None:
    b = Balancer(_runs([1] * 12), ["a", "b", "c"])
    assert b.next_for("a") == [0] and b.next_for("a") == [1] and b.remaining() == 10
    while b.queues["a"]:
        b.next_for("a")
    b.next_for("c")  # c has 3 left, b 4: a steals b's last
    assert b.next_for("a") == [7] and b.stolen == 1
    assert b.next_for("a") == [6]  # b and c have 3 left each: the first in the workers' order
    b.add_workers(["d"])  # a worker that joined late starts empty and steals
    assert b.next_for("d") == [11] and b.stolen == 3
    assert b.next_for("b") == [4]  # its own share first, whatever was stolen from its end
    taken: list[int] = []
    while (run := b.next_for("a")) is not None:
        taken += run
    assert sorted(taken) == [5, 9, 10] and b.remaining() == 0 and b.next_for("b") is None


def test_no_worker_is_refused() -> None:
    with pytest.raises(ValueError, match="at least one worker"):
        Balancer(_runs([1]), [])


def _warm(client: Any, timeout: float = 60.0) -> None:
    """Wait until every worker of ``client`` made its GL context (its warm-up ran)."""
    import time

    from tests.catalogue.test_run import _warmed

    deadline = time.monotonic() + timeout
    while not all(ready for ready, _ in client.run(_warmed).values()) and time.monotonic() < deadline:
        time.sleep(0.2)


@pytest.mark.gl
def test_a_real_run_shares_the_jobs_evenly_and_draws_the_same_images(dask_client: Any, write_spec: Callable[..., Path],
                                                                     tmp_path: Path) -> None:
    from catalogue import expand, load_spec, run_catalogue
    from catalogue.worker import WorkerState

    views = "\n".join(f'[[views]]\nname = "v{k}"\nyaw = {k * 10 - 15}' for k in range(4))
    spec = load_spec(write_spec(write_spec().read_text().replace('[[views]]\nname = "front"', views)))
    jobs = expand(spec)
    assert len(jobs) == 16  # 2 lipsticks × 2 lightings × 4 views
    _warm(dask_client)
    result = run_catalogue(spec, tmp_path / "out", jobs=jobs, client=dask_client)
    assert (result.rendered, result.failed) == (16, [])
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert sorted(e["file"] for e in manifest["images"]) == sorted(j.out for j in jobs)
    assert {e["status"] for e in manifest["images"]} == {"rendered"}
    per_worker = Counter(e["worker"] for e in manifest["images"])
    # runs of ceil(16 / 12) = 2 jobs: each worker its 8, give or take a run or two taken at the end
    run = math.ceil(16 / (6 * 2))
    assert len(per_worker) == 2 and max(per_worker.values()) <= math.ceil(16 / 2) + 2 * run, per_worker
    cold = WorkerState()  # the same bytes as one process drawing the jobs one by one
    try:
        for job in jobs[::5]:
            assert cold.render(job) == (tmp_path / "out" / job.out).read_bytes(), job.out
    finally:
        cold.reset()
