"""The capture's own error: what a user's photograph, points or probe cannot give (one line, exit 2)."""

from __future__ import annotations

from core.errors import SheerError


class CaptureError(SheerError, ValueError):
    """A capture that cannot proceed (the head is not in the photo, no skin, …)."""
