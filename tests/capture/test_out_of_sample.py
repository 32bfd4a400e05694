"""Out-of-sample validation of the capture (issue 12).

tests/capture/test_validation.py checks the capture on the scenes its constants were tuned on: the
photograph drawn by the fitted model's own code (:func:`capture.phong.shade` on the CPU rasteriser),
the true camera passed in, s = 24 and the flash 4° above and 3° right of the lens, the sample head. Here
every photograph is drawn on the GPU by a renderer written for the test (tests/capture/gl_truth.py: its
own GLSL Phong, the GPU's rasteriser and texture filtering, 3 × 3 samples per pixel) and the capture
fits it with its CPU model, and each case changes what the constants never saw: the exponent, the
flash's angle, the skin, the head (the MediaPipe canonical face; the sample head's 1,143-triangle
level of detail), the camera (calibrated from clicked landmarks), the ambient light (the environment's
irradiance E(n)/π instead of a constant).

Every figure is asserted with a bound just above what the capture achieves today. Where it misses the
validation's targets (light ≤ 2°, s within 10 %, i_s within 5 %, diffuse ΔE2000 ≤ 1, reproduction
ΔE2000 < 2) the target is asserted and marked ``xfail(strict=True)`` with the measured figure: the
limitations are documented in :mod:`capture.phong` (s and i_s on textured skin), :mod:`capture.camera`
(clicked landmarks) and :mod:`capture.probe` (``MERGED_FULLNESS``); issue 14 takes them on.

Measured (the flash's direction error, s, i_s, diffuse ΔE2000, reproduction mean ΔE2000 on skin):

============== ============================================ ======= ================ ================= ==== ====
case           what changes (validation: s 24, i_s 0.18,    light   s                i_s               D    repr.
               flash 4° up 3° right, warehouse, sample head)
============== ============================================ ======= ================ ================= ==== ====
gpu-photo      the renderer only                            0.14°   23.67 (−1.4 %)   0.1745 (−3.0 %)   0.49 1.56
clicked-camera camera from 22 landmarks clicked to ±0.5 px  0.44°   22.35 (−6.9 %)   0.1726 (−4.1 %)   0.49 1.55
s12-irradiance s 12, flash 10° up 7° left, studio, E(n)/π   0.15°   12.37 (+3.1 %)   0.1741 (−3.3 %)   0.49 1.62
s60-dark-skin  s 60, i_s 0.10, D (0.25, 0.15, 0.11), city,  0.06°   59.79 (−0.4 %)   0.0986 (−1.4 %)   0.12 1.41
               flash 6° down 9° right
s8             s 8                                          0.14°   6.89 (−13.8 %)   0.1847 (+2.6 %)   0.23 1.78
flash-above    flash 10° up 1° right                        0.04°   28.46 (+18.6 %)  0.1783 (−0.9 %)   0.62 1.45
canonical-face s 30, i_s 0.25, lobby, flash 5° up 4° left   0.15°   29.15 (−2.8 %)   0.2530 (+1.2 %)   0.19 1.25
coarse-head    s 16, i_s 0.15, night, flash 3° up 5° left   0.10°   17.99 (+12.4 %)  0.1733 (+15.5 %)  0.22 1.63
============== ============================================ ======= ================ ================= ==== ====

The misses are the capture's, not the renderer's: the validation's own CPU photograph of the same scenes
gives s 6.91 (s8), 28.50 (flash-above), 18.29 and i_s +16.2 % (coarse-head; on the coarse head even the
validation's scene gives s 33.0 for 24 and i_s +8.3 %), and the skin's texture is what they read: drawn
with an untextured skin the three give s 7.97, 23.85 and 15.99, i_s within 1.3 %. With the landmarks
clicked to 1 px (Gaussian, five seeds) the light is 0.62–1.90° off, s −3.2 to −15.4 % and i_s −4.1 to
−11.6 %. The README's other exponents (the CPU photograph): 12 → 12.20 (studio), 12.41 (warehouse);
40 → 38.13 (city), 38.07 (sunset).
The probe alone, flash on a 2° grid within 12° of the lens: 16 of 169 positions refused as ambiguous
(12–17 in the six environments), the others within 0.35°.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import pytest
from scipy import ndimage

from capture.camera import calibrate, look_at
from capture.lod import simplify_head
from capture.mask import landmark_region
from capture.phong import PhongParams, delta_e2000
from capture.pipeline import capture
from capture.probe import ProbeError, analyse_probe, synthetic_probe
from capture.synthetic import (
    DIM_ROOM,
    FLASH_RGB,
    as_photographed,
    env_mean_radiance,
    light_from_camera,
    make_scene,
    read_env,
    validation_camera,
)
from core.assets import find_asset
from km.srgb import srgb_decode
from painting.head import load_head
from tests.capture import gl_truth

if TYPE_CHECKING:
    import moderngl

    from capture.camera import Camera
    from painting.head import Head

pytestmark = pytest.mark.slow

#: The validation's targets (README, "Validation on synthetic flash photographs").
TARGETS = {"light_deg": 2.0, "s": 0.10, "i_s": 0.05, "diffuse_de": 1.0, "reproduction_de": 2.0}
SKIN = (0.46, 0.31, 0.245)


@dataclass(frozen=True)
class Case:
    """One synthetic photograph: the truth and how it is taken.

    Attributes:
        head: "sample" (the validation's), "canonical" (the MediaPipe canonical face, a procedural
            texture) or "coarse" (the sample head decimated to 1,143 triangles, :mod:`capture.lod`).
        exponent: s. specular: i_s. diffuse: D (linear RGB, the texture's mean over the skin is 1).
        environment: the HDR environment of the ambient light and the probe.
        light_deg: the flash's angles above and to the right of the lens's axis, degrees.
        camera: "given" (the true camera) or "clicks" (calibrated from the head's landmarks clicked at
            the centre of the pixel they fall in).
        ambient: "constant" (the Phong model's A: the environment's mean radiance) or "irradiance"
            (E(n)/π per fragment).
    """

    head: str
    exponent: float
    specular: float = 0.18
    diffuse: tuple[float, float, float] = SKIN
    environment: str = "warehouse"
    light_deg: tuple[float, float] = (4.0, 3.0)
    camera: str = "given"
    ambient: str = "constant"


CASES = {
    "gpu-photo": Case("sample", 24.0),
    "clicked-camera": Case("sample", 24.0, camera="clicks"),
    "s12-irradiance": Case("sample", 12.0, environment="studio", light_deg=(10.0, -7.0), ambient="irradiance"),
    "s60-dark-skin": Case("sample", 60.0, 0.10, (0.25, 0.15, 0.11), "city", (-6.0, 9.0)),
    "s8": Case("sample", 8.0),
    "flash-above": Case("sample", 24.0, light_deg=(10.0, 1.0)),
    "canonical-face": Case("canonical", 30.0, 0.25, environment="lobby", light_deg=(5.0, -4.0)),
    "coarse-head": Case("coarse", 16.0, 0.15, environment="night", light_deg=(3.0, -5.0)),
}


class Figures(NamedTuple):
    """What the capture recovered, against the truth.

    Attributes:
        light_deg: angle between the recovered and the true flash direction, degrees.
        s: relative error of the exponent (s / s_true − 1). i_s: same for the specular intensity.
        diffuse_de: CIEDE2000 between the recovered and the true diffuse colour.
        reproduction_de: the capture's own mean ΔE2000 on skin (photo vs Phong × detail).
        s_value, i_s_value: the recovered values.
    """

    light_deg: float
    s: float
    i_s: float
    diffuse_de: float
    reproduction_de: float
    s_value: float
    i_s_value: float


def _head(kind: str) -> tuple[Head, np.ndarray]:
    """The head and its texture (linear, float (H, W, 3), ~1 on the face)."""
    if kind == "canonical":
        return load_head(find_asset("heads/canonical-face/canonical_face_model.obj")), _skin_texture()
    head = load_head()
    albedo = srgb_decode(np.asarray(head.albedo) / 255.0)
    # The coarse head's UVs come from the fine surface (capture.lod), so the albedo fits it closely
    # enough to be a skin texture; whatever is drawn is the truth.
    return (simplify_head(head, 1143) if kind == "coarse" else head), albedo


def _skin_texture(size: int = 512) -> np.ndarray:
    """A procedural skin texture (linear, mean 1): regional tone (σ 40 texels, 8 %), redness (σ 25, 4 %),
    blotches (σ 5, 4 %) and pores (σ 1, 3 %), seeded.
    """
    rng = np.random.default_rng(7)

    def field(sigma: float, amplitude: float) -> np.ndarray:
        f = ndimage.gaussian_filter(rng.standard_normal((size, size)), sigma)
        return f * (amplitude / f.std())

    tone = 1.0 + field(40, 0.08) + field(5, 0.04) + field(1, 0.03)
    red = field(25, 0.04)
    return np.stack([tone * (1 + red), tone, tone * (1 - 0.5 * red)], axis=-1)


def _camera(head: Head, kind: str) -> Camera:
    """The validation's camera; for the canonical face its framing (2.36 m, 6.4° vertical field, 512²)
    aimed at the middle of the face's landmarks.
    """
    if kind != "canonical":
        return validation_camera()
    lm = np.array(list(head.metadata.landmarks.values()))
    target = (lm.min(axis=0) + lm.max(axis=0)) / 2
    distance = 2362.5 / head.mm_per_unit
    return look_at(target + np.array([0.0, 0.0, distance]), target, np.array([0.0, 1.0, 0.0]), 6.4, 512, 512)


def _clicked_camera(head: Head, camera: Camera) -> Camera:
    """The camera calibrated from the head's landmarks (gnathion = chin left out) clicked at the centre
    of the pixel each falls in (±0.5 px).
    """
    names = sorted(set(head.metadata.landmarks) - {"gnathion"})
    points3d = np.array([head.metadata.landmarks[n] for n in names])
    pixels, _ = camera.project(points3d)
    return calibrate(np.floor(pixels) + 0.5, points3d, 512, 512)


@cache
def measure(ctx: moderngl.Context, name: str) -> Figures:
    """Draw case ``name`` on the GPU, capture it on the CPU, compare (cached per case)."""
    case = CASES[name]
    head, texture = _head(case.head)
    camera = _camera(head, case.head)
    env = read_env(str(find_asset(f"environments/{case.environment}.exr")))
    mean_radiance = env_mean_radiance(env)
    scale = DIM_ROOM / float(mean_radiance.mean())
    sh = gl_truth.irradiance_sh(env, scale) if case.ambient == "irradiance" else None
    light = light_from_camera(camera, *case.light_deg)
    # Scale D so that D × the texture's mean over the face is about the case's D (the exact truth is
    # read after the capture over the skin pixels it used).
    args = dict(specular=case.specular, exponent=case.exponent, light=light, flash=FLASH_RGB,
                ambient=mean_radiance * scale, sh=sh)
    first = gl_truth.render_photo(ctx, head, texture, camera, np.asarray(case.diffuse), supersample=1, **args)
    face = landmark_region(camera, head.metadata.landmarks, (512, 512)) & (first.coverage > 0)
    diffuse = np.asarray(case.diffuse) / first.texture[face].mean(axis=0)
    photo = gl_truth.render_photo(ctx, head, texture, camera, diffuse, **args)
    probe = as_photographed(synthetic_probe(env, camera.R, light, FLASH_RGB, size=256, env_scale=scale))
    used_camera = _clicked_camera(head, camera) if case.camera == "clicks" else camera
    result = capture(head, photo.linear, used_camera, probe=analyse_probe(probe), texture_size=512)
    truth = gl_truth.truth_diffuse(diffuse, photo, result.skin_mask)
    return Figures(
        light_deg=float(np.degrees(np.arccos(np.clip(result.light_dir_world @ light, -1.0, 1.0)))),
        s=result.exponent.s / case.exponent - 1.0, i_s=result.params.specular / case.specular - 1.0,
        diffuse_de=float(delta_e2000(result.params.diffuse, truth)),
        reproduction_de=result.reproduction_de2000_skin, s_value=result.exponent.s,
        i_s_value=result.params.specular)


QUANTITIES = ("light_deg", "s", "i_s", "diffuse_de", "reproduction_de")
#: Bounds just above today's figures (the module docstring), each within its target.
BOUNDS: dict[str, dict[str, float]] = {
    "gpu-photo": {"light_deg": 0.2, "s": 0.05, "i_s": 0.035, "diffuse_de": 0.6, "reproduction_de": 1.7},
    "clicked-camera": {"light_deg": 0.6, "s": 0.045, "i_s": 0.045, "diffuse_de": 0.6, "reproduction_de": 1.7},
    "s12-irradiance": {"light_deg": 0.2, "s": 0.05, "diffuse_de": 0.5, "reproduction_de": 1.75},
    "s60-dark-skin": {"light_deg": 0.1, "s": 0.02, "i_s": 0.035, "diffuse_de": 0.2, "reproduction_de": 1.55},
    "s8": {"light_deg": 0.2, "s": 0.08, "i_s": 0.02, "diffuse_de": 0.4, "reproduction_de": 1.8},
    "flash-above": {"light_deg": 0.1, "s": 0.01, "i_s": 0.045, "diffuse_de": 0.6, "reproduction_de": 1.55},
    "canonical-face": {"light_deg": 0.2, "s": 0.02, "i_s": 0.02, "diffuse_de": 0.25, "reproduction_de": 1.3},
    "coarse-head": {"light_deg": 0.15, "s": 0.02, "i_s": 0.01, "diffuse_de": 0.25, "reproduction_de": 1.65},
}
#: Targets missed today: (case, quantity) → the measured figure and the documented limitation.
MISSED = {
    ("s12-irradiance", "i_s"): "i_s 0.1709 for 0.18 (-5.06 %; -1.3 % untextured): the skin's pores under the "
                               "lobe's curvature at 2 px (capture.phong.specular_from_detail)",
}


def _params() -> list[object]:
    out = []
    for name in CASES:
        for quantity in QUANTITIES:
            reason = MISSED.get((name, quantity))
            marks = [pytest.mark.xfail(strict=True, reason=f"measured {reason}")] if reason else []
            out.append(pytest.param(name, quantity, marks=marks, id=f"{name}-{quantity}"))
    return out


def test_every_figure_has_a_bound_within_its_target_or_is_a_documented_miss() -> None:
    for name in CASES:
        for quantity in QUANTITIES:
            missed = (name, quantity) in MISSED
            assert missed != (quantity in BOUNDS[name]), (name, quantity)
            assert missed or BOUNDS[name][quantity] <= TARGETS[quantity], (name, quantity)


@pytest.mark.gl
@pytest.mark.parametrize(("name", "quantity"), _params())
def test_capture_of_a_gpu_photograph(name: str, quantity: str, gl_ctx: moderngl.Context) -> None:
    figures = measure(gl_ctx, name)
    bound = BOUNDS[name].get(quantity, TARGETS[quantity])
    assert abs(getattr(figures, quantity)) < bound, f"{name}: {figures}"


@pytest.mark.parametrize(("environment", "exponent", "readme"), [("studio", 12.0, 12.2), ("city", 40.0, 38.1)])
def test_the_readmes_other_exponents(environment: str, exponent: float, readme: float) -> None:
    """README: "Other exponents: 12 → 12.2 (studio) …; 40 → 38.1 (city, sunset)" (the validation's CPU
    photograph, s changed). Measured 12.20 and 38.13 (warehouse 12.41, sunset 38.07).
    """
    head = load_head()
    params = PhongParams(diffuse=np.array(SKIN), specular=0.18, exponent=exponent, ambient_scale=1.0)
    scene = make_scene(head, read_env(str(find_asset(f"environments/{environment}.exr"))), params=params)
    result = capture(head, scene.photo_lin, scene.camera, probe=analyse_probe(scene.probe_lin), texture_size=512)
    assert abs(result.exponent.s - readme) < 0.1


@cache
def _probe_scan() -> tuple[list[tuple[int, int]], float]:
    """The validation's probe (warehouse, 256² ball) with the flash on a 6° grid within 12° of the lens:
    (the positions refused, the largest light-direction error of the others in degrees).
    """
    camera = validation_camera()
    env = read_env(str(find_asset("environments/warehouse.exr")))
    scale = DIM_ROOM / float(env_mean_radiance(env).mean())
    refused, worst = [], 0.0
    for up in range(-12, 13, 6):
        for right in range(-12, 13, 6):
            light = light_from_camera(camera, up, right)
            image = as_photographed(synthetic_probe(env, camera.R, light, FLASH_RGB, size=256, env_scale=scale))
            try:
                found = camera.R.T @ analyse_probe(image).light_dir_camera
            except ProbeError:
                refused.append((up, right))
                continue
            worst = max(worst, float(np.degrees(np.arccos(np.clip(found @ light, -1.0, 1.0)))))
    return refused, worst


def test_probe_light_direction_anywhere_near_the_lens() -> None:
    """Measured: at most 0.25° off over the 24 positions found (of 25)."""
    _, worst = _probe_scan()
    assert worst < 0.3


def test_probe_finds_the_flash_anywhere_near_the_lens() -> None:
    """The flash on the lens's axis (a 12-pixel spot on a pixel corner) was refused as merged before
    the inscribed disc counted the spot's half-pixel rim (capture.probe.MERGED_FULLNESS)."""
    refused, _ = _probe_scan()
    assert not refused
