"""Shared set-up of the project tests: a lipstick layer painted with a region mask, as a designer makes it."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from painting import Document, Layer, LayerMask


def masked_lipstick(doc: Document, mask: LayerMask) -> Layer:
    """A "Lipstick" layer of Lipstick Classic Red on ``doc``, filled at 20 µm, with ``mask``."""
    lay = doc.add_layer("Lipstick Classic Red", name="Lipstick")
    doc.fill(lay, 20.0)
    doc.set_layer_mask(lay, mask)
    return lay
