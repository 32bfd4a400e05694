"""A layer of cosmetic, and what the document and its strokes share: the change event and the error.

A :class:`Layer` is a material (a library name and the library's object) with a float32 thickness map
in µm (``H × W``, top row first). :class:`ChangeEvent` is what a :class:`painting.document.Document`
tells its observers; :class:`DocumentError` is what bad input to it raises. Layers are changed only
through the document (:mod:`painting.document`) and its strokes (:mod:`painting.stroke`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from core.errors import SheerError
from painting.maps_io import MAX_THICKNESS_UM

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


class DocumentError(SheerError, ValueError):
    """Bad input to the document (unknown layer or material, bad value, off-surface point…).

    The document is unchanged when it is raised.
    """


@dataclass(frozen=True)
class ChangeEvent:
    """What changed in a :class:`painting.document.Document` (delivered synchronously to every subscriber).

    Attributes:
        kind: "paint" (thickness texels of ``layer`` changed inside ``tiles``), "layers" (the list or a
            layer's name/visibility/opacity/maximum changed: see ``detail``), "material" (a layer's
            material changed: another one, or its own edited in the library), "library" (the document's
            material library was edited: ``detail`` names the material to show, "" after a removal;
            nothing a project saves changed unless "material" events came with it) or "history" (what
            undo/redo can do changed).
        layer: the layer's id (stable for the document's life), or None.
        tiles: (tile row, tile column) of the touched 64² tiles, for "paint".
        detail: "stroke", "undo", "redo", "fill", "import", "rollback" for paint; "added", "removed",
            "moved", "name", "visible", "opacity", "max_thickness", "mask" (the layer's mask recipe or
            channel was replaced) for layers; "mask" for paint also means the mask's paint channel changed
            inside ``tiles`` (the thickness the renderer shows changed there); "material" (another
            material) or "edited" (the library's material was edited) for material.
    """

    kind: str
    layer: int | None = None
    tiles: tuple[tuple[int, int], ...] = ()
    detail: str = ""


class Layer:
    """One layer of cosmetic: a material and its thickness map (µm).

    Read its fields freely; change them only through the :class:`painting.document.Document`
    (``doc.set_layer``…), which records undo steps and emits events. ``thickness`` is a read-only view
    of the map.

    Args:
        layer_id: the layer's id, stable for the document's life.
        name: the name shown to the user.
        material: the material's library name.
        material_object: the library's material (a :class:`km.material.Material`, or a stand-in with
            the same thickness fields).
        resolution: texels per side of the map (a multiple of 64).
        max_thickness: the most "add" builds up to (µm, > 0).
        default_thickness: what a stroke adds when its brush names no amount (µm, ≥ 0).
    """

    def __init__(self, layer_id: int, name: str, material: str, material_object: Any, resolution: int,
                 max_thickness: float, default_thickness: float) -> None:
        self.id = layer_id
        self.name = name
        self.material = material
        self.material_object = material_object
        self.visible = True
        self.opacity = 1.0
        self.max_thickness = float(max_thickness)
        self.default_thickness = float(default_thickness)
        self.resolution = resolution
        # Filled explicitly (not np.zeros, whose pages the kernel maps on first write) so the map is
        # resident from the start: measured at 4096², first-touch faults made the mean 1 cm dab on a
        # new layer 1.3 ms instead of 0.7 ms; filling costs ~30 ms once, when the layer is added.
        #: the writable map (float32 (H, W), µm): written only by the document, its strokes
        #: (:mod:`painting.stroke`) and their undo records (:mod:`painting.history`), which send the events;
        #: everyone else reads :attr:`thickness`
        self.data = np.empty((resolution, resolution), dtype=np.float32)
        self.data.fill(0.0)
        self._view = self.data.view()
        self._view.flags.writeable = False
        #: the mask's recipe (a :class:`painting.mask.LayerMask`) or None; set through the document
        self.mask: Any = None
        #: the mask's paint channel (float32 (H, W) in [0, 2], neutral 1) or None; see :mod:`painting.mask`
        self.mask_channel: np.ndarray | None = None
        #: the recipe's values at this resolution (float32 (H, W) in [0, 1], read-only) or None; set by the
        #: document with :attr:`mask`
        self.mask_recipe: np.ndarray | None = None

    @property
    def thickness(self) -> np.ndarray:
        """float32 (H, W) thickness in µm (read-only view; padding texels copy their source texel)."""
        return self._view

    @property
    def max_thickness_um(self) -> float:
        """The layer's maximum thickness in µm (the same as ``max_thickness``)."""
        return self.max_thickness

    @property
    def has_mask(self) -> bool:
        """Whether a mask (a recipe or a paint channel) limits where the layer shows."""
        return self.mask is not None or self.mask_channel is not None

    def effective_thickness(self) -> np.ndarray:
        """Thickness as rendered: × opacity × the mask, zero when hidden (a new float32 array, µm)."""
        if not self.visible:
            return np.zeros_like(self.data)
        out = self.data * np.float32(self.opacity)
        if self.mask_recipe is not None:
            m = self.mask_recipe if self.mask_channel is None else \
                self.mask_recipe + (self.mask_channel - np.float32(1.0))
            out *= np.clip(m, 0.0, 1.0)
        elif self.mask_channel is not None:
            out *= np.clip(self.mask_channel, 0.0, 1.0)
        return out

    def __repr__(self) -> str:
        return (f"Layer(id={self.id}, name={self.name!r}, material={self.material!r}, "
                f"resolution={self.resolution}, visible={self.visible}, opacity={self.opacity})")


def thickness_value(value: Any, what: str, positive: bool = False) -> float:
    """``value`` as a number the document accepts for a thickness (µm) or an opacity.

    Finite, in ``[0, MAX_THICKNESS_UM]`` (``(0, …]`` when ``positive``; see :mod:`painting.maps_io`).

    Raises:
        DocumentError: naming ``what`` and the value, when it is not such a number.
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise DocumentError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v < 0 or (positive and v == 0) or v > MAX_THICKNESS_UM:
        raise DocumentError(f"{what} must be a finite number in {'(' if positive else '['}0, "
                            f"{MAX_THICKNESS_UM:g}], got {value!r}")
    return v


def as_vec3(value: ArrayLike, what: str, error: type[SheerError] = DocumentError) -> np.ndarray:
    """``value`` as a float64 (3,) vector (a point in mesh units, or a direction).

    Raises:
        SheerError: ``error`` (a :class:`DocumentError` by default), when it is not 3 finite numbers
            (``what`` names it in the message).
    """
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise error(f"{what} must be 3 numbers (x, y, z), got {value!r}") from None
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise error(f"{what} must be 3 finite numbers (x, y, z), got {value!r}")
    return arr
