"""Frames of the sample head on llvmpipe (320×240): determinism, stored references, physical sanity
(the direct path: see the ``r`` fixture)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

import km
from painting.tiles import TILE
from render.km_pass import LayerInput
from render.lights import Light
from render.renderer import Renderer
from render.settings import DEBUG_VIEWS
from tests.imaging import ONE_LEVEL_DE, assert_images_close, assert_matches_reference

if TYPE_CHECKING:
    from collections.abc import Iterator

pytestmark = pytest.mark.gl
SIZE = (320, 240)


@pytest.fixture(scope="module")
def looks(doc: Any) -> dict[str, list[LayerInput]]:
    """Layers of the built-in looks painted through the document's brush API."""
    from painting.looks import apply_look

    out = {}
    for name in ("red-lip", "evening"):
        apply_look(doc, name)
        out[name] = [LayerInput(lay.material_object, np.array(lay.thickness), lay.opacity, lay.visible, lay.name)
                     for lay in doc.layers]
    return out


@pytest.fixture(scope="module")
def renderer(_gl_session_ctx: Any, doc: Any) -> Iterator[Renderer]:
    r = Renderer(_gl_session_ctx, doc.head, layout=doc.layout)
    r.lights = [Light.directional(35.0, 25.0, 1.5), Light.directional(-45.0, 5.0, 0.35, shadows=False)]
    yield r
    r.release()
    assert _gl_session_ctx.error == "GL_NO_ERROR"


@pytest.fixture
def r(renderer: Renderer, gl_ctx: Any) -> Renderer:
    """The module's renderer reset to defaults, bare, on the direct path.

    These tests hold the shading model itself (every term computed per pixel); the texture-space lighting
    cache that the studio draws with is held to this path in tests/render/test_lit_cache.py.
    """
    from render.settings import RenderSettings

    renderer.settings = RenderSettings(lighting_cache=False)
    renderer.lights = [Light.directional(35.0, 25.0, 1.5), Light.directional(-45.0, 5.0, 0.35, shadows=False)]
    renderer.environment = None
    renderer.set_layers([])
    return renderer


def project(r: Renderer, p: np.ndarray) -> tuple[int, int]:
    """Pixel (column, row from the top) of a mesh point in the last frame."""
    c = r.last.view_proj @ np.append(p, 1.0)
    ndc = c[:2] / c[3]
    w, h = r.last.size
    return int((ndc[0] * 0.5 + 0.5) * w), int((0.5 - ndc[1] * 0.5) * h)


def window(img: np.ndarray, xy: tuple[int, int], half: int = 3) -> np.ndarray:
    x, y = xy
    return img[y - half:y + half + 1, x - half:x + half + 1].reshape(-1, img.shape[-1])


def test_deterministic_and_matches_references(r: Renderer, looks: dict[str, list[LayerInput]]) -> None:
    """The frame twice is the same bytes, and the three stored frames (made on llvmpipe) within ΔE2000.

    Twice: one program on the same inputs and state, exactly determined on any GPU (GL 4.5 appendix A,
    rule 4). The references: over the whole 320×240 frame, ΔE2000 mean ≤ 0.2 and p99 ≤ 2. Measured on
    llvmpipe 0.02–0.05 and 0.5–0.8; with the projection moved 1/32 pixel in x and y (a rasteriser with
    GL's minimum of 4 sub-pixel bits snaps each vertex up to that far) 0.12–0.13 and 1.1–1.3; with the
    looks' foundation one shade off (Ivory for Beige) 0.26–0.41 and 3.0–4.7, which fails both bounds.
    """
    a = r.render_image(SIZE)
    b = r.render_image(SIZE)
    np.testing.assert_array_equal(a, b)
    tol = {"de_mean": 0.2, "de_p99": 2.0}
    assert_matches_reference(a, "render_bare_fast.png", **tol)
    r.set_layers(looks["red-lip"])
    assert_matches_reference(r.render_image(SIZE), "render_red_lip_fast.png", **tol)
    r.set_layers(looks["evening"])
    r.settings.mode = "reference"
    assert_matches_reference(r.render_image(SIZE), "render_evening_reference.png", **tol)


def test_zero_thickness_layers_render_like_no_makeup(r: Renderer, looks: dict[str, list[LayerInput]]) -> None:
    """The KM maps of zero thickness are exactly R = 0, T = 1, but the lit pass is another variant of the
    program (MAKEUP, NL): its float maths may round differently on another GPU, and an 8-bit conversion
    may then take the neighbouring level. At most one level on any pixel, ΔE2000 mean ≤ 0.02 (one level on
    a few % of the pixels) and p99 ≤ one level's ΔE; measured on llvmpipe: the same bytes."""
    bare = r.render_image(SIZE)
    zeros = [LayerInput(lay.material, np.zeros_like(lay.thickness)) for lay in looks["evening"]]
    r.set_layers(zeros)
    assert_images_close(r.render_image(SIZE), bare, de_mean=0.02, de_p99=ONE_LEVEL_DE, max_levels=1,
                        name="zero-layers-vs-bare")


def test_lipstick_moves_the_lips_towards_its_colour(r: Renderer, doc: Any, looks: dict[str, list[LayerInput]]) -> None:
    from km.colour import linear_rgb_to_lab

    bare = r.render_image(SIZE, linear=True)
    lips = project(r, doc.head.landmark("lower_lip"))
    lipstick = [lay for lay in looks["red-lip"] if lay.material.category == "lipstick"]
    r.set_layers(lipstick)
    made_up = r.render_image(SIZE, linear=True)
    mat = lipstick[0].material
    from km.optics import layer_rt
    from render.km_pass import default_wavelengths, spectral_matrix

    wl = default_wavelengths()
    r0, _ = layer_rt(np.interp(wl, mat.wavelengths, mat.S), np.interp(wl, mat.wavelengths, mat.K), 1.0)
    target = linear_rgb_to_lab(r0 @ spectral_matrix(wl))

    def hue_distance(img: np.ndarray) -> float:
        lab = linear_rgb_to_lab(np.clip(window(img, lips).mean(axis=0), 1e-6, None))
        return float(np.angle(np.exp(1j * (np.arctan2(lab[2], lab[1]) - np.arctan2(target[2], target[1])))))

    assert abs(hue_distance(made_up)) < abs(hue_distance(bare)) - 0.02
    # and elsewhere nothing changed (the forehead)
    fh = project(r, doc.head.landmark("forehead"))
    np.testing.assert_allclose(window(made_up, fh), window(bare, fh), atol=1e-3)


def test_thicker_foundation_lowers_local_contrast(r: Renderer, doc: Any) -> None:
    mat = km.default_library().get("Foundation Ivory")
    r.settings.mode = "off"
    r.lights = [Light.directional(0.0, 0.0, 1.0, shadows=False)]
    r.settings.spec_intensity = 0.0
    cheek = None
    stds = []
    for x in (0.0, 5.0, 25.0):
        r.set_layers([LayerInput(mat, np.full((512, 512), x, np.float32))])
        img = r.render_image(SIZE, linear=True)
        if cheek is None:
            cheek = project(r, doc.head.landmark("left_cheek"))
        lum = window(img, cheek, 8) @ np.array([0.2126, 0.7152, 0.0722])
        stds.append(float(np.std(lum) / np.mean(lum)))
    assert stds[0] > stds[1] > stds[2]


def test_sss_widens_the_penumbra(gl_ctx: Any, doc: Any) -> None:
    """With a uniform albedo, every edge in the image is lighting (shadow edges, the terminator, normal-map
    detail): subsurface scattering must soften the sharpest of them."""
    import dataclasses

    head = dataclasses.replace(doc.head, albedo=np.full((4, 4, 3), 200, np.uint8))
    r = Renderer(gl_ctx, head)
    r.lights = [Light.directional(70.0, 10.0, 1.5)]  # hard side light: the nose casts a shadow
    r.settings.spec_intensity = 0.0
    r.settings.pcf_radius = 0.5
    r.camera.target = head.landmark("nose_tip")
    r.camera.distance = 2.3  # about 70 mm across the view: 0.3 mm per pixel
    grads = {}
    for mode in ("off", "fast", "reference"):
        r.settings.mode = mode
        img = r.render_image(SIZE, linear=True)
        mask = r.skin_pixel_mask()
        lum = img @ np.array([0.2126, 0.7152, 0.0722])
        gx = np.abs(np.diff(lum, axis=1))  # (H, W-1)
        gy = np.abs(np.diff(lum, axis=0))  # (H-1, W)
        g = np.maximum(gx[:-1, :], gy[:, :-1])
        inner = mask[:-1, :-1] & mask[1:, :-1] & mask[:-1, 1:]
        grads[mode] = float(np.percentile(g[inner], 99))
    r.release()
    assert grads["fast"] < 0.9 * grads["off"]
    assert grads["reference"] < 0.9 * grads["off"]


def test_white_layer_never_reflects_more_than_arrives(r: Renderer) -> None:
    wl = np.arange(380.0, 781.0, 5.0)

    class White:
        name, category, roughness, ior, thickness_um, max_thickness_um = "white", "other", 0.3, 1.5, 20.0, 200.0
        wavelengths = wl
        S = np.full(len(wl), 80.0)
        K = np.zeros(len(wl))

    r.lights = [Light.directional(0.0, 0.0, 1.0)]
    r.settings.spec_intensity = 0.0  # the skin's lobe
    r.settings.layer_spec_intensity = 0.0  # the layer's own (its Fresnel reflection would add to the diffuse)
    r.set_layers([LayerInput(White(), np.full((512, 512), 150.0, np.float32))])
    for mode in ("off", "fast", "reference"):
        r.settings.mode = mode
        img = r.render_image(SIZE, linear=True)
        skin = r.skin_pixel_mask()
        assert img[skin].max() <= 1.0 + 2e-3, mode
        assert img[skin].max() > 0.7, mode  # and it is nearly white where the light is frontal


def test_fast_agrees_with_reference(r: Renderer, looks: dict[str, list[LayerInput]]) -> None:
    r.set_layers(looks["evening"])
    r.settings.mode = "fast"
    fast = r.render_image(SIZE)
    mask = r.skin_pixel_mask()
    r.settings.mode = "reference"
    ref = r.render_image(SIZE)
    # two SSS models on one GPU (its rasterisation is common to both): measured on llvmpipe, on skin,
    # ΔE2000 mean 0.23 and p99 1.8
    assert_images_close(fast, ref, de_mean=1.0, de_p99=4.0, mask=mask, name="fast-vs-reference")


def test_debug_views_and_picking(r: Renderer, gl_ctx: Any, doc: Any, looks: dict[str, list[LayerInput]]) -> None:
    r.set_layers(looks["evening"])
    images = {}
    for view in DEBUG_VIEWS:
        r.settings.debug_view = view
        images[view] = r.render_image(SIZE)
    for view in DEBUG_VIEWS:
        if view != "none":
            assert np.abs(images[view].astype(int) - images["none"]).mean() > 1.0, view
    # picking: the nose tip's pixel unprojects onto the nose tip
    r.settings.debug_view = "none"
    r.render_image(SIZE)
    nose = doc.head.landmark("nose_tip")
    x, y = project(r, nose)
    p = r.pick(x, y)
    assert p is not None and np.linalg.norm(p - nose) * doc.head.mm_per_unit < 3.0
    assert r.pick(2, 2) is None  # background


def test_renders_into_a_viewport_of_a_given_framebuffer(r: Renderer, gl_ctx: Any) -> None:
    colour = gl_ctx.texture((400, 300), 4)
    fbo = gl_ctx.framebuffer([colour])
    try:
        fbo.use()
        fbo.clear(1.0, 0.0, 0.0, 1.0)
        r.render(fbo, (40, 30, 320, 240))
        img = np.frombuffer(fbo.read(components=3), np.uint8).reshape(300, 400, 3)
        # outside the viewport: the clear's exact 8-bit values (1.0 and 0.0), which nothing drew over
        assert (img[:30, :, 0] == 255).all() and (img[:30, :, 1] == 0).all()
        inner = img[30:270, 40:360][::-1]
        ref = r.render_image(SIZE)
        # the same frame moved by whole pixels (even ones: the half-resolution SSS grid stays aligned).
        # Another rasteriser may snap a moved vertex to the neighbouring sub-pixel step and flip a few
        # silhouette pixels (under 1 % of the frame: the p99 stays within one 8-bit level). Measured on
        # llvmpipe: the same bytes
        assert_images_close(inner, ref, de_mean=0.05, de_p99=ONE_LEVEL_DE, name="viewport-vs-frame")
    finally:
        from render.glutil import release_all

        release_all(gl_ctx, [fbo, colour])


def test_binding_pushes_a_dabs_tiles_in_the_next_flush(r: Renderer, doc: Any) -> None:
    """The document → GPU binding: a dab queues its tiles (row, col) under the layer's id; the next flush
    re-evaluates exactly those, and the result equals a full evaluation of the document."""
    from painting import Brush
    from render.binding import DocumentBinding, layer_inputs

    calls: list[int] = []
    binding = DocumentBinding(doc, r, on_change=lambda: calls.append(1))
    try:
        assert binding.pending and binding.flush() and not binding.pending
        assert not binding.flush()  # nothing queued: nothing pushed
        layer = doc.layers[-1]
        before = [a.copy() for a in r.km.read()]
        versions = r.km.version
        with doc.stroke(layer, Brush(radius_mm=4.0, hardness=0.5, strength=1.0, mode="add", amount_um=15.0)) as s:
            s.dab(doc.head.landmark("chin"))
        assert calls and set(binding.dirty) == {layer.id} and not binding.full
        tiles = sorted(binding.dirty[layer.id])
        assert r.km.version == versions  # nothing reaches the GPU before the flush
        assert binding.flush()
        assert r.km.version == versions + 1  # one tile update, not a full evaluation
        incremental = [a.copy() for a in r.km.read()]
        changed = np.zeros(incremental[0].shape[:2], bool)
        for a, b in zip(incremental, before):
            changed |= np.abs(a - b).max(axis=-1) > 0
        rows, cols = np.nonzero(changed)
        assert len(rows) and {(int(y) // TILE, int(x) // TILE) for y, x in zip(rows, cols)} <= set(tiles)
        r.set_layers(layer_inputs(doc))  # a full evaluation gives the same maps
        for a, b in zip(incremental, r.km.read()):
            np.testing.assert_allclose(a, b, atol=2e-3)
        doc.undo()
        assert binding.pending
        binding.flush()
        for a, b in zip(r.km.read(), before):
            np.testing.assert_allclose(a, b, atol=2e-3)
        doc.set_layer(layer, visible=False)  # any other change: every layer read again
        assert binding.full
        binding.flush()
        assert doc.index_of(layer) not in r.km.active
        doc.undo()
        binding.flush()
    finally:
        binding.close()
    doc.set_layer(layer, opacity=0.5)
    doc.undo()
    assert not binding.pending  # closed: no longer following


def test_light_order_does_not_change_the_frame(r: Renderer, looks: dict[str, list[LayerInput]]) -> None:
    """The lit pass is specialised on which lights cast shadows and which are point lights, and the shadow
    visibilities are packed by light index (light 0 in the irradiance's alpha, 1-4 and 5-7 in two more
    maps): any order of the same rig must give the same frame, so every index reads its own light."""
    r.set_layers(looks["evening"])
    rig = [Light.directional(35.0, 25.0, 0.9), Light.directional(-45.0, 5.0, 0.3, shadows=False),
           Light.point((0.0, 0.4, 2.5), 0.5, shadows=True), Light.directional(150.0, 35.0, 0.3),
           Light.directional(-20.0, -30.0, 0.2, shadows=False), Light.directional(80.0, 60.0, 0.25)]
    images = []
    for order in ([0, 1, 2, 3, 4, 5], [5, 3, 2, 0, 4, 1], [1, 4, 0, 5, 2, 3]):
        r.lights = [rig[i] for i in order]
        images.append(r.render_image(SIZE, linear=True))
    assert float(images[0].max()) > 0.1
    for img in images[1:]:
        np.testing.assert_allclose(img, images[0], rtol=2e-3, atol=2e-3)  # float sums in another order


def test_irradiance_padding_index_is_cached_on_disk(gl_ctx: Any, doc: Any, tmp_path: Any,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """The irradiance's padding index is made once per mesh footprint and size, read back equal, and a
    damaged file is made again: the frames are identical in all three cases."""
    monkeypatch.setenv("SHEER_CACHE_DIR", str(tmp_path))
    images = []
    for damage in (None, None, b"broken"):
        files = list((tmp_path / "render").glob("pad-index-*.cache"))
        if damage is not None:
            files[0].write_bytes(damage)
        r = Renderer(gl_ctx, doc.head, layout=doc.layout)
        r.settings.irradiance_size = 256
        r.lights = [Light.directional(35.0, 25.0, 1.5)]
        images.append(r.render_image((160, 120), linear=True))
        r.release()
        assert len(list((tmp_path / "render").glob("pad-index-*.cache"))) == 1
    # exactly determined: the index read back is the one computed, so each renderer runs the same programs
    # on the same inputs (GL 4.5 appendix A, rule 4); in float frames the composite's cover (the hull once
    # it is ready, else the head) writes the clear colour's own floats where no head is
    np.testing.assert_array_equal(images[1], images[0])
    np.testing.assert_array_equal(images[2], images[0])
