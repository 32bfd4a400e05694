"""The material library editor's undoable edits (``QUndoCommand``s) and Duncan shade mixing."""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np
from PySide6.QtGui import QUndoCommand

if TYPE_CHECKING:
    from km.library import Library
    from km.material import Material


#: The properties the editor's fields set, with the type each value is converted to.
EDITABLE = {"category": str, "thickness_um": float, "max_thickness_um": float, "roughness": float,
            "ior": float}


class LibraryView(Protocol):
    """What an undo step needs of the library editor (:class:`app.studio.library_dock.LibraryDock`)."""

    library: Library
    current: str | None

    def changed(self, name: str | None, renamed_from: str | None = None) -> None:
        """The library changed: show ``name`` (None: the set of materials changed)."""


class SetAttr(QUndoCommand):
    """Set one property (or spectrum, ``"S"``/``"K"`` per mm) of material ``name`` from ``old`` to ``new``."""

    def __init__(self, dock: LibraryView, name: str, attr: str, old: object, new: object) -> None:
        super().__init__(f"{attr} of {name}")
        self.dock, self.name, self.attr, self.old, self.new = dock, name, attr, old, new

    def _apply(self, value: object) -> None:
        lib = self.dock.library
        lib.add(lib.get(self.name).replace(**{self.attr: value}), replace=True)
        self.dock.changed(self.name)

    def redo(self) -> None:
        """Do the step (Qt calls it when the step is pushed, and on redo)."""
        self._apply(self.new)

    def undo(self) -> None:
        """Revert the step."""
        self._apply(self.old)


class Rename(QUndoCommand):
    """Rename material ``old`` to ``new``."""

    def __init__(self, dock: LibraryView, old: str, new: str) -> None:
        super().__init__(f"rename {old}")
        self.dock, self.old, self.new = dock, old, new

    def redo(self) -> None:
        """Do the step (Qt calls it when the step is pushed, and on redo)."""
        self.dock.library.rename(self.old, self.new)
        self.dock.changed(self.new, renamed_from=self.old)

    def undo(self) -> None:
        """Revert the step."""
        self.dock.library.rename(self.new, self.old)
        self.dock.changed(self.old, renamed_from=self.new)


class Add(QUndoCommand):
    """Add ``material`` to the library."""

    def __init__(self, dock: LibraryView, material: Material) -> None:
        super().__init__(f"add {material.name}")
        self.dock, self.material = dock, material

    def redo(self) -> None:
        """Do the step (Qt calls it when the step is pushed, and on redo)."""
        self.dock.library.add(self.material)
        self.dock.changed(self.material.name)

    def undo(self) -> None:
        """Revert the step."""
        self.dock.library.remove(self.material.name)
        self.dock.changed(None)


class Remove(QUndoCommand):
    """Remove ``material`` from the library (undo adds it back)."""

    def __init__(self, dock: LibraryView, material: Material) -> None:
        super().__init__(f"delete {material.name}")
        self.dock, self.material = dock, material

    def redo(self) -> None:
        """Do the step (Qt calls it when the step is pushed, and on redo)."""
        self.dock.library.remove(self.material.name)
        self.dock.current = None
        self.dock.changed(None)

    def undo(self) -> None:
        """Revert the step."""
        self.dock.library.add(self.material)
        self.dock.changed(self.material.name)


class AddMany(QUndoCommand):
    """Add ``materials`` to the library as one step (an imported measurement file)."""

    def __init__(self, dock: LibraryView, materials: list[Material], title: str) -> None:
        super().__init__(title)
        self.dock, self.materials = dock, materials

    def redo(self) -> None:
        """Do the step (Qt calls it when the step is pushed, and on redo)."""
        for m in self.materials:
            self.dock.library.add(m)
        self.dock.changed(self.materials[-1].name)

    def undo(self) -> None:
        """Revert the step."""
        for m in self.materials:
            self.dock.library.remove(m.name)
        self.dock.changed(None)


def duncan_mix(a: Material, b: Material, fraction_b: float, name: str) -> Material:
    """A new material ``name`` mixing ``a`` and ``b`` by Duncan's rule (``km.optics.mix``).

    S and K (per mm) are the concentration-weighted sums, ``fraction_b`` in [0, 1] of ``b`` (clipped), on
    ``a``'s wavelength grid (``b``'s spectra interpolated onto it).
    """
    from km.optics import mix

    wl = np.asarray(a.wavelengths, float)
    sb = np.interp(wl, np.asarray(b.wavelengths, float), np.asarray(b.S, float))
    kb = np.interp(wl, np.asarray(b.wavelengths, float), np.asarray(b.K, float))
    c = float(np.clip(fraction_b, 0.0, 1.0))
    S, K = mix([(1.0 - c, np.asarray(a.S, float), np.asarray(a.K, float)), (c, sb, kb)])
    return a.replace(name=name, S=S, K=K, measurement=None, source="modelled",
                     provenance=f"Duncan mix: {1 - c:.0%} {a.name} + {c:.0%} {b.name}")
