"""A gloss lipstick shows a highlight a designer can see from the studio's default view (the daylight preset).

Before, the cosmetic layers' own specular lobes were scaled by the skin's ρ_s (0.18, d'Eon and Luebke's
empirical factor for skin), so a gloss layer reflected a fifth of its Fresnel reflection, and every light was
a point, whose reflection in a smooth layer is a point: at roughness 0.05 a pixel or two of highlight on the
lower lip, and it read as satin. A layer's lobe is now its Fresnel reflection (Huang et al. 2013 Eq. 5:
Kelemen's lobe with Schlick's Fresnel from the layer's IOR; ``RenderSettings.layer_spec_intensity`` = 1), the
skin's own lobe keeping ρ_s; and the studio's lights have a size (``RenderSettings.light_radius_deg``, 12°:
a softbox), which spreads a smooth lobe, normalised, into a patch.

Frames: the viewport's camera (the head framed as ``Viewport.frame_head`` does), the daylight preset's key
light with the default rig's fill and rim (as ``render.view.ViewRenderer``), the lips filled with *Lipstick
Red Gloss* at its default thickness, its roughness set to 0.05 and to 0.35; linear luminance on the lips.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from render.km_pass import LayerInput
from render.lights import default_lights

if TYPE_CHECKING:
    from render.renderer import Renderer

pytestmark = pytest.mark.gl
SIZE = (960, 720)
LUMA = np.array([0.2126, 0.7152, 0.0722])


def studio_view(r: Renderer) -> None:
    """The viewport's starting view (app.view.viewport.Viewport.frame_head) and the daylight rig."""
    from app.settings import LIGHT_PRESETS
    from app.view.camera import Lighting, ViewCamera

    cam = ViewCamera()
    v = r.head.vertices
    top = v[:, 1].max()
    face = v[(v[:, 1] > top - 4.6) & (v[:, 2] > v[:, 2].min() + 0.3 * np.ptp(v[:, 2]))]
    cam.frame_box(face.min(axis=0), face.max(axis=0))
    c = r.camera
    c.yaw, c.pitch, c.distance, c.fov_y, c.target = cam.yaw, cam.pitch, cam.distance, cam.fov_y, np.array(cam.target)
    p = LIGHT_PRESETS["daylight"]
    lighting = Lighting(azimuth=p["azimuth"], elevation=p["elevation"], colour=p["colour"], intensity=p["intensity"])
    r.lights = [lighting.key_light(), *default_lights()[1:]]


def lip_pixels(doc: Any, r: Renderer) -> np.ndarray:
    """Bool (H, W): the pixels of the last frame onto which the lips' inner texels project."""
    from scipy.ndimage import binary_closing

    res = doc.resolution
    atlas = doc.atlas_at(res)
    p = atlas.position[(doc.region_values("lips", res) >= 0.95) & atlas.coverage].astype(np.float64)
    c = np.c_[p, np.ones(len(p))] @ r.last.view_proj.T
    w, h = SIZE
    x = np.clip(((c[:, 0] / c[:, 3] * 0.5 + 0.5) * w).astype(int), 0, w - 1)
    y = np.clip(((0.5 - c[:, 1] / c[:, 3] * 0.5) * h).astype(int), 0, h - 1)
    m = np.zeros((h, w), bool)
    m[y, x] = True
    return np.asarray(binary_closing(m, iterations=2), bool)


def lips_luminance(r: Renderer, doc: Any, lips_um: np.ndarray, roughness: float) -> np.ndarray:
    mat = doc.library.get("Lipstick Red Gloss").replace(roughness=roughness)
    r.set_layers([LayerInput(mat, lips_um)])
    return r.render_image(SIZE, linear=True) @ LUMA


def test_a_gloss_lipstick_shows_a_highlight_from_the_default_view(renderer: Renderer, doc: Any, gl_ctx: Any) -> None:
    gloss = doc.library.get("Lipstick Red Gloss")
    lay = doc.add_layer(gloss.name)
    doc.fill_region(lay, "lips", gloss.thickness_um)
    lips_um = np.array(lay.thickness)
    studio_view(renderer)
    figures = {}
    try:
        for rho in (0.18, 1.0):  # the old scaling (the skin's ρ_s, point lights), the layer's Fresnel reflection
            renderer.settings.layer_spec_intensity = rho
            renderer.settings.light_radius_deg = 0.0 if rho < 1.0 else 12.0
            for rough in (0.05, 0.35):
                lum = lips_luminance(renderer, doc, lips_um, rough)
                on = lip_pixels(doc, renderer)
                assert on.sum() > 1000
                figures[(rho, rough)] = (float(lum[on].max()), int((lum[on] > 0.5).sum()), float(np.median(lum[on])))
    finally:
        renderer.settings.layer_spec_intensity = 1.0
        renderer.settings.light_radius_deg = 12.0
        doc.remove_layer(lay)
    print("lips: (peak linear luminance, pixels above 0.5, median) by (layer lobe scale, roughness):",
          {k: (round(a, 3), n, round(m, 3)) for k, (a, n, m) in figures.items()})
    (peak, bright, median), (satin_peak, satin_bright, satin_median) = figures[(1.0, 0.05)], figures[(1.0, 0.35)]
    # a highlight: past the tone curve's shoulder (shown near white) on a patch of the lower lip, seven
    # times the lipstick's own brightness, where a rough lipstick of the same colour shows none
    assert peak >= 1.5 and peak >= 5.0 * satin_peak and bright >= 10 and satin_bright == 0, figures
    # the highlight is the lobe's: the lips' diffuse colour (their median) is the same for both roughnesses
    assert median == pytest.approx(satin_median, rel=0.15)
    # what the old scaling showed: half the peak, a pixel or two
    assert figures[(0.18, 0.05)][0] < 0.6 * peak and figures[(0.18, 0.05)][1] <= bright / 3, figures
