"""The lighting cache with a point light inside or next to the head (render.lit_cache's wide range): the
cached frames must show what the direct path shows. Before the half-float colours, a light 1.5 units from
the sample head's centre (0.26 from a surface inside the head) drew the head nearly black through the
cache (mean 42 against 91): its 8-bit colours were scaled to a bound of 3·10⁶."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from render.km_pass import LayerInput
from render.lights import Light
from render.lit_cache import MAX_8BIT_RANGE, irradiance_bound, irradiance_range
from render.renderer import Renderer
from tests.imaging import assert_images_close
from tests.render.test_lit_cache import CACHE_DE

if TYPE_CHECKING:
    from collections.abc import Iterator

pytestmark = pytest.mark.gl
SIZE = (480, 360)
KEY = Light.directional(35.0, 25.0, 1.2)


@pytest.fixture(scope="module")
def renderer(_gl_session_ctx: Any) -> Iterator[Renderer]:
    from painting import Document
    from painting.looks import apply_look

    doc = Document.from_head(resolution=512)
    apply_look(doc, "evening")
    r = Renderer(_gl_session_ctx, doc.head, layout=doc.layout)
    r.set_layers([LayerInput(lay.material_object, np.array(lay.thickness), lay.opacity, lay.visible, lay.name)
                  for lay in doc.layers])
    yield r
    r.release()


def test_range_is_one_without_point_lights_and_large_with_one_inside(renderer: Renderer) -> None:
    v = renderer.gpu_head.vertices
    assert irradiance_range([KEY, Light.directional(-45.0, 5.0, 0.35)], None, v) == 1.0
    far = irradiance_range([KEY, Light.point((3.0, 2.0, 9.0), 0.8, reference_distance=8.0)], None, v)
    assert 1.0 < far < MAX_8BIT_RANGE, "a light an arm's length away keeps the 8-bit colours"
    inside = [KEY, Light.point((0.0, 0.0, 1.48), 1.0, reference_distance=8.0)]
    assert irradiance_range(inside, None, v) > 1000.0
    assert irradiance_bound(inside, None, v)[0] > 1000.0


@pytest.mark.parametrize("where, position", [
    ("centre", (0.0, 0.0, 0.0)),
    ("inside, near a surface", (0.0, 0.0, 1.48)),
    ("before the nose", (0.0, 1.1, 2.85)),
    ("an arm's length away", (3.0, 2.0, 9.0)),
])
def test_cached_frames_match_direct_ones_with_a_point_light(
        renderer: Renderer, gl_ctx: Any,
        where: str, position: tuple[float, float, float]) -> None:
    r = renderer
    r.lights = [KEY, Light.point(position, 1.0, reference_distance=8.0)]
    r.settings.lighting_cache = True
    try:
        r.render_image(SIZE)
        cached = r.render_image(SIZE)  # the second frame after a light change uses the cache
        assert r.lighting.version > 0 and r.lighting.level is not None
        mask = r.skin_pixel_mask()
        r.settings.lighting_cache = False
        direct = r.render_image(SIZE)
    finally:
        r.settings.lighting_cache = True
    m_cached, m_direct = cached[..., :3][mask].mean(), direct[..., :3][mask].mean()
    assert abs(m_cached - m_direct) < 1.0, f"{where}: skin mean {m_cached:.1f} cached, {m_direct:.1f} direct"
    assert_images_close(cached, direct, **CACHE_DE, mask=mask, name=f"point-light-{where}")
    wide = irradiance_range(r.lights, None, r.gpu_head.vertices) > MAX_8BIT_RANGE
    assert r.lighting.wide == wide
