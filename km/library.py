"""The material library: a named, ordered set of :class:`km.Material` stored as one JSON file.

File format (UTF-8 JSON, at most :data:`MAX_FILE_BYTES`)::

    {"format": "sheer.materials", "schema_version": 2, "name": str,
     "materials": [<Material.to_json()>, ...]}

Loading is all-or-nothing: the whole file is parsed, migrated and validated before a
:class:`Library` is returned, and any problem raises :class:`LibraryError` naming the file and the
field (``default.json: materials[3].S[12]: negative (-0.5)``).

Schema versions: files written by an older Sheer are upgraded in memory by the steps registered in
:data:`MIGRATIONS` (a :class:`core.migrations.Migrations`: one function per version step, ``v -> v + 1``,
registered with ``@MIGRATIONS.register(v)``); a file from a newer Sheer is refused. Saving is atomic
(:mod:`core.atomicio`): a failed save never damages the file, and the previous file is kept as
``FILE.bak``.

Versions: 1, the materials without ``coverage``; 2 (current), each material states its coverage (or
``null``: none stated, see :mod:`km.coverage`). The step 1 → 2 gives every material ``"coverage": null``,
so a version-1 library loads with the coverage its S and K give, saying so in its provenance.
"""

from __future__ import annotations

import difflib
import functools
import json
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

from core.errors import SheerError
from core.files import read_bounded
from core.migrations import Migrations
from km.material import MAX_NAME_CHARS, Material, MaterialError

if TYPE_CHECKING:
    from collections.abc import Iterable, Iterator

FORMAT = "sheer.materials"
#: The schema version this Sheer writes.
SCHEMA_VERSION = 2
#: Largest library file read, in bytes.
MAX_FILE_BYTES = 32 * 1024 * 1024
#: Most materials in one library.
MAX_MATERIALS = 5000

_NUMBER_LIST_RE = re.compile(r"\[(\s*\n[-+0-9.eE,\s]*?)\]")


class LibraryError(SheerError, ValueError):
    """A library file or operation that cannot be done; the message names the file and field."""


#: ``from_version -> step(data) -> data at from_version + 1``.
MIGRATIONS = Migrations(LibraryError)


@MIGRATIONS.register(1)
def _v1_to_v2(data: dict[str, Any]) -> dict[str, Any]:
    """1 → 2: every material gets ``"coverage": null`` (it states none: its S and K give it on loading)."""
    items = data.get("materials")
    if isinstance(items, list):  # anything else is refused by the validation after the migration
        for m in items:
            if isinstance(m, dict):
                m.setdefault("coverage", None)  # one that has it keeps it (then validated)
    data["schema_version"] = 2
    return data


def migrate(data: dict[str, Any], *, source: str = "library") -> dict[str, Any]:
    """Bring a parsed library dict up to :data:`SCHEMA_VERSION` (a new dict; the input is untouched).

    Raises:
        LibraryError: a missing, invalid, unknown or newer version; a missing or failing step (the
            message names the file and the step).
    """
    if not isinstance(data, dict):
        raise LibraryError(f"{source}: the top level must be a JSON object, got {_json_type(data)}")
    version = data.get("schema_version")
    if version is None:
        raise LibraryError(f"{source}: schema_version: missing (is this a Sheer material library?)")
    if isinstance(version, bool) or not isinstance(version, int):
        raise LibraryError(f"{source}: schema_version: must be an integer, got {_json_type(version)}")
    if version > SCHEMA_VERSION:
        raise LibraryError(f"{source}: schema_version: {version} is newer than this Sheer supports "
                           f"({SCHEMA_VERSION}); update Sheer to open it")
    if version < 1:
        raise LibraryError(f"{source}: schema_version: unknown version {version}")
    return MIGRATIONS.upgrade(data, version=version, target=SCHEMA_VERSION, source=source)


class Library:
    """An ordered collection of materials with unique names (compared case-insensitively).

    Mutating methods (:meth:`add`, :meth:`duplicate`, :meth:`remove`, :meth:`rename`) change only this
    object; :meth:`save` writes it. Materials are immutable values, so a library is cheap to copy.
    """

    def __init__(self, materials: Iterable[Material] = (), *, name: str = "", path: str | Path | None = None):
        self.name: str = name
        #: the file this library was loaded from or last saved to
        self.path: Path | None = Path(path) if path is not None else None
        self._materials: list[Material] = []
        for m in materials:
            self.add(m)

    # ---- container protocol

    def __len__(self) -> int:
        return len(self._materials)

    def __iter__(self) -> Iterator[Material]:
        return iter(list(self._materials))

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and self._index(name) is not None

    def __getitem__(self, name: str) -> Material:
        return self.get(name)

    def __repr__(self) -> str:
        return f"Library({self.name!r}, {len(self)} materials)"

    @property
    def materials(self) -> list[Material]:
        """The materials in order (a new list; the materials themselves are immutable)."""
        return list(self._materials)

    def names(self) -> list[str]:
        """Material names in library order."""
        return [m.name for m in self._materials]

    def categories(self) -> list[str]:
        """Categories present, in order of first appearance."""
        return list(dict.fromkeys(m.category for m in self._materials))

    def copy(self) -> Library:
        """An independent copy (mutating it never affects this library)."""
        return Library(self._materials, name=self.name, path=self.path)

    # ---- lookup

    def _index(self, name: str) -> int | None:
        key = name.strip().casefold()
        for i, m in enumerate(self._materials):
            if m.name.casefold() == key:
                return i
        return None

    def get(self, name: str) -> Material:
        """The material called ``name`` (case-insensitive).

        Raises:
            LibraryError: there is none (the message suggests close matches).
        """
        i = self._index(name)
        if i is None:
            raise LibraryError(self._not_found(name))
        return self._materials[i]

    def by_category(self, category: str) -> list[Material]:
        """Materials whose category is ``category`` (case-insensitive), in library order."""
        key = category.strip().casefold()
        return [m for m in self._materials if m.category == key]

    def _not_found(self, name: str) -> str:
        names = self.names()
        lowered = {n.casefold(): n for n in names}
        close = [lowered[c] for c in difflib.get_close_matches(name.casefold(), list(lowered), n=4, cutoff=0.5)]
        close += [n for n in names if name.casefold() in n.casefold() and n not in close][: 4 - len(close)]
        where = f" in {self.path.name}" if self.path else ""
        hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else \
            f"; {len(names)} materials available (see 'sheer materials list')"
        return f"no material named {name!r}{where}{hint}"

    # ---- editing

    def add(self, material: Material, *, replace: bool = False) -> Material:
        """Append ``material``.

        A material with the same name (case-insensitive) is an error unless ``replace`` (then it is
        replaced in place).
        """
        if not isinstance(material, Material):
            raise TypeError(f"expected a Material, got {type(material).__name__}")
        i = self._index(material.name)
        if i is not None:
            if not replace:
                raise LibraryError(f"a material named {self._materials[i].name!r} already exists")
            self._materials[i] = material
            return material
        if len(self._materials) >= MAX_MATERIALS:
            raise LibraryError(f"a library holds at most {MAX_MATERIALS} materials")
        self._materials.append(material)
        return material

    def remove(self, name: str) -> Material:
        """Remove and return the material called ``name``."""
        i = self._index(name)
        if i is None:
            raise LibraryError(self._not_found(name))
        return self._materials.pop(i)

    def rename(self, old: str, new: str) -> Material:
        """Rename a material (the new name must be free, except a change of case of the same name)."""
        i = self._index(old)
        if i is None:
            raise LibraryError(self._not_found(old))
        j = self._index(new)
        if j is not None and j != i:
            raise LibraryError(f"a material named {self._materials[j].name!r} already exists")
        try:
            renamed = self._materials[i].replace(name=new)
        except MaterialError as exc:
            raise LibraryError(f"cannot rename to {new!r}: {exc.reason}") from None
        self._materials[i] = renamed
        return renamed

    def duplicate(self, name: str, new_name: str | None = None) -> Material:
        """Copy the material ``name`` under ``new_name``, inserted right after it; returns the copy.

        ``new_name`` defaults to ``"<name> copy"`` (``"<name> copy 2"``… when taken).
        """
        i = self._index(name)
        if i is None:
            raise LibraryError(self._not_found(name))
        src = self._materials[i]
        if new_name is None:
            new_name = self.unique_name(f"{src.name} copy")
        elif self._index(new_name) is not None:
            raise LibraryError(f"a material named {new_name!r} already exists")
        try:
            dup = src.replace(name=new_name)
        except MaterialError as exc:
            raise LibraryError(f"cannot duplicate as {new_name!r}: {exc.reason}") from None
        self._materials.insert(i + 1, dup)
        return dup

    def unique_name(self, base: str) -> str:
        """A free material name: ``base``, else the first unused of ``"base 2"``, ``"base 3"`` and so on.

        The name is cut to fit :data:`MAX_NAME_CHARS` with its suffix; an empty one becomes "material".
        """
        base = base.strip()[: MAX_NAME_CHARS - 6] or "material"
        if self._index(base) is None:
            return base
        n = 2
        while self._index(f"{base} {n}") is not None:
            n += 1
        return f"{base} {n}"

    # ---- JSON

    def to_json(self) -> dict[str, Any]:
        """The library as a JSON-ready dict (see the module docstring)."""
        return {"format": FORMAT, "schema_version": SCHEMA_VERSION, "name": self.name,
                "materials": [m.to_json() for m in self._materials]}

    def dumps(self) -> str:
        """The file content (deterministic).

        Indented JSON with each list of numbers on one line, shortest round-trip floats (bit-identical
        on reload), a final newline.
        """
        text = json.dumps(self.to_json(), indent=1, ensure_ascii=False, allow_nan=False)
        # Only lists that the indenter spread over several lines are joined; JSON strings never hold a
        # raw newline, so text inside strings is never touched.
        return _NUMBER_LIST_RE.sub(lambda m: "[" + ", ".join(x.strip() for x in m.group(1).split(",")) + "]",
                                   text) + "\n"

    @classmethod
    def from_json(cls, data: Any, *, source: str = "library", path: str | Path | None = None) -> Library:
        """Migrate and validate a parsed library dict; errors are prefixed with ``source``."""
        d = migrate(data, source=source)
        allowed = {"format", "schema_version", "name", "materials"}
        unknown = sorted(str(k) for k in d if k not in allowed)
        if unknown:
            raise LibraryError(f"{source}: unknown field{'s' if len(unknown) > 1 else ''} {', '.join(unknown)}")
        if d.get("format") != FORMAT:
            raise LibraryError(f"{source}: format: expected {FORMAT!r}, got {d.get('format')!r}")
        name = d.get("name", "")
        if not isinstance(name, str) or len(name) > MAX_NAME_CHARS:
            raise LibraryError(f"{source}: name: must be a string of at most {MAX_NAME_CHARS} characters")
        items = d.get("materials")
        if not isinstance(items, list):
            raise LibraryError(f"{source}: materials: must be a list, got {_json_type(items)}")
        if len(items) > MAX_MATERIALS:
            raise LibraryError(f"{source}: materials: {len(items)} materials, at most {MAX_MATERIALS}")
        materials: list[Material] = []
        seen: dict[str, int] = {}
        for i, item in enumerate(items):
            try:
                m = Material.from_json(item, where=f"materials[{i}]")
            except MaterialError as exc:
                raise LibraryError(f"{source}: {exc}") from None
            key = m.name.casefold()
            if key in seen:
                raise LibraryError(f"{source}: materials[{i}].name: {m.name!r} duplicates the name of "
                                   f"materials[{seen[key]}]")
            seen[key] = i
            materials.append(m)
        return cls(materials, name=name, path=path)

    @classmethod
    def loads(cls, text: str | bytes, *, source: str = "library", path: str | Path | None = None) -> Library:
        """Parse, migrate and validate library JSON text."""
        if isinstance(text, bytes):
            try:
                text = text.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise LibraryError(f"{source}: not UTF-8 text (byte {exc.start})") from None
        try:
            data = json.loads(text, parse_constant=_reject_constant)
        except _ConstantError as exc:
            raise LibraryError(f"{source}: {exc.args[0]} is not valid JSON (non-finite numbers are not "
                               "allowed)") from None
        except json.JSONDecodeError as exc:
            raise LibraryError(f"{source}: not valid JSON: {exc.msg} at line {exc.lineno} column {exc.colno}"
                               ) from None
        except RecursionError:
            raise LibraryError(f"{source}: JSON nested too deeply") from None
        return cls.from_json(data, source=source, path=path)

    @classmethod
    def load(cls, path: str | Path) -> Library:
        """Read a library file (all-or-nothing; see the module docstring)."""
        p = Path(path)
        raw = read_bounded(p, MAX_FILE_BYTES, "library file", LibraryError)
        return cls.loads(raw, source=str(p), path=p)

    def save(self, path: str | Path | None = None, *, keep_backup: bool = True) -> Path:
        """Write the library atomically to ``path`` (default: where it was loaded from).

        The previous file is kept as ``FILE.bak`` unless ``keep_backup=False``. Returns the path written.
        """
        from core.atomicio import atomic_write_text

        target = Path(path) if path is not None else self.path
        if target is None:
            raise LibraryError("the library has no file yet: give a path to save it to")
        text = self.dumps()  # serialise first: a failure here never touches the file
        try:
            atomic_write_text(target, text, keep_backup=keep_backup)
        except OSError as exc:
            raise LibraryError(f"{target}: cannot save: {exc.strerror or exc}") from None
        self.path = target
        return target


class _ConstantError(ValueError):
    pass


def _reject_constant(name: str) -> Any:
    raise _ConstantError(name)


def _json_type(value: Any) -> str:
    return {dict: "an object", list: "a list", str: "a string", bool: "a boolean", int: "a number",
            float: "a number", type(None): "null"}.get(type(value), type(value).__name__)


# --------------------------------------------------------------------------------------------------


def default_library_path() -> Path:
    """``resources/materials/default.json``."""
    from core.assets import resource_path

    return resource_path("materials", "default.json")


@functools.lru_cache(maxsize=1)
def _cached_default() -> Library:
    return Library.load(default_library_path())


def default_library() -> Library:
    """The default library shipped with Sheer.

    Loaded once; each call returns an independent copy, safe to mutate, whose ``path`` is None so that
    saving it needs an explicit path.
    """
    lib = _cached_default().copy()
    lib.path = None
    return lib
