"""The error of an invalid material, apart so that :mod:`km.material` and :mod:`km.coverage` share it."""

from __future__ import annotations

from core.errors import SheerError

__all__ = ["MaterialError"]


class MaterialError(SheerError, ValueError):
    """An invalid material or measurement.

    ``field`` is the path of the offending value (e.g. ``materials[3].S[12]``) and ``reason`` says what
    is wrong with it; ``str()`` gives both.
    """

    def __init__(self, field: str, reason: str) -> None:
        self.field = field
        self.reason = reason
        super().__init__(f"{field}: {reason}" if field else reason)

    def within(self, prefix: str) -> MaterialError:
        """The same error with ``prefix`` put before the field path."""
        if not prefix:
            return self
        joined = f"{prefix}.{self.field}" if self.field and not self.field.startswith("[") else prefix + self.field
        return MaterialError(joined, self.reason)
