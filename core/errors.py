"""Errors whose message is meant for the user.

Every error that Sheer raises because of bad input derives from :class:`SheerError`. The command line
and the studio show its message as it is (no traceback); anything else is an internal error.
"""

from __future__ import annotations


class SheerError(Exception):
    """An error caused by input (a file, an argument, a value) with a message that says what and where."""


class AssetNotFoundError(SheerError, FileNotFoundError):
    """A sample asset or resource was not found; the message lists every place that was searched."""
