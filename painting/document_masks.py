"""The document's regions and layer masks (a mixin of :class:`painting.document.Document`).

Every edit here is one undo step and sends the events the renderer follows: replacing a layer's mask
sends ``ChangeEvent("layers", id, detail="mask")``; painting its channel sends ``"paint"`` events for
the layer's id with the touched tiles (so only those tiles are uploaded again).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from painting.brush import Brush, BrushError
from painting.history import Step
from painting.layer import ChangeEvent, DocumentError, thickness_value
from painting.mask import (
    LayerMask,
    MaskChannel,
    check_channel,
    layer_mask_values,
    neutral_channel,
    recipe_values,
)
from painting.region_shapes import regions_for
from painting.regions import REGION_RESOLUTION, RegionError, RegionSet
from painting.stroke import Stroke

if TYPE_CHECKING:
    from collections.abc import Callable

    from painting.atlas import Atlas
    from painting.head import Head
    from painting.history import History
    from painting.layer import Layer
    from painting.layout import UVLayout


#: Bump when the cached derived regions' format changes.
_REGIONS_CACHE_VERSION = 1
#: The code that derives the regions: a change of it is a new entry (:func:`core.cache.source_digest`).
_REGIONS_SOURCES: tuple[Path, ...] = (Path(__file__).with_name("regions.py"),
                                      Path(__file__).with_name("region_shapes.py"))


class MaskEditing:
    """Regions and layer masks of a document (mixed into :class:`painting.document.Document`)."""

    head: Head
    layout: UVLayout
    history: History
    _regions: RegionSet | None = None

    if TYPE_CHECKING:  # the document's public API, which this part uses
        def resolve(self, layer: Layer | int) -> Layer: ...  # noqa: D102
        def atlas_at(self, resolution: int) -> Atlas: ...  # noqa: D102
        def require_idle(self, what: str) -> None: ...  # noqa: D102
        def push_step(self, step: Step) -> None: ...  # noqa: D102
        def emit(self, event: ChangeEvent) -> None: ...  # noqa: D102

    @property
    def regions(self) -> RegionSet:
        """The head's facial regions (:func:`painting.region_shapes.regions_for`; read or derived on first use)."""
        if self._regions is None:
            stored = regions_for(self.head)
            if all(why == "no atlas to derive them on" for why in stored.missing.values()) and stored.missing:
                stored = self._derived_regions()
            self._regions = stored
        return self._regions

    def _derived_regions(self) -> RegionSet:
        """The head's regions derived on its layout, through the cache (the ``looks`` kind).

        Always as stored (8-bit, :func:`painting.regions.encode_regions`), so the first use and later
        ones paint the same.
        """
        from core.cache import load_arrays, save_arrays
        from painting.regions import decode_regions, encode_regions

        path = self._regions_cache_path()
        cached = load_arrays(path, _REGIONS_CACHE_VERSION)
        if cached is not None and "png" in cached:
            try:
                return decode_regions(cached["png"].tobytes(), str(path), self.head.name)
            except RegionError:
                pass  # a damaged entry: derive again
        derived = regions_for(self.head, self.atlas_at(REGION_RESOLUTION), head_uv=self.layout.source == "mesh")
        if not derived.regions:
            return derived
        blob = encode_regions(derived)
        save_arrays(path, {"png": np.frombuffer(blob, np.uint8)}, _REGIONS_CACHE_VERSION)
        return decode_regions(blob, "derived regions", self.head.name)

    def _regions_cache_path(self) -> Path:
        """The cache entry of the derived regions (the ``looks`` kind).

        Keyed by the layout, the head's metadata, albedo and skin mask, and the deriving code
        (:data:`_REGIONS_SOURCES`).
        """
        import hashlib
        import json

        from core.cache import cache_dir, source_digest

        h = hashlib.sha256(f"{self.layout.key}|{self.layout.source}|".encode())
        h.update(json.dumps(self.head.metadata.to_json(), sort_keys=True).encode())
        for image in (self.head.albedo, self.head.skin_mask):
            h.update(b"-" if image is None else np.ascontiguousarray(image).tobytes())
        h.update(source_digest(_REGIONS_SOURCES).encode())
        return cache_dir("looks") / f"regions-{h.hexdigest()[:32]}.cache"

    def region_values(self, name: str, resolution: int) -> np.ndarray:
        """Region ``name`` at ``resolution``² texels (float32 [0, 1]); :class:`DocumentError` naming it if absent."""
        try:
            return self.regions.at(name, resolution)
        except RegionError as exc:
            raise DocumentError(str(exc)) from None

    # ------------------------------------------------------------------------------ masks
    def set_layer_mask(self, layer: Layer | int, mask: LayerMask | None,
                       channel: np.ndarray | None = None) -> None:
        """Give ``layer`` a mask recipe and/or paint channel (None clears each); one undo step.

        Args:
            layer: a layer of this document, or its index.
            mask: the recipe (:class:`painting.mask.LayerMask`; its regions must be the head's), or None.
            channel: the paint channel (float32 (H, W) of the layer, values in [0, 2], neutral 1), or None;
                copied.

        Raises:
            DocumentError: an unknown or missing region (named), a bad op or feather, or a channel of
                the wrong size or range; the document is unchanged.
        """
        self.require_idle("change a mask")
        lay = self.resolve(layer)
        if mask is not None and not isinstance(mask, LayerMask):
            raise DocumentError(f"mask must be a painting.LayerMask or None, got {type(mask).__name__}")
        recipe = None
        if mask is not None:
            mask.validate(self.regions)
            recipe = recipe_values(mask, self.regions, lay.resolution, self.atlas_at(lay.resolution).texel_mm)
            recipe.flags.writeable = False
        new_channel = None if channel is None else check_channel(channel, lay)
        old = (lay.mask, lay.mask_channel, lay.mask_recipe)
        new = (mask, new_channel, recipe)

        def apply(values: tuple[Any, np.ndarray | None, np.ndarray | None]) -> Callable[[], None]:
            def run() -> None:
                lay.mask, lay.mask_channel, lay.mask_recipe = values
                self.emit(ChangeEvent("layers", lay.id, detail="mask"))
            return run

        apply(new)()
        nbytes = sum(a.nbytes for a in (new_channel, recipe, old[1], old[2]) if a is not None)
        self.push_step(Step(f"mask of {lay.name}", undo_fn=apply(old), redo_fn=apply(new), extra_bytes=nbytes))

    def mask_values(self, layer: Layer | int) -> np.ndarray | None:
        """The mask ``layer`` is rendered with (float32 (H, W) in [0, 1]), or None when it has none."""
        return layer_mask_values(self.resolve(layer))

    def mask_stroke(self, layer: Layer | int, brush: Brush, mirror: bool | None = None) -> Stroke:
        """Begin a stroke on ``layer``'s mask channel (as :meth:`stroke`): add reveals, erase hides.

        A layer without a channel gets a neutral one first (its own undo step). Values are channel units
        (see :mod:`painting.mask`): "add" raises towards 2 (its amount defaults to 2), "erase" lowers
        towards 0, "set" with ``amount_um=1`` restores the recipe.
        """
        self.require_idle("paint a mask")
        lay = self.resolve(layer)
        try:
            brush.validate()
        except BrushError as exc:
            raise DocumentError(str(exc)) from None
        if lay.mask_channel is None:
            self.set_layer_mask(lay, lay.mask, neutral_channel(lay.resolution))
        assert lay.mask_channel is not None
        target = MaskChannel(lay, lay.mask_channel)
        return Stroke(self, target, brush, brush.mirror if mirror is None else bool(mirror),  # type: ignore[arg-type]
                      detail="mask")

    def fill_region(self, layer: Layer | int, region: str, thickness_um: float | None = None) -> None:
        """Fill ``region`` of ``layer`` to ``thickness_um`` with the region's soft edge; one undo step.

        Each texel moves from its thickness ``t`` to ``t + (value − t) · m``, ``m`` the region's mask
        there (so the feather is a soft falloff); ``thickness_um`` (µm) defaults to the material's
        default thickness and is clamped to the layer's maximum.
        """
        self.require_idle("fill a region")
        lay = self.resolve(layer)
        weights = self.region_values(region, lay.resolution)
        value = lay.default_thickness if thickness_um is None else thickness_value(thickness_um,
                                                                                           "fill thickness")
        with Stroke(self, lay, Brush(mode="set"), False, detail="fill") as s:  # type: ignore[arg-type]
            s.fill_soft(weights.reshape(-1), min(value, lay.max_thickness))
