"""Renderer errors (bad input the user can fix)."""

from __future__ import annotations

from core.errors import SheerError


class RenderError(SheerError, ValueError):
    """Bad renderer input (a size, a setting, a layer, a shader name); the message says what and where."""
