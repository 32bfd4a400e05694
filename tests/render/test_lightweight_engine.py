"""The lightweight engine (render/lightweight.py) on llvmpipe: Phong × detail, clamping after modulation,
shadows, ≤ 8 lights, eye highlights, cosmetic layers from KM textures."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from capture.face import Face
from capture.phong import PhongParams

pytestmark = pytest.mark.gl
SIZE = (320, 180)


@pytest.fixture(scope="module")
def head() -> Any:
    from painting.head import load_head

    return load_head()


def _face(head: Any) -> Face:
    from km.srgb import srgb_decode

    alb = srgb_decode(head.albedo / 255.0)
    detail = (alb / alb.reshape(-1, 3).mean(axis=0)).astype(np.float32)
    params = PhongParams(diffuse=np.array([0.6, 0.42, 0.33]), specular=0.2, exponent=24.0, ambient_scale=1.0,
                         flash_rgb=np.ones(3), ambient_rgb=np.full(3, 0.02))
    return Face(params=params, detail=detail, data={})


@pytest.fixture
def engine(gl_ctx: Any, head: Any) -> Any:
    from render.lightweight import LightweightRenderer

    r = LightweightRenderer(gl_ctx, head, _face(head), shadow_size=512)
    yield r
    r.release()


def _face_box(img: np.ndarray) -> np.ndarray:
    h, w = img.shape[:2]
    return img[h // 4: h // 2, w // 2 - w // 16: w // 2 + w // 16].astype(float)


def test_renders_deterministically(engine: Any) -> None:
    a = engine.render_image(SIZE)
    b = engine.render_image(SIZE)
    # one program on the same inputs and state: exactly determined on any GPU (GL 4.5 appendix A, rule 4)
    assert a.shape == (SIZE[1], SIZE[0], 3) and np.array_equal(a, b)
    assert _face_box(a).mean() > 60  # the face is lit


def test_overexposure_clamps_after_modulation(engine: Any) -> None:
    base = _face_box(engine.render_image(SIZE))
    engine.exposure = 12.0
    hot = _face_box(engine.render_image(SIZE))
    assert (hot >= 254).mean() > 0.5  # saturated
    assert hot.std() < base.std()  # the detail disappears in the overexposed highlight


def test_lights_limit_and_shadows(engine: Any) -> None:
    from render.errors import RenderError
    from render.lights import Light

    engine.lights = [Light.directional(az, 20, 0.2) for az in range(-80, 80, 20)]
    assert len(engine.lights) == 8
    with_shadows = engine.render_image(SIZE)
    engine.shadows_on = False
    without = engine.render_image(SIZE)
    assert not np.array_equal(with_shadows, without)
    assert with_shadows.astype(float).mean() <= without.astype(float).mean()
    engine.lights = engine.lights + [Light.directional(0, 0, 0.1)]
    with pytest.raises(RenderError):
        engine.render_image(SIZE)


def test_eye_highlights_add_light(engine: Any) -> None:
    from render.lights import Light

    engine.lights = [Light.directional(10, 10, 1.0)]
    on = engine.render_image((1280, 720)).astype(float)
    engine.eye_highlights = False
    off = engine.render_image((1280, 720)).astype(float)
    assert np.all(on >= off - 1e-9) and (on - off).max() > 30


def test_makeup_textures_apply(engine: Any, gl_ctx: Any) -> None:
    red = np.zeros((4, 4, 4), np.float32)
    red[..., 0] = 0.8
    red[..., 3] = 1.0
    zero = np.zeros((4, 4, 4), np.float32)
    texs = [gl_ctx.texture((4, 4), 4, a.tobytes(), dtype="f4") for a in (red, zero, zero)]

    class Makeup:
        def bind(self, unit: int) -> None:
            for i, t in enumerate(texs):
                t.use(unit + i)

    engine.makeup = Makeup()
    img = _face_box(engine.render_image(SIZE))
    for t in texs:
        t.release()
    # An opaque red layer (T = 0): red, no green or blue, no skin specular.
    assert img[..., 0].mean() > 100 and img[..., 1].mean() < 5 and img[..., 2].mean() < 5


def test_lipstick_from_the_km_pass_shows(engine: Any, gl_ctx: Any, head: Any) -> None:
    """The real texture-space KM outputs (8-bit sRGB maps) of a lipstick-only document redden the lips:
    no foundation under it, so nothing but the lipstick marks those texels."""
    import km
    from render.km_pass import KMTextureSpace, LayerInput
    from render.shaders import ShaderLibrary

    lipstick = km.default_library().get("Lipstick Classic Red")
    km_pass = KMTextureSpace(gl_ctx, ShaderLibrary())  # the renderer's default 8-bit sRGB outputs
    try:
        km_pass.set_layers([LayerInput(lipstick, np.full((256, 256), 12.0, np.float32))])  # the whole face
        bare = _face_box(engine.render_image(SIZE))
        engine.makeup = km_pass
        made_up = _face_box(engine.render_image(SIZE))
    finally:
        engine.makeup = None
        km_pass.release()
    redness = lambda img: float((img[..., 0] - img[..., 1]).mean())  # noqa: E731
    assert redness(made_up) > redness(bare) + 20


def test_hdr_environment_adds_light(engine: Any) -> None:
    from bench.capture_synthetic import read_env
    from core.assets import find_asset
    from render.lights import Environment, Light

    engine.lights = [Light.directional(90, 0, 0.5)]
    dark = engine.render_image(SIZE).astype(float)
    engine.environment = Environment.from_image(read_env(str(find_asset("environments/studio.exr"))), "studio", 0.5)
    lit = engine.render_image(SIZE).astype(float)
    assert _face_box(lit).mean() > _face_box(dark).mean() + 5


def test_vertex_shadows_match_pixel_shadows(engine: Any) -> None:
    from render.lights import Light

    engine.lights = [Light.directional(60, 20, 1.0)]
    engine.shadow_mode = "pixel"
    pixel = engine.render_image(SIZE).astype(float)
    engine.shadow_mode = "vertex"
    vertex = engine.render_image(SIZE).astype(float)
    assert np.abs(pixel - vertex).mean() < 3.0  # softer edges, same shadows
