"""What you pick is what you see: every material of the default library, rendered on a flat patch at normal
incidence under the studio's daylight preset, is its as-applied swatch (``km.Material.applied_rgb``: a
layer of its default thickness on the reference skin, or on the reference lip for lip products).

The patch is a flat, evenly subdivided square facing the camera, its albedo the reference background, its
thickness map the material's default thickness everywhere, drawn by the real renderer (shadows, the
texture-space irradiance and lighting cache, the fast SSS, the composite) with the viewport's lights: the
daylight preset's key light (``app.view.camera.Lighting.key_light``) and the default rig's fill and rim, as
``render.view.ViewRenderer`` sets them. The lobes (the skin's and the layer's) are switched off: the test
holds the diffuse colour, the highlights are ``tests/render/test_finishes.py``'s.

Exposure accounted for: the frame's linear values divided by the irradiance at normal incidence and the
exposure are the reflectance, compared with the swatch (ΔE2000 ≤ 2); and the displayed 8-bit frame (ACES,
sRGB) with the swatch lit the same way and shown through the same tone curve (ΔE2000 ≤ 2), at the
viewport's exposure (1) and ``sheer render``'s (0.85).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

import km
from km.colour import delta_e2000, linear_rgb_to_lab
from km.coverage import reference_background
from km.srgb import srgb_decode, srgb_encode
from render.km_pass import LayerInput
from render.lights import Light, default_lights
from render.renderer import Renderer

if TYPE_CHECKING:
    from collections.abc import Iterator

    from painting.head import Head

pytestmark = pytest.mark.gl
SIZE = (128, 128)
CENTRE = (slice(40, 88), slice(40, 88))  # the frame's middle, far from the patch's edges
TEX = 64  # the patch's albedo and thickness maps (texels per side)


def patch_head(albedo_linear: np.ndarray, quads: int = 16, side: float = 6.0) -> Head:
    """A flat square (``side`` mesh units, 10 mm each) facing +Z, UVs over [0, 1]², of uniform albedo."""
    from painting.head import Head, HeadMetadata

    g = np.linspace(-side / 2, side / 2, quads + 1)
    xx, yy = np.meshgrid(g, g)
    vertices = np.c_[xx.ravel(), yy.ravel(), np.zeros(xx.size)]
    uv = np.c_[(xx.ravel() + side / 2) / side, (yy.ravel() + side / 2) / side]
    faces = []
    for j in range(quads):
        for i in range(quads):
            a = j * (quads + 1) + i
            faces += [[a, a + 1, a + quads + 2], [a, a + quads + 2, a + quads + 1]]
    code = np.round(srgb_encode(np.clip(albedo_linear, 0, 1)) * 255).astype(np.uint8)
    return Head(Path("flat-patch"), vertices, np.asarray(faces, np.int64), uv,
                np.tile([0.0, 0.0, 1.0], (len(vertices), 1)), HeadMetadata(name="flat patch", mm_per_unit=10.0),
                albedo=np.broadcast_to(code, (TEX, TEX, 3)).copy())


def daylight_rig() -> list[Light]:
    """The viewport's lights under the daylight preset (app.settings.LIGHT_PRESETS, render.view's rig)."""
    from app.settings import LIGHT_PRESETS
    from app.view.camera import Lighting

    p = LIGHT_PRESETS["daylight"]
    lighting = Lighting(azimuth=p["azimuth"], elevation=p["elevation"], colour=p["colour"], intensity=p["intensity"])
    return [lighting.key_light(), *default_lights()[1:]]


def normal_irradiance(lights: list[Light]) -> np.ndarray:
    """Linear RGB irradiance on a surface facing +Z (display units)."""
    e = np.zeros(3)
    for lt in lights:
        d = np.asarray(lt.vector, float) / np.linalg.norm(lt.vector)
        e += np.asarray(lt.colour) * lt.intensity * max(float(d[2]), 0.0)
    return e


def aces(x: np.ndarray) -> np.ndarray:
    """common.glsl's tonemap_aces (Narkowicz 2015)."""
    return np.clip((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


def de(a: np.ndarray, b: np.ndarray) -> float:
    return float(delta_e2000(linear_rgb_to_lab(a), linear_rgb_to_lab(b)))


@pytest.fixture(scope="module")
def patches(_gl_session_ctx: Any) -> Iterator[dict[str, Renderer]]:
    """A renderer of a flat patch per reference background ("skin", "lip"), camera square on, daylight rig."""
    out = {}
    for key, category in (("skin", "foundation"), ("lip", "lipstick")):
        r = Renderer(_gl_session_ctx, patch_head(reference_background(category)))
        r.camera.yaw, r.camera.pitch, r.camera.distance, r.camera.fov_y = 0.0, 0.0, 8.0, 30.0
        r.camera.target = np.zeros(3)
        r.lights = daylight_rig()
        r.settings.spec_intensity = 0.0
        r.settings.layer_spec_intensity = 0.0
        out[key] = r
    yield out
    for r in out.values():
        r.release()
    assert _gl_session_ctx.error == "GL_NO_ERROR"


def centre(img: np.ndarray) -> np.ndarray:
    return np.median(img[CENTRE].reshape(-1, 3).astype(np.float64), axis=0)


def test_the_patch_is_square_on_and_evenly_lit(patches: dict[str, Renderer], gl_ctx: Any) -> None:
    """The bare patch shows its albedo times the irradiance at normal incidence (no layer: ΔE2000 ≤ 1)."""
    e = normal_irradiance(daylight_rig())
    for key, r in patches.items():
        r.set_layers([])
        img = r.render_image(SIZE, linear=True)
        assert np.ptp(img[CENTRE].reshape(-1, 3) @ [0.2126, 0.7152, 0.0722]) < 0.01  # flat: no gradient
        bg = reference_background("lipstick" if key == "lip" else "skin")
        assert de(centre(img) / e, bg) <= 1.0, key


@pytest.mark.parametrize("exposure", [1.0, 0.85], ids=["viewport", "sheer-render"])
def test_every_material_renders_as_its_as_applied_swatch(patches: dict[str, Renderer], gl_ctx: Any,
                                                          exposure: float) -> None:
    e = normal_irradiance(daylight_rig())
    worst: dict[str, tuple[float, float]] = {}
    for m in km.default_library():
        r = patches["lip" if m.category in ("lipstick", "lipgloss", "lipliner") else "skin"]
        r.settings.exposure = exposure
        r.set_layers([LayerInput(m, np.full((TEX, TEX), m.thickness_um, np.float32))])
        linear = centre(r.render_image(SIZE, linear=True))
        shown = centre(r.render_image(SIZE))
        swatch = m.applied_rgb("reference")
        reflectance_de = de(linear / (e * exposure), swatch)
        display_de = de(srgb_decode(shown / 255.0), srgb_decode(np.round(srgb_encode(aces(swatch * e * exposure)) * 255)
                                                                / 255.0))
        worst[m.name] = (round(reflectance_de, 2), round(display_de, 2))
    r.settings.exposure = 1.0
    print(f"exposure {exposure}: ΔE2000 (reflectance, display) per material:", worst)
    bad = {k: v for k, v in worst.items() if max(v) > 2.0}
    assert not bad, bad
