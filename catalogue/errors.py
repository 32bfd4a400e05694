"""The catalogue's one user-facing error type."""

from __future__ import annotations

from core.errors import SheerError


class CatalogueError(SheerError, ValueError):
    """A catalogue spec, job or output folder that cannot be used; the message names the file and the key."""
