"""Errors raised while reading or writing a ``.sheer`` project (see ``docs/FORMAT.md``).

All of them are :class:`ProjectError`, a :class:`core.errors.SheerError` and a ``ValueError``, whose
message names the file, the entry (or JSON path) and the problem. The subclasses let the studio react
to the cases it can do something about:

- :class:`HeadChecksumError` / :class:`HeadMissingError`: offer to relink the head
  (``open_project(path, head_path=NEW)`` or ``accept_head_change=True``);
- :class:`ProjectVersionError`: the file was written by a newer Sheer;
- :class:`MigrationError`: an older file could not be upgraded (the original is untouched).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from core.errors import SheerError

if TYPE_CHECKING:
    from pathlib import Path


class ProjectError(SheerError, ValueError):
    """A project file that cannot be used; the message names the file, the entry and the problem."""


class ProjectContainerError(ProjectError):
    """The zip container itself is unsafe or damaged (names, links, sizes, CRC, not a zip)."""


class ProjectVersionError(ProjectError):
    """The project's ``schema_version`` is newer than this Sheer reads (or not a version at all)."""


class MigrationError(ProjectError):
    """Upgrading an older project failed; the original data (and file) is left as it was."""


class HeadMissingError(ProjectError):
    """The referenced head file is not where the project says (offer to relink).

    Attributes: ``head_path`` (where it was looked for).
    """

    def __init__(self, message: str, head_path: Path | None = None) -> None:
        super().__init__(message)
        self.head_path = head_path


class HeadChecksumError(ProjectError):
    """A file of the referenced head no longer has the SHA-256 recorded in the project.

    The studio offers to relink the head, or to accept the changed head.

    Attributes: ``head_path``, ``file`` (the changed file, relative to the head's folder),
    ``expected`` and ``actual`` (hex digests; ``actual`` is None when the file is gone).
    """

    def __init__(self, message: str, head_path: Path | None = None, file: str = "",
                 expected: str = "", actual: str | None = None) -> None:
        super().__init__(message)
        self.head_path = head_path
        self.file = file
        self.expected = expected
        self.actual = actual
