"""Finishes that read (issue #16): real GL frames of the sample head's lips, default camera and lights.

- matte / satin / gloss lipsticks of the default library (the same red, roughness 0.45 / 0.20 / 0.07)
  differ visibly: the gloss's peak luminance on the lower lip is ≥ 1.3× the matte's, and the matte shows
  no highlight (its peak is close to its median);
- the lip's own texture (albedo detail) shows through a sheer lipstick and is hidden by an opaque one:
  the gain of the bare lips' high-pass detail in each render (a regression slope), measured on the
  "unlit" debug view (makeup over the albedo, no shading) and on the lit frame.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from render.km_pass import LayerInput
from render.renderer import Renderer
from render.settings import RenderSettings

if TYPE_CHECKING:
    from collections.abc import Iterator

pytestmark = pytest.mark.gl
SIZE = (960, 720)
RESOLUTION = 1024
LUMA = np.array([0.2126, 0.7152, 0.0722])


@pytest.fixture(scope="module")
def doc() -> Any:
    from painting import Document

    return Document.from_head(resolution=RESOLUTION)


@pytest.fixture(scope="module")
def lips_um(doc: Any) -> np.ndarray:
    """A lipstick's thickness map: the lips filled to 20 µm with their 0.5 mm feather."""
    lay = doc.add_layer("Lipstick Classic Red")
    doc.fill_region(lay, "lips", 20.0)
    return np.array(lay.thickness)


@pytest.fixture(scope="module")
def renderer(_gl_session_ctx: Any, doc: Any) -> Iterator[Renderer]:
    r = Renderer(_gl_session_ctx, doc.head, layout=doc.layout)  # default camera and lights
    yield r
    r.release()
    assert _gl_session_ctx.error == "GL_NO_ERROR"


def region_pixels(doc: Any, r: Renderer, region: str, erode: int = 0) -> np.ndarray:
    """Bool (H, W): the pixels of the last frame onto which the region's inner texels (≥ 0.95) project."""
    from scipy.ndimage import binary_closing, binary_erosion

    atlas = doc.atlas_at(RESOLUTION)
    sel = (doc.region_values(region, RESOLUTION) >= 0.95) & atlas.coverage
    p = atlas.position[sel].astype(np.float64)
    c = np.c_[p, np.ones(len(p))] @ r.last.view_proj.T
    ndc = c[:, :2] / c[:, 3:4]
    w, h = SIZE
    x = np.clip(((ndc[:, 0] * 0.5 + 0.5) * w).astype(int), 0, w - 1)
    y = np.clip(((0.5 - ndc[:, 1] * 0.5) * h).astype(int), 0, h - 1)
    m = np.zeros((h, w), bool)
    m[y, x] = True
    m = binary_closing(m, iterations=2)
    return np.asarray(binary_erosion(m, iterations=erode) if erode else m, bool)


def frame(r: Renderer, layers: list[LayerInput], view: str = "none") -> np.ndarray:
    """Linear luminance (H, W) of a frame with ``layers`` (default lights, no tone map)."""
    r.settings = RenderSettings(debug_view=view)
    r.set_layers(layers)
    return r.render_image(SIZE, linear=True) @ LUMA


def test_gloss_shows_a_highlight_on_the_lower_lip_and_matte_does_not(doc: Any, renderer: Renderer,
                                                                      lips_um: np.ndarray, gl_ctx: Any) -> None:
    lib = doc.library
    finishes = {f: lib.get(f"Lipstick Red {f.title()}") for f in ("matte", "satin", "gloss")}
    frame(renderer, [])
    lower = region_pixels(doc, renderer, "lower_lip")
    assert lower.sum() > 400
    peak, median = {}, {}
    for f, mat in finishes.items():
        lum = frame(renderer, [LayerInput(mat, lips_um)])[lower]
        peak[f], median[f] = float(lum.max()), float(np.median(lum))
    print("lower lip peak (linear luminance):", {f: round(v, 4) for f, v in peak.items()},
          "gloss/matte", round(peak["gloss"] / peak["matte"], 2))
    assert peak["gloss"] >= 1.3 * peak["matte"]
    assert peak["matte"] < peak["satin"] < peak["gloss"]
    # a matte has no highlight: its brightest lower-lip pixel is within 1.6× its median (the gloss's is
    # several times it)
    assert peak["matte"] <= 1.6 * median["matte"]
    assert peak["gloss"] >= 2.5 * median["gloss"]


def test_the_lip_texture_shows_through_a_sheer_lipstick_and_not_an_opaque_one(
        doc: Any, renderer: Renderer, lips_um: np.ndarray, gl_ctx: Any) -> None:
    from scipy.ndimage import gaussian_filter

    lib = doc.library
    frame(renderer, [])
    # inside each lip, away from the mouth line and the outline (3 px)
    inner = region_pixels(doc, renderer, "upper_lip", 3) | region_pixels(doc, renderer, "lower_lip", 3)
    assert inner.sum() > 300

    def detail(lum: np.ndarray) -> np.ndarray:
        return (lum - gaussian_filter(lum, 2.0))[inner]

    gains: dict[str, dict[str, float]] = {}
    for view in ("unlit", "none"):
        bare = detail(frame(renderer, [], view))
        gains[view] = {}
        for name in ("Lipstick Sheer Red", "Lipstick Classic Red", "Lipstick Red Matte"):
            d = detail(frame(renderer, [LayerInput(lib.get(name), lips_um)], view))
            gains[view][name] = float(np.cov(d, bare)[0, 1] / np.var(bare))
    print("gain of the bare lips' detail:", {v: {k: round(g, 3) for k, g in d.items()} for v, d in gains.items()})
    unlit, lit = gains["unlit"], gains["none"]
    # the albedo's detail: most of it through the sheer tint, little through the opaque reds
    assert unlit["Lipstick Sheer Red"] >= 0.6
    assert unlit["Lipstick Classic Red"] <= 0.25 and unlit["Lipstick Red Matte"] <= unlit["Lipstick Classic Red"]
    # in the lit frame the lips' relief (normal map) shades every lipstick; the sheer still shows much more
    assert lit["Lipstick Sheer Red"] >= 1.5 * lit["Lipstick Classic Red"]
