"""The texture-space lighting cache (render.lit_cache) on llvmpipe: it equals the direct path on skin, is
recomputed whole when a light, the environment or a material changes, and only over a dab's tiles."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from render.km_pass import LayerInput
from render.lights import Light
from render.renderer import Renderer

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator

pytestmark = pytest.mark.gl
SIZE = (480, 360)


@pytest.fixture(scope="module")
def doc() -> Any:
    from painting import Document
    from painting.looks import apply_look

    d = Document.from_head(resolution=512)
    apply_look(d, "evening")
    return d


def inputs(doc: Any) -> list[LayerInput]:
    return [LayerInput(lay.material_object, np.array(lay.thickness), lay.opacity, lay.visible, lay.name)
            for lay in doc.layers]


@pytest.fixture(scope="module")
def renderer(_gl_session_ctx: Any, doc: Any) -> Iterator[Renderer]:
    r = Renderer(_gl_session_ctx, doc.head, layout=doc.layout)
    r.lights = [Light.directional(35.0, 25.0, 1.5), Light.directional(-45.0, 5.0, 0.35, shadows=False)]
    r.set_layers(inputs(doc))
    yield r
    r.release()


def settled(r: Renderer) -> np.ndarray:
    """A frame with the lights at rest (the second frame after a light change uses the cache)."""
    r.render_image(SIZE)
    return r.render_image(SIZE)


def test_cached_path_equals_direct_path_on_skin(renderer: Renderer, gl_ctx: Any,
                                               assert_de2000_close: Callable[..., float]) -> None:
    r = renderer
    r.settings.lighting_cache = True
    r.set_environment("studio", 0.5)
    try:
        cached = settled(r)
        assert r.lighting.version > 0, "the cached frame did not use the cache"
        mask = r.skin_pixel_mask()
        r.settings.lighting_cache = False
        direct = r.render_image(SIZE)
        r.settings.lighting_cache = True
        mean = assert_de2000_close(cached, direct, mask, 0.5, "cached-vs-direct")
        assert mean > 0.0, "the two paths are the same code: the comparison proves nothing"
    finally:
        r.set_environment(None)


def test_invalidated_by_light_environment_and_material(renderer: Renderer, doc: Any, gl_ctx: Any) -> None:
    r = renderer
    settled(r)
    whole = r.lighting.full_updates
    r.render_image(SIZE)
    r.camera.yaw += 10.0  # the camera alone: nothing to recompute
    r.render_image(SIZE)
    r.camera.yaw -= 10.0
    assert r.lighting.full_updates == whole
    r.lights[0] = Light.directional(20.0, 30.0, 1.5)  # a light moves
    settled(r)
    assert r.lighting.full_updates == whole + 1
    r.set_environment("city", 0.5)  # an environment
    settled(r)
    assert r.lighting.full_updates == whole + 2
    r.set_environment(None)
    settled(r)
    layers = inputs(doc)  # a material edit re-evaluates the KM maps whole
    r.set_layers(layers)
    r.render_image(SIZE)
    assert r.lighting.full_updates == whole + 4


def test_a_dab_recomputes_only_its_tiles_and_shows(renderer: Renderer, doc: Any, gl_ctx: Any) -> None:
    from painting.tiles import TILE

    r = renderer
    r.set_layers(inputs(doc))
    before = settled(r)
    whole, tiles = r.lighting.full_updates, r.lighting.tiles_updated
    lip = next(i for i, lay in enumerate(doc.layers) if "ip" in lay.name or "Lip" in str(lay.material))
    a = np.array(r.km.layers[lip].thickness)
    ys, xs = np.nonzero(a > 0)
    row, col = int(ys[len(ys) // 2]) // TILE, int(xs[len(xs) // 2]) // TILE
    a[row * TILE:(row + 2) * TILE, col * TILE:(col + 1) * TILE] += 40.0  # a dab over two tiles
    r.km.update_tiles(lip, a, [(row, col), (row + 1, col)])
    after = r.render_image(SIZE)
    assert r.lighting.full_updates == whole, "a dab must not recompute the whole cache"
    assert r.lighting.tiles_updated == tiles + 2
    assert np.abs(after.astype(int) - before.astype(int)).max() > 10, "the dab does not show in the frame"


def test_zero_thickness_layers_look_like_no_makeup_through_the_cache(
        renderer: Renderer, doc: Any, gl_ctx: Any, assert_de2000_close: Callable[..., float]) -> None:
    r = renderer
    r.set_layers([])
    bare = r.render_image(SIZE)
    mask = r.skin_pixel_mask()
    r.set_layers([LayerInput(lay.material, np.zeros_like(lay.thickness)) for lay in inputs(doc)])
    zeros = settled(r)
    assert r.lighting.full_updates > 0
    assert_de2000_close(bare, zeros, mask, 0.5, "zero-layers-vs-bare")
    r.set_layers(inputs(doc))
