"""The Regions overlay (render.region_overlay, issue #16): outlines of the shown regions on the visible
surface, in their colours, over a real frame; nothing drawn when none is shown; the region's inside tinted."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from render.errors import RenderError
from render.glutil import release_all
from render.region_overlay import RegionOverlay, region_colour

if TYPE_CHECKING:
    from collections.abc import Iterator

    from render.renderer import Renderer

pytestmark = pytest.mark.gl
SIZE = (480, 360)


@pytest.fixture(scope="module")
def target(_gl_session_ctx: Any) -> Iterator[Any]:
    """One colour target for the module (released last: a deleted framebuffer must never stay bound)."""
    colour = _gl_session_ctx.texture(SIZE, 4)
    fbo = _gl_session_ctx.framebuffer([colour])
    yield fbo
    release_all(_gl_session_ctx, [fbo, colour])  # re-binds GL's framebuffer when this one is still bound


def _frame_with(r: Renderer, fbo: Any, overlay: RegionOverlay | None) -> np.ndarray:
    """A bare frame (8-bit sRGB, top row first) with the overlay drawn over it."""
    r.render(fbo, (0, 0, *SIZE))
    if overlay is not None:
        overlay.draw(fbo, SIZE, r.last.view_proj, r.camera.view())
    raw = fbo.read(components=3)
    return np.frombuffer(raw, np.uint8).reshape(SIZE[1], SIZE[0], 3)[::-1].astype(int)


def _project(r: Renderer, points: np.ndarray) -> np.ndarray:
    c = np.c_[points, np.ones(len(points))] @ r.last.view_proj.T
    ndc = c[:, :2] / c[:, 3:4]
    return np.stack([(ndc[:, 0] * 0.5 + 0.5) * SIZE[0], (0.5 - ndc[:, 1] * 0.5) * SIZE[1]], axis=1)


def test_outlines_follow_the_shown_regions(doc: Any, renderer: Renderer, target: Any, gl_ctx: Any) -> None:
    overlay = RegionOverlay(gl_ctx, renderer.shaders, renderer.gpu_head)
    try:
        bare = _frame_with(renderer, target, None)
        overlay.set_regions({})
        # nothing shown, nothing drawn: the same frame again, exactly determined (GL 4.5 appendix A, rule 4)
        assert np.array_equal(_frame_with(renderer, target, overlay), bare)
        regions = {n: doc.regions.get(n).mask for n in ("lips", "lash_line")}
        overlay.set_regions(regions)
        shown = _frame_with(renderer, target, overlay)
        changed = np.abs(shown - bare).max(axis=-1) > 24
        assert changed.sum() > 150
        # every changed pixel is near a shown region's projected texels (its outline or tinted inside)
        atlas = doc.atlas_at(1024)
        near = np.zeros(changed.shape, bool)
        for mask in regions.values():
            sel = (mask >= 0.25) & atlas.coverage
            px = np.round(_project(renderer, atlas.position[sel].astype(float))).astype(int)
            ok = (px[:, 0] >= 0) & (px[:, 0] < SIZE[0]) & (px[:, 1] >= 0) & (px[:, 1] < SIZE[1])
            near[px[ok, 1], px[ok, 0]] = True
        from scipy.ndimage import binary_dilation

        near = binary_dilation(near, iterations=3)
        assert (changed & ~near).sum() <= 0.01 * changed.sum()
        # the lips' outline is drawn in the lips' colour: the most changed pixels around the mouth lean to it
        lc = _project(renderer, np.asarray([doc.head.metadata.landmarks["lip_centre"]], float))[0].astype(int)
        box = (slice(lc[1] - 25, lc[1] + 25), slice(lc[0] - 40, lc[0] + 40))
        delta = (shown - bare)[box][changed[box]]
        want = np.asarray(region_colour("lips")) - 0.5
        assert float(np.mean(delta @ want)) > 0.0
        # both eyes' lash lines are outlined (changed pixels above the eye corners' level, both sides)
        eyes = [_project(renderer, np.asarray([doc.head.metadata.landmarks[f"{s}_eye_outer"]], float))[0]
                for s in ("left", "right")]
        for e in eyes:
            x, y = int(e[0]), int(e[1])
            assert changed[y - 15:y + 10, min(x, SIZE[0] // 2) - 5:max(x, SIZE[0] // 2) + 5].any()
        with pytest.raises(RenderError, match="square and of one size"):
            overlay.set_regions({"lips": np.zeros((8, 8)), "eyes": np.zeros((16, 16))})
    finally:
        overlay.release()
