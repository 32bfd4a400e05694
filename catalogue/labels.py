"""Labels: a catalogue's head, look, light, view and product names as they appear in file names.

A label is readable, safe in a file name on every system (ASCII letters, digits, ``.``, ``_``, ``-``) and
the same on every run and machine:

- :func:`label` transliterates a name to ASCII with ``anyascii`` ("Rouge Été" → ``Rouge_Ete``, "日本 1" →
  ``RiBen_1``; the dependency is pinned to its 0.3 tables so a name keeps its label), after Unicode NFC
  normalisation (a name typed precomposed or decomposed is one name). What gives nothing (symbols only)
  or more than :data:`MAX_LABEL` characters gets a short hash of the name instead of, or after, its text;
- :func:`unique_labels` labels the names of one axis so that two different names never share a label:
  names whose labels collide (case-insensitively, as on macOS and Windows file systems) get
  ``-<6 hex digits>``, the start of the SHA-256 of the name — except the one plain-ASCII name of the group,
  if there is exactly one, which keeps its label (its images keep their names when an accented variant is
  added). A collision left after that (a name spelled like another's suffixed label) is a
  :class:`LabelCollision`, refused by the spec.
"""

from __future__ import annotations

import hashlib
import re
import unicodedata
from typing import TYPE_CHECKING

from anyascii import anyascii

if TYPE_CHECKING:
    from collections.abc import Sequence

#: Longest label, characters (a file name holds several, and most file systems allow 255 bytes).
MAX_LABEL = 64
#: Hex digits of the name hash added to a label.
SUFFIX_DIGITS = 6


class LabelCollision(ValueError):
    """Two different names that would still share a label: ``first``, ``second`` and the ``label``."""

    def __init__(self, first: str, second: str, shared: str) -> None:
        super().__init__(f"{first!r} and {second!r} would both be labelled {shared!r}")
        self.first, self.second, self.label = first, second, shared


def normal(name: str) -> str:
    """``name`` in Unicode NFC: the form names are compared and hashed in."""
    return unicodedata.normalize("NFC", name)


def name_hash(name: str) -> str:
    """The first :data:`SUFFIX_DIGITS` hex digits of the SHA-256 of ``name`` (NFC, UTF-8)."""
    return hashlib.sha256(normal(name).encode("utf-8")).hexdigest()[:SUFFIX_DIGITS]


def _with_suffix(base: str, name: str) -> str:
    """``base`` (cut to fit) followed by ``-`` and the name's hash."""
    room = MAX_LABEL - SUFFIX_DIGITS - 1
    return f"{base[:room].rstrip('._-') or 'x'}-{name_hash(name)}"


def label(text: str) -> str:
    """A readable label of ``text`` that is safe in a file name (see the module docstring); never empty."""
    base = re.sub(r"[^A-Za-z0-9._-]+", "_", anyascii(normal(text))).strip("._")
    if not base:
        return _with_suffix("x", text)
    if len(base) > MAX_LABEL:
        return _with_suffix(base, text)
    return base


def unique_labels(names: Sequence[str]) -> list[str]:
    """The label of each of ``names`` (one axis of a catalogue), two different names never sharing one.

    Equal names (after NFC) get equal labels; the caller refuses duplicates.

    Raises:
        LabelCollision: two different names whose labels still collide after the hash suffixes.
    """
    plain = [label(n) for n in names]
    groups: dict[str, set[str]] = {}
    for name, lab in zip(names, plain, strict=True):
        groups.setdefault(lab.casefold(), set()).add(normal(name))
    out: list[str] = []
    for name, lab in zip(names, plain, strict=True):
        group = groups[lab.casefold()]
        ascii_names = [g for g in group if g.isascii()]
        keeps = len(group) == 1 or (len(ascii_names) == 1 and normal(name) == ascii_names[0])
        out.append(lab if keeps else _with_suffix(lab, name))
    seen: dict[str, str] = {}
    for name, lab in zip(names, out, strict=True):
        other = seen.setdefault(lab.casefold(), normal(name))
        if other != normal(name):
            raise LabelCollision(other, normal(name), lab)
    return out
