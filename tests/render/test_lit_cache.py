"""The texture-space lighting cache (render.lit_cache) on llvmpipe: it equals the direct path on skin, is
recomputed whole when a light, the environment or a material changes, and only over a dab's tiles."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from render.km_pass import LayerInput
from render.lights import Light
from render.renderer import Renderer
from tests.imaging import assert_images_close

if TYPE_CHECKING:
    from collections.abc import Iterator

pytestmark = pytest.mark.gl
SIZE = (480, 360)
#: the cache against the direct path on skin (both on one GPU, so its rasterisation is common to both):
#: ΔE2000 mean ≤ 0.5 and p99 ≤ 3 — measured on llvmpipe mean 0.22–0.27, p99 1.1–1.7 (here and with point
#: lights), where the cache's 8-bit texels meet sharp shading; a GPU filtering them with 8-bit weights
#: moves an interpolated value by at most 1/512 of its two texels' difference
CACHE_DE = {"de_mean": 0.5, "de_p99": 3.0}


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


def test_cached_path_equals_direct_path_on_skin(renderer: Renderer, gl_ctx: Any) -> None:
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
        stats = assert_images_close(cached, direct, **CACHE_DE, mask=mask, name="cached-vs-direct")
        assert stats.mean > 0.0, "the two paths are the same code: the comparison proves nothing"
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


def test_a_half_side_relight_never_passes_for_the_full_side_s_cache(renderer: Renderer, gl_ctx: Any) -> None:
    """While a light is dragged the renderer relights at half the irradiance's side; each side counts its
    own versions, so the cache's key must name the side: when the counts meet, the interactive frame must
    still show the moved light (the direct path), not the cache made for where the light was."""
    r = renderer
    key0 = r.lights[0]
    settled(r)
    full = r.irradiance
    half = r._irradiance_at(full.size // 2)
    r.settings.interactive = True
    try:
        az = 0.0
        while True:  # drag the key light until the half side's count reaches the full side's
            az += 7.0
            r.lights[0] = Light.directional(az, 30.0, 1.5)
            r.render_image(SIZE)
            assert r.irradiance is half
            if half.version >= full.version:
                break
        assert half.version == full.version, "the counts must meet for this test to mean anything"
        shown = r.render_image(SIZE)  # the same frame again (nothing recomputed)
        r.settings.lighting_cache = False
        direct = r.render_image(SIZE)
        # both frames are the direct path on the same half-side irradiance: one program on the same inputs,
        # exactly determined (GL 4.5 appendix A, rule 4)
        assert np.array_equal(shown, direct), "an interactive relight used the cache of the old light"
    finally:
        r.settings.interactive = False
        r.settings.lighting_cache = True
        r.lights[0] = key0
        settled(r)


def test_a_deferred_frame_draws_direct_and_the_cache_is_built_after_it(
        renderer: Renderer, gl_ctx: Any) -> None:
    """The studio's settle frame after a relight (Renderer.defer_cache): the direct path's frame, no
    whole rebuild in it; build_deferred_cache rebuilds the level once, and the next frame fetches it."""
    r = renderer
    key0 = r.lights[0]
    settled(r)
    try:
        r.lights[0] = Light.directional(25.0, 35.0, 1.5)
        whole = r.lighting.full_updates
        r.defer_cache = True
        deferred = r.render_image(SIZE)
        r.defer_cache = False
        assert r.lighting.full_updates == whole, "the deferred frame rebuilt the cache"
        mask = r.skin_pixel_mask()
        r.settings.lighting_cache = False
        try:
            # the same program on the same inputs (the irradiance is current): exactly determined
            assert np.array_equal(deferred, r.render_image(SIZE)), "the deferred frame is the direct path's"
        finally:
            r.settings.lighting_cache = True
        assert r.build_deferred_cache() and r.lighting.full_updates == whole + 1
        assert not r.build_deferred_cache(), "built once"
        cached = r.render_image(SIZE)
        assert r.lighting.full_updates == whole + 1, "the next frame fetches the built cache"
        assert_images_close(deferred, cached, **CACHE_DE, mask=mask, name="deferred-vs-cached")
        # a light moved since the deferred frame: nothing is built for the old one
        r.lights[0] = Light.directional(15.0, 35.0, 1.5)
        r.defer_cache = True
        r.render_image(SIZE)
        r.defer_cache = False
        r.lights[0] = Light.directional(5.0, 35.0, 1.5)
        r.settings.interactive = True
        r.render_image(SIZE)
        r.settings.interactive = False
        assert not r.build_deferred_cache() and r.lighting.full_updates == whole + 1
    finally:
        r.defer_cache = r.settings.interactive = False
        r.lights[0] = key0
        settled(r)


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
        renderer: Renderer, doc: Any, gl_ctx: Any) -> None:
    r = renderer
    r.set_layers([])
    bare = r.render_image(SIZE)
    mask = r.skin_pixel_mask()
    r.set_layers([LayerInput(lay.material, np.zeros_like(lay.thickness)) for lay in inputs(doc)])
    zeros = settled(r)
    assert r.lighting.full_updates > 0
    assert_images_close(bare, zeros, **CACHE_DE, mask=mask, name="zero-layers-vs-bare")
    r.set_layers(inputs(doc))


def test_irradiance_bound_holds_the_cache_s_irradiance(renderer: Renderer, doc: Any, gl_ctx: Any) -> None:
    """The colours are encoded against irradiance_bound: it must bound E (else they clip), not loosely."""
    from render.lit_cache import irradiance_bound

    r = renderer
    saved = list(r.lights)
    r.lights = [Light.directional(35.0, 25.0, 1.5), Light.directional(-45.0, 5.0, 0.35, shadows=False),
                Light.point((3.0, 2.0, 9.0), 0.8, (1.0, 0.8, 0.6), reference_distance=8.0)]
    r.set_environment("studio", 0.5)
    try:
        settled(r)
        e = np.frombuffer(r.irradiance.textures[0].read(), np.float16).reshape(-1, 4)[:, :3].astype(float)
        bound = irradiance_bound(r.lights, r.environment, r.gpu_head.vertices)
        assert np.all(e.max(axis=0) <= bound), (e.max(axis=0), bound)
        assert np.all(e.max(axis=0) >= 0.4 * bound), "the bound is so loose the 8-bit colours lose precision"
        np.testing.assert_allclose(r.lighting.scale, bound, rtol=1e-6)
    finally:
        r.lights = saved
        r.set_environment(None)


def test_level_follows_the_frame_s_texel_density(gl_ctx: Any, doc: Any) -> None:
    """2048² maps over a 1024² albedo: minified frames fetch the half-side level (never below the albedo's
    texels), close-ups level 0; a dab reaches the level that is not in use when it is used again."""
    from painting.tiles import TILE

    lips = next(lay for lay in doc.layers if "ip" in lay.name)
    thick = np.kron(np.asarray(lips.thickness), np.ones((4, 4), np.float32))
    r = Renderer(gl_ctx, doc.head, layout=doc.layout)
    try:
        r.lights = [Light.directional(35.0, 25.0, 1.5)]
        r.set_layers([LayerInput(lips.material_object, thick)])
        assert r.lighting.max_level(r.km, r.gpu_head) == 1
        cached = settled(r)  # 480×360: about 4 texels of 2048 a pixel
        assert r.lighting.level == 1 and r.lighting.size == (1024, 1024)
        mask = r.skin_pixel_mask()
        r.settings.lighting_cache = False
        direct = r.render_image(SIZE)
        r.settings.lighting_cache = True
        assert_images_close(cached, direct, **CACHE_DE, mask=mask, name="level1-vs-direct")
        # a dab while level 1 is in use, then a close-up: level 0 is made whole once, then takes dabs as tiles
        r.camera.distance *= 0.3
        r.render_image((1280, 960))
        assert r.lighting.level == 0
        ys, xs = np.nonzero(thick > 0)
        row, col = int(ys[len(ys) // 2]) // TILE, int(xs[len(xs) // 2]) // TILE
        r.camera.distance /= 0.3
        settled(r)
        assert r.lighting.level == 1
        full, tiles = r.lighting.full_updates, r.lighting.tiles_updated
        thick[row * TILE:(row + 1) * TILE, col * TILE:(col + 1) * TILE] += 30.0
        r.km.update_tiles(0, thick, [(row, col)])
        r.render_image(SIZE)
        r.camera.distance *= 0.3
        r.render_image((1280, 960))
        assert r.lighting.level == 0
        assert r.lighting.full_updates == full and r.lighting.tiles_updated == tiles + 2, \
            "each level takes the dab's tile once, neither is recomputed whole"
    finally:
        r.release()
