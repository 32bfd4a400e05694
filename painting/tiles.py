"""Texture tiles: the unit of change between the document, its undo history and the renderer.

A layer map of side ``resolution`` texels (a multiple of :data:`TILE`) is cut into ``resolution // TILE``
squares per side; tile ``(row, col)`` covers texels ``[row·TILE, row·TILE + TILE) × [col·TILE, col·TILE +
TILE)`` (row 0 is the top row of the map). Change events, undo records and GPU uploads all name tiles so.
"""

from __future__ import annotations

#: the side of a tile in texels
TILE: int = 64
