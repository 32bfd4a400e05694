"""Layer masks reach the renderer (render.binding): the thickness uploaded is the map × the mask; a mask
edit re-evaluates the layers, a dab on the mask's channel only its tiles, and undo brings the render back."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from painting.tiles import TILE

if TYPE_CHECKING:
    from render.renderer import Renderer

pytestmark = pytest.mark.gl


def _uploaded(r: Renderer, slot: int) -> np.ndarray:
    tex = r.km.thickness_textures[slot]
    return np.frombuffer(tex.read(), dtype=np.float32).reshape(tex.height, tex.width)


def test_mask_multiplies_the_uploaded_thickness_and_follows_edits(doc: Any, renderer: Renderer,
                                                                  gl_ctx: Any) -> None:
    from painting import Brush, LayerMask
    from render.binding import DocumentBinding, layer_inputs

    lay = doc.add_layer("Lipstick Classic Red")
    doc.fill(lay, 20.0)  # everywhere: the mask alone decides where it shows
    binding = DocumentBinding(doc, renderer)
    try:
        binding.flush()
        full = _uploaded(renderer, 0).copy()
        assert full.max() == pytest.approx(20.0)
        doc.set_layer_mask(lay, LayerMask((("union", "lips"),)))
        assert binding.full  # a mask edit re-reads the layers
        binding.flush()
        lips = doc.region_values("lips", lay.resolution)
        np.testing.assert_allclose(_uploaded(renderer, 0), np.asarray(lay.thickness) * lips, atol=1e-5)
        # a dab on the mask's channel (erase = hide) re-uploads only its tiles
        lm = doc.head.metadata.landmarks
        with doc.mask_stroke(lay, Brush(radius_mm=4.0, mode="erase")) as s:
            s.dab(lm["lower_lip"])
        assert binding.full  # the new channel (a mask edit) came first
        binding.flush()
        version = renderer.km.version
        prev = _uploaded(renderer, 0).copy()
        with doc.mask_stroke(lay, Brush(radius_mm=4.0, mode="erase")) as s:
            s.dab(lm["upper_lip"])
        assert not binding.full and set(binding.dirty) == {lay.id}
        tiles = binding.dirty[lay.id]
        binding.flush()
        assert renderer.km.version == version + 1  # a tile update, not a full evaluation
        expected = np.asarray(layer_inputs(doc)[0].thickness)
        got = _uploaded(renderer, 0)
        np.testing.assert_allclose(got, expected, atol=1e-5)
        rows, cols = np.nonzero(got != prev)  # the dab hid some lip texels, all inside its tiles
        assert len(rows) and {(int(y) // TILE, int(x) // TILE) for y, x in zip(rows, cols)} <= set(tiles)
        # undo everything back to the unmasked layer (2 strokes, the new channel, the recipe)
        for _ in range(4):
            doc.undo()
        assert not lay.has_mask
        binding.flush()
        np.testing.assert_array_equal(_uploaded(renderer, 0), full)  # float texels uploaded and read back
    finally:
        binding.close()
        doc.remove_layer(lay)


def test_mask_undo_redo_is_bit_exact(doc: Any) -> None:
    from painting import Brush, LayerMask

    lay = doc.add_layer("Lipstick Classic Red")
    doc.set_layer_mask(lay, LayerMask((("union", "lips"), ("subtract", "upper_lip")), feather_mm=0.5))
    before = doc.mask_values(lay).copy()
    with doc.mask_stroke(lay, Brush(radius_mm=6.0, mode="add", amount_um=2.0)) as s:
        s.dab(doc.head.metadata.landmarks["upper_lip"])
    painted = doc.mask_values(lay).copy()
    assert not np.array_equal(painted, before)
    doc.undo()
    np.testing.assert_array_equal(doc.mask_values(lay), before)
    doc.redo()
    np.testing.assert_array_equal(doc.mask_values(lay), painted)
    doc.undo()
    doc.undo()
    doc.undo()
    assert doc.mask_values(lay) is None
    doc.remove_layer(lay)
