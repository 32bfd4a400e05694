"""Even shares of a catalogue's runs of jobs for its workers, with stealing for the stragglers.

Dask hands tasks to whichever worker asks first, so with every run submitted at once the workers that
were ready first took most of them (measured with 8 workers on 96 images: 24, 20, 16, 8, 8, 8, 8 and 4
images) and the run lasted as long as the busiest one. :class:`Balancer` instead gives each worker its
own queue, a contiguous share of the runs (in expansion order, so a worker's runs mostly share a head,
look and lighting and it keeps its caches warm) of about the same number of jobs. The driver
(:mod:`catalogue.driver`) keeps only one or two runs in flight per worker, each pinned to its worker
(loosely: Dask moves it if that worker dies), and asks :meth:`Balancer.next_for` for the next one as each
finishes: a worker that is ready late still finds its share waiting, and a worker whose own queue is
empty takes the last run of the longest queue left, so a slow or dead worker never holds up the end.
"""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING, Generic, TypeVar

if TYPE_CHECKING:
    from collections.abc import Iterable, Sequence

T = TypeVar("T")


class Balancer(Generic[T]):
    """Per-worker queues of runs (see the module docstring).

    Args:
        runs: the runs of jobs in order (anything with a length: the number of jobs it holds).
        workers: the workers' names (e.g. Dask addresses), in a fixed order.

    Attributes:
        queues: per worker, the runs not handed out yet, next first.
        stolen: how many runs were taken from another worker's queue.
    """

    def __init__(self, runs: Sequence[Sequence[T]], workers: Sequence[str]) -> None:
        self.queues: dict[str, deque[Sequence[T]]] = {w: deque() for w in workers}
        self.stolen = 0
        names = list(self.queues)
        if not names:
            raise ValueError("a Balancer needs at least one worker")
        left = sum(len(r) for r in runs)
        todo = deque(runs)
        for k, name in enumerate(names):  # each worker in turn: runs while they bring it nearer its share
            queue, share, target = self.queues[name], 0, left / (len(names) - k)
            while todo and (k == len(names) - 1 or abs(share + len(todo[0]) - target) <= abs(share - target)):
                share += len(todo[0])
                queue.append(todo.popleft())
            left -= share

    def add_workers(self, workers: Iterable[str]) -> None:
        """Let workers that joined since take runs (from the others' queues: theirs start empty)."""
        for w in workers:
            self.queues.setdefault(w, deque())

    def next_for(self, worker: str) -> Sequence[T] | None:
        """The next run for ``worker``: its own queue's next, else the last of the longest queue; None at the end."""
        own = self.queues.setdefault(worker, deque())
        if own:
            return own.popleft()
        victim = max(self.queues.values(), key=lambda q: sum(len(r) for r in q))
        if not victim:
            return None
        self.stolen += 1
        return victim.pop()

    def remaining(self) -> int:
        """Runs not handed out yet."""
        return sum(len(q) for q in self.queues.values())
