"""Upgrading a parsed JSON document through registered per-version steps (the one mechanism).

A :class:`Migrations` registry holds one step per version, ``from_version -> step``; a step turns a
document at ``from_version`` into one at ``from_version + 1`` and sets the version field
(:data:`VERSION_KEY`) itself. The material library (:mod:`km.library`) and ``project.json``
(:mod:`project.migrations`) each keep one registry, and their own checks of the version they read
(missing, not an integer, newer than this Sheer, older than any format) before
:meth:`Migrations.upgrade` runs the steps. Example::

    MIGRATIONS = Migrations(LibraryError)

    @MIGRATIONS.register(1)
    def _v1_to_v2(data: dict[str, Any]) -> dict[str, Any]:
        data["name"] = data.pop("title")
        data["schema_version"] = 2
        return data

    upgraded = MIGRATIONS.upgrade(parsed, version=1, target=2, source="old.json")
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterator, Mapping
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from core.errors import SheerError

#: A step: the document at version ``n`` (a private copy it may modify) -> the document at ``n + 1``.
Step = Callable[[dict[str, Any]], dict[str, Any]]
#: The documents' version field (an integer).
VERSION_KEY = "schema_version"


class Migrations(Mapping[int, Step]):
    """The upgrade steps of one document format, read as a mapping ``from_version -> step``.

    Args:
        error: The format's :class:`~core.errors.SheerError` subclass, raised (with a message naming
            the source and the step) when the upgrade cannot be done.
        steps: Steps to start with, ``from_version -> step`` (tests build small registries this way).
    """

    def __init__(self, error: type[SheerError], steps: Mapping[int, Step] | None = None) -> None:
        self.error = error
        self._steps: dict[int, Step] = dict(steps or {})

    def __getitem__(self, from_version: int) -> Step:
        return self._steps[from_version]

    def __iter__(self) -> Iterator[int]:
        return iter(self._steps)

    def __len__(self) -> int:
        return len(self._steps)

    def register(self, from_version: int) -> Callable[[Step], Step]:
        """A decorator registering ``func(data) -> data`` as the step ``from_version -> from_version + 1``.

        Args:
            from_version: The version the step reads, an integer.

        Returns:
            The decorator; it returns the function unchanged.

        Raises:
            ValueError: A step from ``from_version`` is already registered (a programming error).
        """

        def decorate(func: Step) -> Step:
            if from_version in self._steps:
                raise ValueError(f"a migration from {VERSION_KEY} {from_version} is already registered")
            self._steps[from_version] = func
            return func

        return decorate

    def upgrade(self, data: dict[str, Any], *, version: int, target: int, source: str) -> dict[str, Any]:
        """Run the steps from ``version`` up to ``target`` on a deep copy of ``data``.

        ``data`` itself is never modified, so a failure leaves the caller's document as it was (the
        roll-back). Each step must return a dict whose version field is the next version.

        Args:
            data: The parsed document, at ``version``.
            version: Its version, already checked by the caller (an integer, not newer than ``target``).
            target: The version to reach; ``version == target`` returns an unchanged copy.
            source: What the document is, for messages (a file name, ``"library"``).

        Returns:
            A new dict at ``target``.

        Raises:
            SheerError: Of the registry's ``error`` class: no step from some version, a step that
                raised (an error of that class passes through as it is), or a step whose result is not
                a dict at the next version.
        """
        out = copy.deepcopy(data)
        while version < target:
            step = self._steps.get(version)
            if step is None:
                raise self.error(f"{source}: no migration from {VERSION_KEY} {version} to {version + 1}")
            try:
                out = step(out)
            except self.error:
                raise
            except Exception as exc:  # a step that fails on odd data: the caller's data is untouched
                raise self.error(f"{source}: migration from {VERSION_KEY} {version} to {version + 1} failed "
                                 f"({type(exc).__name__}: {exc}); the original is unchanged") from None
            if not isinstance(out, dict) or out.get(VERSION_KEY) != version + 1:
                got = f"{VERSION_KEY} {out.get(VERSION_KEY)!r}" if isinstance(out, dict) else type(out).__name__
                raise self.error(f"{source}: migration from {VERSION_KEY} {version} did not produce version "
                                 f"{version + 1} (it returned {got})")
            version += 1
        return out
