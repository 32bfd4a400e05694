"""The texture-space KM pass on the GPU against ``km`` (spectral, per texel)."""

from __future__ import annotations

import numpy as np
import pytest

import km
from km.colour import spectrum_to_rgb
from km.optics import layer_rt, stack
from render.km_pass import KMTextureSpace, LayerInput, default_wavelengths
from render.shaders import ShaderLibrary

pytestmark = pytest.mark.gl
MATERIALS = ("Foundation Ivory", "Blush Berry", "Eyeshadow Plum", "Lipstick Classic Red")


def km_reference(materials: list[object], maps: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(R_top, T, R_bottom) in linear sRGB per texel with km's own maths (float64)."""
    wl = default_wavelengths()
    pairs = []
    for mat, x in zip(materials, maps):
        s = np.interp(wl, mat.wavelengths, mat.S)
        k = np.interp(wl, mat.wavelengths, mat.K)
        pairs.append(layer_rt(s, k, x[..., None].astype(np.float64) * 1e-3))
    r_top, r_bottom, t = stack(pairs[::-1])  # km stacks top first
    return (spectrum_to_rgb(r_top, wl), spectrum_to_rgb(t, wl), spectrum_to_rgb(r_bottom, wl))


@pytest.fixture
def km_pass(gl_ctx: object):
    p = KMTextureSpace(gl_ctx, ShaderLibrary(), dtype="f4")
    yield p
    p.release()


def test_gpu_matches_km_spectrally(km_pass: KMTextureSpace) -> None:
    lib = km.default_library()
    mats = [lib.get(n) for n in MATERIALS]
    rng = np.random.default_rng(7)
    maps = [(rng.random((8, 16)) * m.max_thickness_um).astype(np.float32) for m in mats]
    maps[1][:, :4] = 0.0  # some texels without a layer
    maps[2][2, :] = 0.0
    for m in maps:
        m[0, 0] = 0.0
    maps[0][0, 1] = 1e-3  # very thin
    km_pass.set_layers([LayerInput(m, x) for m, x in zip(mats, maps)])
    got = km_pass.read()
    want = km_reference(mats, maps)
    for g, w, name in zip(got, want, ("R_top", "T", "R_bottom")):
        np.testing.assert_allclose(g, w, atol=1e-4, err_msg=name)


@pytest.mark.parametrize("split", [False, True], ids=["full", "tile-through-scratch"])
def test_display_encoding_is_within_8_bit_srgb_steps(gl_ctx: object, split: bool) -> None:
    """The default ``srgb8`` outputs (what the lit pass samples) are the float results rounded to the nearest
    8-bit sRGB code (within half a code, plus float slack), also for tiles evaluated through the scratch
    target and copied (a copy must move the encoded bytes, never decode or re-encode them)."""
    def encode(v: np.ndarray) -> np.ndarray:
        v = np.clip(v, 0.0, 1.0)
        return np.where(v <= 0.0031308, v * 12.92, 1.055 * v ** (1 / 2.4) - 0.055) * 255.0

    lib = km.default_library()
    mats = [lib.get(n) for n in MATERIALS]
    rng = np.random.default_rng(3)
    maps = [(rng.random((128, 128)) * m.max_thickness_um).astype(np.float32) for m in mats]
    exact = KMTextureSpace(gl_ctx, ShaderLibrary(), dtype="f4")
    disp = KMTextureSpace(gl_ctx, ShaderLibrary(), dtype="srgb8")
    try:
        layers = [LayerInput(m, x) for m, x in zip(mats, maps)]
        exact.set_layers(layers)
        if split:  # set up with zeros, then paint one tile: the few-tiles path goes through the scratch
            disp.set_layers([LayerInput(m, np.zeros_like(x)) for m, x in zip(mats, maps)])
            for i, x in enumerate(maps):
                disp.update_tiles(i, x, [(0, 1)])  # row 0, column 1
        else:
            disp.set_layers(layers)
        region = (slice(0, 64), slice(64, 128)) if split else (slice(None), slice(None))
        for g, w, name in zip(disp.read(), exact.read(), ("R_top", "T", "R_bottom")):
            np.testing.assert_allclose(encode(g[region]), encode(w[region]), rtol=0, atol=0.5 + 0.02, err_msg=name)
            assert g[region].max() > 0.05, name  # not trivially zero
    finally:
        exact.release()
        disp.release()


def test_tiles_update_only_their_texels_and_match_a_full_update(km_pass: KMTextureSpace) -> None:
    lib = km.default_library()
    mats = [lib.get("Foundation Ivory"), lib.get("Lipstick Classic Red")]
    maps = [np.full((128, 192), 10.0, np.float32), np.zeros((128, 192), np.float32)]
    km_pass.set_layers([LayerInput(m, x) for m, x in zip(mats, maps)])
    before = km_pass.read()
    new = maps[1].copy()
    new[64:128, 64:128] = 25.0  # tile (row 1, column 1)
    new[0:64, 128:192] = 25.0   # tile (row 0, column 2): (column, row) would be off the map
    new[0:10, 0:10] = 25.0      # tile (0, 0), not reported: must stay as it was
    km_pass.update_tiles(1, new, [(1, 1), (0, 2)])
    after = km_pass.read()
    reported = np.zeros((128, 192), bool)
    reported[64:128, 64:128] = reported[0:64, 128:192] = True
    ref = km_reference(mats, [maps[0], np.where(reported, new, 0.0)])
    for a, b, r in zip(after, before, ref):
        np.testing.assert_allclose(a[reported], r[reported], atol=1e-4)
        assert (np.abs(a[reported] - b[reported]) > 1e-3).any()  # the reported tiles did change
        np.testing.assert_array_equal(a[~reported], b[~reported])


def test_no_layers_is_the_identity(km_pass: KMTextureSpace) -> None:
    km_pass.set_layers([])
    r_top, t, r_bottom = km_pass.read()
    assert r_top.shape == (1, 1, 3)
    np.testing.assert_array_equal(r_top, 0.0)
    np.testing.assert_array_equal(t, 1.0)
    np.testing.assert_array_equal(r_bottom, 0.0)


def test_white_non_absorbing_layer_conserves_energy(km_pass: KMTextureSpace) -> None:
    wl = default_wavelengths()

    class White:
        name = "white"
        wavelengths = wl
        S = np.full(len(wl), 50.0)
        K = np.zeros(len(wl))

    x = np.linspace(0.0, 200.0, 64, dtype=np.float32).reshape(4, 16)
    km_pass.set_layers([LayerInput(White(), x)])
    r_top, t, _ = km_pass.read()
    np.testing.assert_allclose(r_top + t, 1.0, atol=1e-4)


def test_bad_layers_are_refused(km_pass: KMTextureSpace) -> None:
    from render.errors import RenderError

    mat = km.default_library().get("Foundation Ivory")
    with pytest.raises(RenderError, match="2D"):
        km_pass.set_layers([LayerInput(mat, np.zeros(5, np.float32))])
    with pytest.raises(RenderError, match="other layers"):
        km_pass.set_layers([LayerInput(mat, np.zeros((4, 4), np.float32)),
                            LayerInput(mat, np.zeros((8, 8), np.float32))])
    with pytest.raises(RenderError, match="opacity"):
        km_pass.set_layers([LayerInput(mat, np.zeros((4, 4), np.float32), opacity=2.0)])


def test_render_grid_matches_km_grid_in_colour() -> None:
    """The renderer integrates at RENDER_STEP_NM (10 nm); km's grid is 5 nm. Over every material of the
    default library, stacks of three at random thicknesses over skin-like backgrounds keep their colour
    within ΔE2000 0.05 (measured: 0.008)."""
    from km.colour import delta_e2000, linear_rgb_to_lab
    from km.spectra import DEFAULT_GRID

    fine = np.asarray(getattr(DEFAULT_GRID, "wavelengths", DEFAULT_GRID), dtype=np.float64)
    coarse = default_wavelengths()
    assert len(coarse) < len(fine)
    lib = km.default_library()
    mats = list(lib)
    rng = np.random.default_rng(11)

    def colour(wl: np.ndarray, layers: list, xs: list[float], skin: float) -> np.ndarray:
        pairs = [layer_rt(np.interp(wl, m.wavelengths, m.S), np.interp(wl, m.wavelengths, m.K), x * 1e-3)
                 for m, x in zip(layers, xs)]
        r_top, r_bottom, t = stack(pairs[::-1])
        return spectrum_to_rgb(r_top + t * t * skin / (1.0 - r_bottom * skin), wl)

    worst = 0.0
    for i in range(120):
        layers = [mats[(i + k * 7) % len(mats)] for k in range(3)]
        xs = [float(rng.random() * m.max_thickness_um) for m in layers]
        skin = float(0.25 + 0.3 * rng.random())
        a, b = colour(fine, layers, xs, skin), colour(coarse, layers, xs, skin)
        worst = max(worst, float(delta_e2000(linear_rgb_to_lab(a[None]), linear_rgb_to_lab(b[None]))[0]))
    assert worst < 0.05
