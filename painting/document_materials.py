"""The document's material library edits (a mixin of :class:`painting.document.Document`).

A layer names its material (``layer.material``) and holds the library's object (``layer.material_object``),
which is what a renderer draws and what a project embeds. So that the two never part, the library a
document paints with is edited only here: :meth:`MaterialEditing.replace_material` puts the new material
in the library *and* on every layer of it, as one undo step on the document's history (the same stack as
strokes). The studio's Material Library edits through these methods.

Events: each layer whose material was replaced gets ``ChangeEvent("material", id, detail="edited")`` (its
saved material changed: the renderer evaluates it again, the document is modified); every edit, and its
undo, then sends ``ChangeEvent("library", detail=NAME)``, ``NAME`` the material to show ("" when one was
removed). A "library" event alone changes nothing a project saves.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol, cast

from core.errors import SheerError
from painting.history import Step
from painting.layer import ChangeEvent, DocumentError

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator, Sequence

    from painting.history import History
    from painting.layer import Layer


class EditableLibrary(Protocol):
    """A material library the document can edit (:class:`km.library.Library`)."""

    def get(self, name: str) -> Any:
        """The material called ``name`` (case-insensitive)."""
        ...

    def add(self, material: Any, *, replace: bool = False) -> Any:
        """Append ``material``, or with ``replace`` put it in place of the one of its name."""
        ...

    def remove(self, name: str) -> Any:
        """Remove and return the material ``name``."""
        ...

    def rename(self, old: str, new: str) -> Any:
        """Rename a material in place."""
        ...

    def __contains__(self, name: object) -> bool: ...  # noqa: D105

    def __iter__(self) -> Iterator[Any]: ...  # noqa: D105


def material_thicknesses(material: Any) -> tuple[float, float]:
    """(default, maximum) thickness in µm a layer of ``material`` takes from it."""
    default = getattr(material, "default_thickness_um", None)
    thickness = float(getattr(material, "thickness_um", 20.0) if default is None else default)
    return thickness, float(getattr(material, "max_thickness_um", 100.0))


def _key(name: str) -> str:
    return name.strip().casefold()


class MaterialEditing:
    """Edits of the document's material library that its layers follow (mixed into ``Document``)."""

    history: History

    if TYPE_CHECKING:  # the document's public API, which this part uses
        @property
        def library(self) -> Any: ...  # noqa: D102
        @property
        def layers(self) -> list[Layer]: ...  # noqa: D102
        def require_idle(self, what: str) -> None: ...  # noqa: D102
        def push_step(self, step: Step) -> None: ...  # noqa: D102
        def emit(self, event: ChangeEvent) -> None: ...  # noqa: D102

    def _editable_library(self) -> EditableLibrary:
        lib = self.library
        if not all(hasattr(lib, m) for m in ("add", "remove", "rename", "__contains__", "__iter__")):
            raise DocumentError(f"this document's material library ({type(lib).__name__}) cannot be edited")
        return cast("EditableLibrary", lib)

    def layers_using(self, name: str) -> list[Layer]:
        """The layers whose material is the library's ``name`` (case-insensitive), bottom first."""
        return [lay for lay in self.layers if _key(lay.material) == _key(name)]

    def replace_material(self, name: str, material: Any, label: str = "") -> None:
        """Make ``material`` the library's ``name`` and every layer's of it, as one undo step.

        ``material`` may carry another name (a rename: it must be free). Layers of it take its name, the
        object and its default thickness (their own maximum thickness stays theirs).

        Args:
            name: a material of the document's library.
            material: its replacement (a :class:`km.material.Material`).
            label: the undo step's label (default "edit NAME").

        Raises:
            DocumentError: an unknown ``name``, a new name already taken, or a material the library
                refuses; the document and the library are unchanged then.
        """
        self.require_idle("edit a material")
        lib = self._editable_library()
        try:
            old = lib.get(name)
        except (SheerError, KeyError, LookupError) as exc:
            raise DocumentError(f"unknown material {name!r}: {exc}") from None
        new_name = getattr(material, "name", None)
        if not isinstance(new_name, str) or not new_name.strip():
            raise DocumentError(f"the replacement of {old.name!r} has no name")
        if _key(new_name) != _key(old.name) and new_name in lib:
            raise DocumentError(f"a material named {new_name!r} already exists")
        if material is old:
            return

        def put(src: Any, dst: Any) -> Callable[[], None]:
            def run() -> None:
                if src.name != dst.name:
                    lib.rename(src.name, dst.name)
                lib.add(dst, replace=True)
                default, _ = material_thicknesses(dst)
                for lay in self.layers_using(src.name):
                    lay.material, lay.material_object, lay.default_thickness = dst.name, dst, default
                    self.emit(ChangeEvent("material", lay.id, detail="edited"))
                self.emit(ChangeEvent("library", detail=dst.name))
            return run

        try:
            put(old, material)()
        except (SheerError, TypeError, ValueError) as exc:  # the library refused it: undo a half-done rename
            if old.name not in lib and new_name in lib:
                lib.rename(new_name, old.name)
            lib.add(old, replace=True)
            raise DocumentError(f"material {old.name!r} cannot be replaced: {exc}") from None
        self.push_step(Step(label or f"edit {old.name}", undo_fn=put(material, old),
                            redo_fn=put(old, material)))

    def add_materials(self, materials: Sequence[Any], label: str = "") -> None:
        """Add ``materials`` (new names) to the library as one undo step.

        Raises:
            DocumentError: a name already taken, or a material the library refuses (nothing is added).
        """
        self.require_idle("add materials")
        lib = self._editable_library()
        mats = list(materials)
        if not mats:
            return
        names = [_key(getattr(m, "name", "")) for m in mats]
        taken = [m.name for m in mats if m.name in lib]
        if taken or len(set(names)) != len(names):
            raise DocumentError(f"a material named {(taken or [mats[-1].name])[0]!r} already exists")

        def remove() -> None:
            for m in reversed(mats):
                lib.remove(m.name)
            self.emit(ChangeEvent("library", detail=""))

        def add() -> None:
            done = []
            try:
                for m in mats:
                    lib.add(m)
                    done.append(m)
            except (SheerError, TypeError, ValueError) as exc:
                for m in reversed(done):
                    lib.remove(m.name)
                raise DocumentError(f"material {getattr(m, 'name', m)!r} cannot be added: {exc}") from None
            self.emit(ChangeEvent("library", detail=mats[-1].name))

        add()
        self.push_step(Step(label or f"add {mats[-1].name}", undo_fn=remove, redo_fn=add))

    def remove_material(self, name: str, label: str = "") -> None:
        """Remove material ``name`` from the library (one undo step; undo puts it back where it was).

        Raises:
            DocumentError: an unknown name, or a material a layer uses.
        """
        self.require_idle("remove a material")
        lib = self._editable_library()
        if name not in lib:
            raise DocumentError(f"unknown material {name!r}")
        users = self.layers_using(name)
        if users:
            raise DocumentError(f"'{lib.get(name).name}' is used by the layer '{users[0].name}'; change that "
                                f"layer's material first")
        order = [m.name for m in lib]
        mat = lib.get(name)
        pos = order.index(mat.name)

        def remove() -> None:
            lib.remove(mat.name)
            self.emit(ChangeEvent("library", detail=""))

        def restore() -> None:
            after = list(lib)[pos:]
            lib.add(mat)
            for m in after:  # back in its place: the ones after it move behind it again
                lib.add(lib.remove(m.name))
            self.emit(ChangeEvent("library", detail=mat.name))

        remove()
        self.push_step(Step(label or f"delete {mat.name}", undo_fn=restore, redo_fn=remove))
