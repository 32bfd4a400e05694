"""Texture tiles: the unit of change between the document, its undo history and the renderer.

A layer map of side ``resolution`` texels (a multiple of :data:`TILE`) is cut into ``resolution // TILE``
squares per side; tile ``(row, col)`` covers texels ``[row·TILE, row·TILE + TILE) × [col·TILE, col·TILE +
TILE)`` (row 0 is the top row of the map). Change events, undo records and GPU uploads all name tiles so.
"""

from __future__ import annotations

from typing import TypeVar

import numpy as np

#: the side of a tile in texels
TILE: int = 64

_Index = TypeVar("_Index", int, np.ndarray)


def tile_of(flat: _Index, res: int) -> _Index:
    """The tile id (row · tiles per row + column) of row-major texel index ``flat`` in a map of side ``res``.

    The one spelling of the formula: for a scalar or an integer array, in numpy and in the compiled kernels
    (:mod:`painting.kernels` compiles and inlines it; numba freezes it into their on-disk cache, as it does
    :data:`TILE`).
    """
    return (flat // (res * TILE)) * (res // TILE) + (flat % res) // TILE


def tile_rects(tiles: list[tuple[int, int]], size: tuple[int, int]) -> list[tuple[int, int, int, int]]:
    """The texel rectangles (x, y, width, height) of tiles (row, col) of a map of ``size`` (width, height).

    Tiles are clipped to the map; tiles wholly outside it and repeats are dropped.
    """
    w, h = size
    out: list[tuple[int, int, int, int]] = []
    seen: set[tuple[int, int]] = set()
    for row, col in tiles:
        x0, y0 = int(col) * TILE, int(row) * TILE
        if (row, col) in seen or not (0 <= x0 < w and 0 <= y0 < h):
            continue
        seen.add((row, col))
        out.append((x0, y0, min(x0 + TILE, w) - x0, min(y0 + TILE, h) - y0))
    return out
