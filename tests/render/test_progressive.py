"""Progressive refinement (render.progressive, render.view): the adaptive scale, and interactive frames of
the sample head on llvmpipe — close to the settled frame, inside their viewport, robust to odd sizes."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from core.errors import SheerError
from render.progressive import MIN_SCALE, SCALE_STEP, AdaptiveScale, scaled_size
from tests.imaging import assert_images_close

if TYPE_CHECKING:
    from collections.abc import Iterator

    from render.view import ViewRenderer


# ---------------------------------------------------------------- the controller (no GPU)
def simulate(ctrl: AdaptiveScale, fixed_ms: float, full_ms: float, frames: int = 30) -> list[float]:
    """Feed ``ctrl`` frames that cost ``fixed_ms + (full_ms - fixed_ms) · scale²``; the scales it chose."""
    scales = []
    for _ in range(frames):
        s = ctrl.scale
        ctrl.update(fixed_ms + (full_ms - fixed_ms) * s * s, s)
        scales.append(s)
    return scales


def test_scale_converges_to_the_budget() -> None:
    ctrl = AdaptiveScale(budget_ms=30.0, max_scale=1.0, scale=1.0)
    scales = simulate(ctrl, fixed_ms=8.0, full_ms=70.0)
    final = scales[-1]
    cost = 8.0 + 62.0 * final * final
    assert cost <= 30.0 * 1.1, f"settled at scale {final} costing {cost:.1f} ms (budget 30)"
    assert 8.0 + 62.0 * (final + SCALE_STEP) ** 2 > 30.0 * 0.9, "a larger scale would still fit: too timid"
    assert len(set(scales[-10:])) == 1, f"the scale keeps moving: {scales[-10:]}"
    assert all(abs(s / SCALE_STEP - round(s / SCALE_STEP)) < 1e-6 for s in scales)


def test_scale_respects_cap_and_minimum_and_says_when_over_budget() -> None:
    cheap = AdaptiveScale(budget_ms=30.0, max_scale=0.75, scale=0.3)
    assert simulate(cheap, 1.0, 10.0)[-1] == 0.75, "a cheap frame rises to the cap, not beyond"
    assert not cheap.over_budget
    slow = AdaptiveScale(budget_ms=30.0, max_scale=0.75, scale=0.75)
    assert simulate(slow, 40.0, 200.0)[-1] == MIN_SCALE
    assert slow.over_budget, "over budget at the smallest scale must be reported"
    slow.set_cap(1.0)
    assert slow.max_scale == 1.0
    with pytest.raises(SheerError, match="cap"):
        slow.set_cap(0.05)
    assert slow.max_scale == 1.0
    with pytest.raises(SheerError, match="budget"):
        AdaptiveScale(budget_ms=0.0)


def test_scaled_size_never_below_one_pixel() -> None:
    assert scaled_size((1, 1), 0.3) == (1, 1)
    assert scaled_size((1280, 720), 0.5) == (640, 360)
    assert scaled_size((7680, 4320), 0.3) == (2304, 1296)


# ---------------------------------------------------------------- interactive frames on the GPU
@pytest.fixture(scope="module")
def view(_gl_session_ctx: Any) -> Iterator[ViewRenderer]:
    from painting import Document
    from painting.looks import apply_look
    from render.binding import DocumentBinding
    from render.view import ViewRenderer

    doc = Document.from_head(resolution=512)
    apply_look(doc, "evening")
    v = ViewRenderer(_gl_session_ctx, doc.head, doc.layout)
    binding = DocumentBinding(doc, v.r, None)
    binding.flush()
    v.doc = doc  # type: ignore[attr-defined]
    yield v
    binding.close()
    v.release()


def frame(ctx: Any, v: ViewRenderer, size: tuple[int, int], *, interactive: bool, scale: float = 0.5,
          split: float = 0.0, camera: Any = None, pad: int = 0) -> np.ndarray:
    """The view drawn into a target ``pad`` pixels larger than ``size`` each way, filled with a sentinel
    colour first; the whole target (top row first, uint8 RGB)."""
    from render.lights import default_lights

    w, h = size
    tex = ctx.texture((w + pad, h + pad), 4)
    fbo = ctx.framebuffer([tex])
    try:
        fbo.use()
        fbo.clear(1.0, 0.0, 1.0, 1.0)
        cam = camera if camera is not None else v.r.camera
        v.render(fbo, size, cam, default_lights()[0], split=split, interactive=interactive, scale=scale)
        img = np.frombuffer(fbo.read(components=3), np.uint8).reshape(h + pad, w + pad, 3)[::-1]
    finally:
        from render.glutil import release_all

        release_all(ctx, [fbo, tex])
    return np.ascontiguousarray(img)


@pytest.mark.gl
def test_interactive_frame_close_to_settled(view: ViewRenderer, gl_ctx: Any) -> None:
    size = (640, 480)
    settled = frame(gl_ctx, view, size, interactive=False)
    assert view.scale == 1.0 and not view.interactive
    mask = view.r.skin_pixel_mask()
    inter = frame(gl_ctx, view, size, interactive=True, scale=0.5)
    assert view.interactive and view.scale == pytest.approx(0.5)
    assert tuple(view.r.last.size) == (320, 240), "the interactive frame runs at its reduced size"
    # half the resolution, upscaled: measured on llvmpipe ΔE2000 mean 1.0 and p99 8.5 on skin (the edges)
    assert_images_close(settled, inter, de_mean=2.0, de_p99=15.0, mask=mask, name="interactive-vs-settled")


@pytest.mark.gl
def test_a_dab_shows_in_the_next_interactive_frame(view: ViewRenderer, gl_ctx: Any) -> None:
    from painting.brush import Brush
    from render.binding import DocumentBinding

    doc = view.doc  # type: ignore[attr-defined]
    size = (640, 480)
    before = frame(gl_ctx, view, size, interactive=True, scale=0.5)
    # a dab at the pixel at the centre of the face, on the top layer, picked from the last frame
    x, y = 320, 250
    hit = view.pick(x, y, view.r.camera)
    assert hit is not None, "the probe pixel must be on the face"
    binding = DocumentBinding(doc, view.r, None)
    try:
        with doc.stroke(len(doc.layers) - 1, Brush(radius_mm=6.0, strength=1.0, hardness=0.9,
                                                    amount_um=40.0)) as stroke:
            assert stroke.dab(np.asarray(hit)), "the dab painted nothing"
        assert binding.flush()
        after = frame(gl_ctx, view, size, interactive=True, scale=0.5)
    finally:
        binding.close()
    d = np.abs(after[y - 3:y + 4, x - 3:x + 4].astype(int) - before[y - 3:y + 4, x - 3:x + 4].astype(int))
    assert d.max() > 8, "the dab is not in the next interactive frame at its pixel"


@pytest.mark.gl
@pytest.mark.parametrize("split", [0.1, 0.5, 0.9])
def test_interactive_frames_stay_inside_their_viewport(view: ViewRenderer, gl_ctx: Any, split: float) -> None:
    size, pad = (400, 300), 37
    img = frame(gl_ctx, view, size, interactive=True, scale=0.45, split=split, pad=pad)
    h = size[1]
    top = img[:pad]  # rows above the viewport (the target is read top row first; the view sits bottom-left)
    right = img[:, size[0]:]
    for part in (top, right):  # the clear's exact 8-bit values (1.0 and 0.0), which nothing drew over
        assert (part == [255, 0, 255]).all(), "an interactive frame wrote outside its viewport"
    view_px = img[pad:pad + h, :size[0]]
    assert not (view_px == [255, 0, 255]).all(axis=-1).any(), "the viewport was not covered"
    # the bare skin left of the split, the made-up face right of it: the divider is at the split
    col = int(split * size[0])
    # the divider is a scissored clear to 1.0 over whole columns: exactly 255
    assert (view_px[:, max(col - 1, 0):col + 1] == 255).all(), "the divider is not at the split"


@pytest.mark.gl
@pytest.mark.parametrize("size", [(1, 1), (3, 2), (7680, 4320)])
def test_odd_sizes_do_not_break_interactive_frames(view: ViewRenderer, gl_ctx: Any, size: tuple[int, int]) -> None:
    scale = MIN_SCALE if size[0] > 4000 else 0.5
    img = frame(gl_ctx, view, size, interactive=True, scale=scale)
    assert img.shape == (size[1], size[0], 3)
    assert view.r.last.size == scaled_size(size, scale)


@pytest.mark.gl
@pytest.mark.parametrize("distance", [0.05, 1e4])
def test_zoom_extremes(view: ViewRenderer, gl_ctx: Any, distance: float) -> None:
    import copy

    saved = copy.deepcopy(view.r.camera)
    cam = copy.deepcopy(saved)
    cam.distance = distance
    try:
        img = frame(gl_ctx, view, (320, 240), interactive=True, scale=0.5, camera=cam)
    finally:
        view.r.camera = saved
    assert img.shape == (240, 320, 3)


@pytest.mark.gl
def test_eight_shadowed_lights_and_a_map_covering_every_texel(view: ViewRenderer, gl_ctx: Any) -> None:
    from render.binding import layer_inputs
    from render.lights import Light

    doc = view.doc  # type: ignore[attr-defined]
    full = layer_inputs(doc, None)
    for lay in full:
        lay.thickness = np.full_like(lay.thickness, 5.0)
    saved = list(view.r.lights)
    try:
        view.r.set_layers(full)
        rig = [Light.directional(-170.0 + 45.0 * i, 10.0 + 5.0 * i, 0.4, shadows=True) for i in range(8)]
        view.r.lights = rig
        img = view.r.render_image((320, 240))
        assert img.std() > 5
    finally:
        view.r.lights = saved
        view.r.set_layers(layer_inputs(doc, None))


@pytest.mark.gl
def test_a_light_drag_relights_at_half_resolution_until_the_view_settles(view: ViewRenderer, gl_ctx: Any) -> None:
    from render.lights import Light

    size = (320, 240)
    frame(gl_ctx, view, size, interactive=False)
    full = view.r.settings.irradiance_size
    assert view.r.irradiance.size == full
    rebuilt = view.r.lighting.full_updates
    for az in (10.0, 20.0, 30.0):  # the key light dragged: interactive frames
        key = Light.directional(az, 30.0, 2.0)
        view.render(_target(gl_ctx, size), size, view.r.camera, key, interactive=True, scale=0.5)
        assert view.r.irradiance.size == full // 2, "a moving light must be relit at half resolution"
    assert view.r.lighting.full_updates == rebuilt, "no whole lighting cache while the light moves"
    view.render(_target(gl_ctx, size), size, view.r.camera, key, interactive=False)  # settled
    assert view.r.irradiance.size == full
    assert view.r.lighting.full_updates == rebuilt + 1, "the settled frame rebuilds the lighting cache once"


_TARGETS: dict[tuple[int, int], Any] = {}


def _target(ctx: Any, size: tuple[int, int]) -> Any:
    """A colour framebuffer of ``size`` kept for the module (the view binds and draws into it)."""
    if size not in _TARGETS:
        _TARGETS[size] = ctx.framebuffer([ctx.texture(size, 4)])
    return _TARGETS[size]
