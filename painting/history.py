"""Undo/redo: one step per stroke or edit, paint stored as 64² tile deltas, bounded memory.

A paint step keeps, per touched tile, the tile's *other* state (before the step while it is on the undo
stack, after it while on the redo stack); undo and redo swap it with the layer's current tile, so they
restore maps bit-exactly and a step never stores a whole layer. Layer and material edits are steps with
``undo``/``redo`` callables on the same stack. When the bytes held by both stacks exceed the budget the
oldest undo steps are dropped (a single step larger than the budget is not kept at all).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from painting.tiles import TILE

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy as np

    from painting.layer import Layer

DEFAULT_BUDGET_BYTES = 256 * 1024 * 1024


@dataclass
class TileDelta:
    """Stored tiles of one layer.

    ``tiles``: int32 (n, 2) (tile row, tile column); ``data``: float32 (n, 64, 64) thickness in µm.
    """

    layer: Layer
    tiles: np.ndarray
    data: np.ndarray

    @property
    def nbytes(self) -> int:
        """Bytes held (the stored tiles and their indices)."""
        return int(self.data.nbytes + self.tiles.nbytes)

    def swap(self) -> None:
        """Exchange the stored tiles with the layer's current ones (undo and redo are the same)."""
        arr = self.layer.data
        h, w = arr.shape
        view = arr.reshape(h // TILE, TILE, w // TILE, TILE)
        ty, tx = self.tiles[:, 0], self.tiles[:, 1]
        current = view[ty, :, tx, :]  # fancy indexing copies: (n, 64, 64)
        view[ty, :, tx, :] = self.data
        self.data = current


@dataclass
class Step:
    """One undoable step: paint deltas and/or a command (``undo``/``redo`` callables)."""

    label: str
    deltas: list[TileDelta] = field(default_factory=list)
    undo_fn: Callable[[], None] | None = None
    redo_fn: Callable[[], None] | None = None
    extra_bytes: int = 0

    @property
    def nbytes(self) -> int:
        """Bytes held: the tile deltas, ``extra_bytes`` (e.g. a removed layer's map) and a small overhead."""
        return sum(d.nbytes for d in self.deltas) + int(self.extra_bytes) + 256


class History:
    """The undo and redo stacks (see the module docstring).

    Attributes:
        budget_bytes: the most bytes both stacks may hold.
        peak_bytes: the most they have held.
        dropped: steps dropped to respect the budget.
    """

    def __init__(self, budget_bytes: int = DEFAULT_BUDGET_BYTES) -> None:
        self.budget_bytes = int(budget_bytes)
        self._undo: deque[Step] = deque()
        self._redo: deque[Step] = deque()
        self._bytes = 0
        self.peak_bytes = 0
        self.dropped = 0

    @property
    def nbytes(self) -> int:
        """Bytes held now by both stacks."""
        return self._bytes

    @property
    def can_undo(self) -> bool:
        """Whether there is a step to undo."""
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        """Whether there is a step to redo."""
        return bool(self._redo)

    def __len__(self) -> int:
        return len(self._undo)

    @property
    def undo_step(self) -> Step | None:
        """The step :meth:`pop_undo` would return (the last one done), or None."""
        return self._undo[-1] if self._undo else None

    @property
    def undo_label(self) -> str | None:
        """The label of the step :meth:`pop_undo` would return, or None."""
        return self._undo[-1].label if self._undo else None

    @property
    def redo_label(self) -> str | None:
        """The label of the step :meth:`pop_redo` would return, or None."""
        return self._redo[-1].label if self._redo else None

    def push(self, step: Step) -> None:
        """Add a new step; clears redo; drops the oldest steps over the budget."""
        for s in self._redo:
            self._bytes -= s.nbytes
        self._redo.clear()
        size = step.nbytes
        if size > self.budget_bytes:
            self.dropped += 1 + len(self._undo)
            self._undo.clear()
            self._bytes = 0
            return
        self._undo.append(step)
        self._bytes += size
        while self._bytes > self.budget_bytes and self._undo:
            old = self._undo.popleft()
            self._bytes -= old.nbytes
            self.dropped += 1
        self.peak_bytes = max(self.peak_bytes, self._bytes)

    def take_since(self, mark: Step | None) -> list[Step]:
        """Remove and return, oldest first, the steps done after ``mark`` (an earlier :attr:`undo_step`).

        ``None`` (there was no step then), or a mark the budget has dropped since, takes every step.
        """
        undo = list(self._undo)
        start = next((i + 1 for i in range(len(undo) - 1, -1, -1) if undo[i] is mark), 0) if mark is not None else 0
        taken = undo[start:]
        for _ in taken:
            self._bytes -= self._undo.pop().nbytes
        return taken

    def pop_undo(self) -> Step | None:
        """The last step, moved to the redo stack (the caller replays it backwards), or None."""
        return self._move_last(self._undo, self._redo)

    def pop_redo(self) -> Step | None:
        """The last undone step, moved back to the undo stack (the caller replays it), or None."""
        return self._move_last(self._redo, self._undo)

    @staticmethod
    def _move_last(source: deque[Step], target: deque[Step]) -> Step | None:
        """The last step of ``source``, moved onto ``target``, or None when ``source`` is empty."""
        if not source:
            return None
        step = source.pop()
        target.append(step)
        return step

    def clear(self) -> None:
        """Forget every step."""
        self._undo.clear()
        self._redo.clear()
        self._bytes = 0
