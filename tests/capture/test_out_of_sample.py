"""Out-of-sample validation of the capture (issues 12 and 14).

tests/capture/test_validation.py checks the capture on the scenes its constants were first tuned on:
the photograph drawn by the fitted model's own code (:func:`capture.phong.shade` on the CPU rasteriser),
the true camera passed in, s = 24 and the flash 4° above and 3° right of the lens, the sample head. Here
every photograph is drawn on the GPU by a renderer written for the purpose (bench/capture_truth.py: its
own GLSL Phong, the GPU's rasteriser and texture filtering, 3 × 3 samples per pixel) and the capture
fits it with its CPU model, and each case changes what the constants never saw: the exponent (8–60),
the flash's angle (straight above, beside, off-axis), the skin, the head (the MediaPipe canonical face;
the sample head's 1,143-triangle level of detail), the camera (turned −30° to +30°, 10° below the eyes,
at 1.2 m to 4 m, calibrated from landmarks clicked to ±0.5 px or with 1 px of Gaussian noise), the ambient light (the
environment's irradiance E(n)/π instead of a constant).

Every figure is asserted with a bound just above what the capture achieves; where it misses the
validation's targets (light ≤ 2°, s within 10 %, i_s within 5 %, diffuse ΔE2000 ≤ 1, reproduction
ΔE2000 < 2) the target is asserted and marked ``xfail(strict=True)`` with the measured figure.

Measured (the flash's direction error, s, i_s, diffuse ΔE2000, the capture's reproduction mean ΔE2000 on
skin; "noisy": calibrated from landmarks with 1 px of noise):

================== =========================================== ======= =============== ================ ==== ====
case               what changes (validation: s 24, i_s 0.18,   light   s               i_s              D    repr.
                   flash 4° up 3° right, warehouse, sample)
================== =========================================== ======= =============== ================ ==== ====
gpu-photo          the renderer only                           0.14°   25.08 (+4.5 %)  0.1766 (−1.9 %)  0.52 0.45
clicked-camera     camera from 22 landmarks clicked to ±0.5 px 0.35°   25.04 (+4.3 %)  0.1764 (−2.0 %)  0.54 0.45
s12-irradiance     s 12, flash 10° up 7° left, studio, E(n)/π  0.15°   11.47 (−4.4 %)  0.1722 (−4.3 %)  0.42 0.45
s60-dark-skin      s 60, i_s 0.10, dark skin, city, flash 6°   0.06°   59.28 (−1.2 %)  0.1034 (+3.4 %)  0.12 0.40
                   down 9° right
s8                 s 8                                         0.14°   7.44 (−7.0 %)   0.1787 (−0.7 %)  0.34 0.44
flash-above        flash 10° up 1° right                       0.04°   24.14 (+0.6 %)  0.1746 (−3.0 %)  0.55 0.45
canonical-face     s 30, i_s 0.25, lobby, flash 5° up 4° left  0.15°   29.51 (−1.6 %)  0.2537 (+1.5 %)  0.19 0.16
coarse-head        s 16, i_s 0.15, night, flash 3° up 5° left  0.10°   15.56 (−2.7 %)  0.1498 (−0.1 %)  0.22 0.51
yaw-30-s40-beside  s 40, turned −30°, flash 8° right, sunset   0.64°   38.05 (−4.9 %)  0.1880 (+4.5 %)  0.45 0.49
                   sky, noisy
yaw+30-s24-above   turned +30°, flash 8° above, lobby sky,     0.23°   24.36 (+1.5 %)  0.1937 (+7.6 %)  0.24 0.50
                   noisy, the probe also without the flash
yaw+15-s12-near    s 12, turned +15° at 1.2 m, flash 6° above, 0.33°   11.62 (−3.2 %)  0.1753 (−2.6 %)  0.27 0.47
                   city sky, noisy
yaw-15-s8-off-axis s 8, turned −15°, flash 7° down 7° left,    0.51°   7.68 (−4.0 %)   0.1817 (+1.0 %)  0.27 0.45
                   studio sky, noisy
s60-beside-far     s 60 at 4 m, flash 10° left, warehouse      0.32°   62.22 (+3.7 %)  0.1708 (−5.1 %)  0.33 0.46
                   sky, noisy
sensor-noise-vign. s 24, flash 6° up 2° right, city sky, noisy, 0.95°   24.41 (+1.7 %)  0.1709 (−5.1 %)  0.61 0.90
                   40 % vignetting, photon and read noise
shadow-beside15-   s 24, turned +30°, flash 15° right, sunset  0.07°   21.85 (−9.0 %)  0.1858 (+3.2 %)  0.87 0.47
yaw+30             sky, the flash's cast shadows
shadow-above15-s40 s 40, flash 15° above, night sky, noisy,    0.50°   38.60 (−3.5 %)  0.1740 (−3.3 %)  0.55 0.43
                   cast shadows, the probe also without the flash
photo-s12-yaw-15-  s 12, turned −15°, flash 8° off-axis, city  0.40°   11.12 (−7.3 %)  0.1688 (−6.2 %)  1.01 0.91
off-axis           sky, noisy, cast shadows, the sky occluded,
                   the sensor above
pitch-10-s8-yaw-20 s 8, the camera 10° below the eyes (looking  0.19°   7.54 (−5.8 %)   0.1796 (−0.2 %)  0.53 0.45
                   up), turned −20°, flash 6° down 4° right,
                   lobby sky, noisy
================== =========================================== ======= =============== ================ ==== ====

The three before the last have the flash's cast shadows (bench/capture_truth.py draws them with its own shadow
map; the capture casts its own rays and leaves the shadowed skin out of the fit, capture/shadow.py), the
third also the sky occluded by the head (per-vertex ambient occlusion, 64 rays, which the capture does not model:
from the true camera it alone moves s 12 to 11.24 and i_s to −4.7 %, D 0.17). Without
the shadows drawn the first two give the same figures to 0.1 % (s 21.92, i_s +0.6 %, D 0.85; s 39.02,
i_s −7.9 %, D 1.11); before the capture cast its rays, a shadowed photograph moved s by up to 2 points
(turned +30°, the flash 15° beside, city sky, the true camera: −7.4 % without shadows, −9.4 % with). From
the true camera: s 40 → 39.42 (−1.4 %), i_s −3.3 %,
D 1.06 for the second; s −6.8 %, i_s −7.3 %, D 0.95 for the third, whose sensor alone costs it (from the true
camera, each part alone) D 0.09 → 0.88 and i_s −5.0 → −7.1 % with the vignetting (the fit reads the
darker periphery as darker skin) and the reproduction 0.43 → 0.88 with the noise (which no texture follows;
s and i_s unmoved by it).

Before issue 14 (the paper's saturation estimate refined by a robust Luv fit over the lobe, i_s on the
photograph high-passed at 3.5 mm) s came out 6.89 for 8 (−13.8 %), 28.46 for 24 with the flash above
(+18.6 %) and 17.99 for 16 on the coarse head (+12.4 %, i_s +15.5 %); with an untextured skin all three
were exact — the skin's texture under the lobe was read as part of it. Now s and i_s are fitted on the
photograph high-passed at 2 px (:func:`capture.lobe.specular_from_detail`). From the true camera the
noisy cases give s within 5 % (7.86, 24.26, 11.64, 62.90 and 24.62 for 8, 24, 12, 60 and 24 with the
sensor's noise) and i_s within 6.3 %: the
misses left are the landmarks' noise (which turns the flash and misplaces a narrow lobe). Every "noisy"
figure above is after the camera's rotation is refined on the photograph's specular lobe
(:mod:`capture.pose`, weighed against the landmarks' own uncertainty); before it they were (light, s,
i_s, D): 0.44°, −3.3 %, −3.1 %, 0.40; 0.32°, +2.2 %, +3.1 %, 0.98; 0.62°, −1.3 %, −6.9 %, 0.20; 1.12°,
−10.6 %, −2.2 %, 0.25; 0.07°, +4.4 %, −10.6 %, 0.34; 2.19°, −6.8 %, −16.3 %, 0.56; 1.15°, −2.4 %, −7.9 %,
1.10; 0.13°, −11.9 %, −16.4 %, 0.93 (in the table's order, the clicked camera 0.44°, +3.7 %, −3.8 %). The
noisy rows were measured on commit 0710a5f (the turn reads the surface the turned camera sees, weighed
by the lobe fit's own covariance); every row is re-measured on adca085, with capture.phong fitting the
lobe's registration (the geometry's sub-pixel shift across the photograph, a257991). That fit moves
the cases drawn from the true camera by ≤ 0.3 points of s but one: the 1,143-triangle head, s +1.3 →
−2.7 %, i_s −0.8 → +1.5 % (from the true camera it shifts that head's geometry 0.19 px: its normals,
interpolated linearly over triangles ~10 px across, kink at the edges, where the fit's second-order
pixel integration is not exact; still within the targets). The
reproduction of a face turned 15–30° was ΔE2000 2.04–2.82 while the detail texture was the photograph ÷
the paper's reflectance map; it is the photograph ÷ the fitted model since issue 15 (0.16–0.51 on every
case here, 0.90 with the sensor's noise, which the detail cannot follow; tests/capture/test_detail.py).
Every row is re-measured on 415e9e8: the lobe's registration also scales and rolls the image
(f24ee6d; it moved the noisy rows' s by up to 1 point) and i_s is read from the lobe integrated over each
pixel's square (capture.pixel_lobe; s unchanged by it): together they moved i_s by +0.3 to +3.0 points
(the second-order centre value had diluted the amplitude: −0.8 % on average untextured), −1.6 on the
1,143-triangle head (+1.5 → −0.1 %) and +6.5 on yaw-30-s40-beside (−2.2 → +4.3 %, with the scale and roll). The i_s misses left
are the skin's texture under the lobe (from the true camera untextured they read +0.2, +0.5 and −2.4 %)
and the sensor's vignetting, which the capture cannot tell from the face's albedo: given the lens's
falloff (``sheer capture --vignetting``, capture.vignetting) the sensor case reads i_s −3.3 % and D 0.13,
the last −4.0 % and D 0.16.
The noisy rows are re-measured on deb4870: the face's outline is a third measurement of the
camera's turn (capture.contour, fused with the landmarks and the lobe over the calibration's seven
parameters). It moved the light 0.46 → 0.23° on yaw+30-s24-above (i_s +8.3 → +7.3 %), 0.37 → 0.40° and
0.39 → 0.51° on the two turned −15° (whose landmarks' focal length is fitted, so the outline informs it more
than the turn), and D on photo-s12 0.94 → 1.01 across its target (its vignetting: 0.95 from the true camera);
the others by ≤ 0.01° and ≤ 0.3 points.
The two rows marked "the probe also without the flash" read the flash's hue from the probe photographed
with the flash minus the same probe without it (capture.probe.analyse_probe's ``without_flash``): from the
flash probe alone the room's texture under the flash's halo on the ball reads as flash light (R −2.2 %,
B +3.3 % in the lobby; R +3.1 %, B −4.1 % in the night; tests/capture/test_probe_hue.py), and D was 1.004
(1.002–1.007 over the five drawings) and 1.07, missing the target; with the second probe 0.24 (0.236–0.246)
and 0.55 (0.550–0.551). It moved i_s +7.3 → +7.6 % and −3.2 → −3.3 %, light and s by ≤ 0.001° and
0.05 points. Their D bounds follow the rule below (0.05 above the worst of the five drawings, rounded up
to 0.05).
The error distribution over 45 such scenes is ``sheer bench capture`` (the README).
The probe alone, flash on a 6° grid within 12° of the lens: all 25 positions found (the flash on the
lens's axis was refused before), within 0.3°.

Another GPU draws the photographs a little differently (GL asks only 4 sub-pixel bits of its rasteriser:
vertices may land up to 1/32 pixel away). Drawn again with the camera's projection moved 1/32 pixel each
way diagonally, the cases' figures moved by up to 0.08° (light), 1 point (s and i_s) and 0.01 (ΔE2000),
the noisy-camera ones most (their calibration refits every landmark's pixel). Each bound is at least half
its step (0.05° and ΔE2000, 0.5 point of s and i_s) above the worst of the five drawings; a documented
miss that came within that reach of its target (:data:`STRADDLING`) is an xfail that may also pass.
"""

from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING

import numpy as np
import pytest

from bench.capture_synthetic import (
    DIM_ROOM,
    FLASH_RGB,
    as_photographed,
    env_mean_radiance,
    light_from_camera,
    make_scene,
    read_env,
    validation_camera,
)
from bench.capture_truth import TARGETS, Case, Figures, Sensor, measure_case
from capture.phong import PhongParams
from capture.pipeline import capture
from capture.probe import ProbeError, analyse_probe, synthetic_probe
from core.assets import find_asset
from painting.head import load_head

if TYPE_CHECKING:
    import moderngl

pytestmark = pytest.mark.slow

SKIN = (0.46, 0.31, 0.245)

CASES = {
    "gpu-photo": Case("sample", 24.0),
    "clicked-camera": Case("sample", 24.0, camera="clicks"),
    "s12-irradiance": Case("sample", 12.0, environment="studio", light_deg=(10.0, -7.0), ambient="irradiance"),
    "s60-dark-skin": Case("sample", 60.0, 0.10, (0.25, 0.15, 0.11), "city", (-6.0, 9.0)),
    "s8": Case("sample", 8.0),
    "flash-above": Case("sample", 24.0, light_deg=(10.0, 1.0)),
    "canonical-face": Case("canonical", 30.0, 0.25, environment="lobby", light_deg=(5.0, -4.0)),
    "coarse-head": Case("coarse", 16.0, 0.15, environment="night", light_deg=(3.0, -5.0)),
    # Issue 14's grid: exponents 8–60, the camera turned −30° to +30° and nearer, the flash straight
    # above, beside and off-axis, the HDR sky as ambient, and landmarks with 1 px of noise (never the
    # true camera).
    "yaw-30-s40-beside": Case("sample", 40.0, environment="sunset", light_deg=(0.0, 8.0), camera="noisy",
                              ambient="irradiance", yaw_deg=-30.0),
    "yaw+30-s24-above": Case("sample", 24.0, environment="lobby", light_deg=(8.0, 0.0), camera="noisy",
                             ambient="irradiance", yaw_deg=30.0, probe_without_flash=True),
    "yaw+15-s12-near": Case("sample", 12.0, environment="city", light_deg=(6.0, 0.0), camera="noisy",
                            ambient="irradiance", yaw_deg=15.0, distance_mm=1200.0),
    "yaw-15-s8-off-axis": Case("sample", 8.0, environment="studio", light_deg=(-7.0, -7.0), camera="noisy",
                               ambient="irradiance", yaw_deg=-15.0),
    "s60-beside-far": Case("sample", 60.0, environment="warehouse", light_deg=(0.0, -10.0), camera="noisy",
                           ambient="irradiance", distance_mm=4000.0),
    # A real sensor: 40 % vignetting in the corners, photon noise (SNR 100 at 0.5) and read noise.
    "sensor-noise-vignetting": Case("sample", 24.0, environment="city", light_deg=(6.0, 2.0), camera="noisy",
                                    ambient="irradiance", sensor=Sensor(vignetting=0.4, shot=5e-5, read=0.002)),
    # yaw+30-s24-above and shadow-above15-s40 also photograph the probe without the flash (the flash's hue from
    # the difference: one probe reads it 2-4 % off per channel in the lobby and the night, ΔE2000 1.004 and 1.07).
    # The flash's cast shadows (the GPU's own shadow map; the capture casts its own rays, capture/shadow.py),
    # a flash on a bracket 15° from the lens.
    "shadow-beside15-yaw+30": Case("sample", 24.0, environment="sunset", light_deg=(0.0, 15.0), ambient="irradiance",
                                   yaw_deg=30.0, shadows=True),
    "shadow-above15-s40": Case("sample", 40.0, environment="night", light_deg=(15.0, 0.0), camera="noisy",
                               ambient="irradiance", shadows=True, probe_without_flash=True),
    # What a photograph has: shadows, the sky occluded in the creases, the sensor's vignetting and noise,
    # landmarks with noise.
    "photo-s12-yaw-15-off-axis": Case("sample", 12.0, environment="city", light_deg=(-5.7, 5.7), camera="noisy",
                                      ambient="irradiance", yaw_deg=-15.0, shadows=True,
                                      sensor=Sensor(vignetting=0.4, shot=5e-5, read=0.002), occlusion=True),
    # The camera below the eyes, looking up (``sheer bench capture --pitch`` spreads −10°, 0, +10°).
    "pitch-10-s8-yaw-20": Case("sample", 8.0, environment="lobby", light_deg=(-6.0, 4.0), camera="noisy",
                               ambient="irradiance", yaw_deg=-20.0, pitch_deg=-10.0),
}


@cache
def measure(ctx: moderngl.Context, name: str) -> Figures:
    """Case ``name`` drawn on the GPU and captured on the CPU (cached per case: every quantity's test
    shares one capture)."""
    return measure_case(ctx, CASES[name])


QUANTITIES = ("light_deg", "s", "i_s", "diffuse_de", "reproduction_de")
#: Bounds above today's figures and above those of the photographs drawn 1/32 pixel off (the module docstring),
#: each within its target.
BOUNDS: dict[str, dict[str, float]] = {
    "gpu-photo": {"light_deg": 0.2, "s": 0.05, "i_s": 0.025, "diffuse_de": 0.6, "reproduction_de": 0.5},
    "clicked-camera": {"light_deg": 0.4, "s": 0.05, "i_s": 0.025, "diffuse_de": 0.6, "reproduction_de": 0.5},
    "s12-irradiance": {"light_deg": 0.2, "s": 0.05, "i_s": 0.05, "diffuse_de": 0.5, "reproduction_de": 0.5},
    "s60-dark-skin": {"light_deg": 0.1, "s": 0.02, "i_s": 0.04, "diffuse_de": 0.2, "reproduction_de": 0.45},
    "s8": {"light_deg": 0.2, "s": 0.08, "i_s": 0.015, "diffuse_de": 0.4, "reproduction_de": 0.5},
    "flash-above": {"light_deg": 0.1, "s": 0.01, "i_s": 0.035, "diffuse_de": 0.6, "reproduction_de": 0.5},
    "canonical-face": {"light_deg": 0.2, "s": 0.02, "i_s": 0.02, "diffuse_de": 0.25, "reproduction_de": 0.2},
    "coarse-head": {"light_deg": 0.15, "s": 0.04, "i_s": 0.015, "diffuse_de": 0.3, "reproduction_de": 0.55},
    "yaw-30-s40-beside": {"light_deg": 0.7, "s": 0.055, "i_s": 0.05, "diffuse_de": 0.5, "reproduction_de": 0.55},
    "yaw+30-s24-above": {"light_deg": 0.3, "s": 0.02, "diffuse_de": 0.3, "reproduction_de": 0.55},
    "yaw+15-s12-near": {"light_deg": 0.4, "s": 0.05, "i_s": 0.035, "diffuse_de": 0.35, "reproduction_de": 0.5},
    "yaw-15-s8-off-axis": {"light_deg": 0.6, "s": 0.05, "i_s": 0.015, "diffuse_de": 0.4, "reproduction_de": 0.5},
    "s60-beside-far": {"light_deg": 0.4, "s": 0.04, "diffuse_de": 0.4, "reproduction_de": 0.5},
    "sensor-noise-vignetting": {"light_deg": 1.1, "s": 0.03, "diffuse_de": 0.65, "reproduction_de": 0.95},
    "shadow-beside15-yaw+30": {"light_deg": 0.1, "s": 0.1, "i_s": 0.04, "diffuse_de": 0.95, "reproduction_de": 0.5},
    "shadow-above15-s40": {"light_deg": 0.6, "s": 0.045, "i_s": 0.04, "diffuse_de": 0.65, "reproduction_de": 0.5},
    "photo-s12-yaw-15-off-axis": {"light_deg": 0.5, "s": 0.08, "reproduction_de": 0.95},
    # five drawings: light 0.17-0.20°, s -5.8 to -6.4 %, i_s -0.4 to +0.6 %, D 0.534-0.543, reproduction 0.447
    "pitch-10-s8-yaw-20": {"light_deg": 0.25, "s": 0.07, "i_s": 0.01, "diffuse_de": 0.6, "reproduction_de": 0.5},
}
#: Targets missed today: (case, quantity) → the measured figure and the documented limitation.
MISSED = {
    ("yaw+30-s24-above", "i_s"): "i_s 0.1937 for 0.18 (+7.6 %; +7.3 % with the flash's hue from one probe; "
                                 "+7.9 % from the true camera, +0.2 % from it untextured): the skin's texture under "
                                 "the lobe at 2 px",
    ("s60-beside-far", "i_s"): "i_s 0.1708 for 0.18 (-5.1 %; -5.3 % from the true camera, +0.5 % from it "
                               "untextured): the skin's texture under a narrow lobe at 2 px",
    ("sensor-noise-vignetting", "i_s"): "i_s 0.1709 for 0.18 (-5.1 %; -4.9 % from the true camera; -3.3 % with "
                                        "the lens's falloff given, capture.vignetting: the 40 % vignetting)",
    ("photo-s12-yaw-15-off-axis", "diffuse_de"): "ΔE2000 1.007 (0.94 before the face's outline joined the pose, "
                                                 "capture.contour; 0.95 from the true camera, 0.16 with the lens's "
                                                 "falloff given): the sensor's 40 % vignetting, read as darker skin "
                                                 "at the periphery",
    ("photo-s12-yaw-15-off-axis", "i_s"): "i_s 0.1688 for 0.18 (-6.2 %; -6.4 % from the true camera, -4.0 % "
                                          "with the lens's falloff given, -2.4 % from the true camera untextured)",
}


#: The documented misses' own bounds, an ordinary test each (:func:`test_a_documented_miss_stays_within_its_bound`):
#: the figure measured above plus a margin wider than the five drawings moved it (0.05 ΔE2000, 1 to 1.4 points
#: of i_s), so a miss that grows fails, whatever its target's expected failure does. A bound is loosened only
#: with the measured cause in the commit message.
MISS_BOUNDS = {
    ("yaw+30-s24-above", "i_s"): 0.085,  # +7.5 to +7.6 %
    ("s60-beside-far", "i_s"): 0.065,  # -4.9 to -5.3 %
    ("sensor-noise-vignetting", "i_s"): 0.07,  # -4.6 to -5.6 %
    ("photo-s12-yaw-15-off-axis", "diffuse_de"): 1.06,  # 1.007
    ("photo-s12-yaw-15-off-axis", "i_s"): 0.075,  # -6.2 %
}


#: Documented misses within another rasteriser's reach of their targets (the module docstring): measured
#: across the five drawings, s60-beside-far's i_s −4.9 to −5.3 %, sensor-noise-vignetting's i_s −4.6 to −5.6 %.
STRADDLING = {("s60-beside-far", "i_s"), ("sensor-noise-vignetting", "i_s")}


def _params() -> list[object]:
    out = []
    for name in CASES:
        for quantity in QUANTITIES:
            reason = MISSED.get((name, quantity))
            strict = (name, quantity) not in STRADDLING
            marks = ([pytest.mark.xfail(strict=strict, raises=AssertionError, reason=f"measured {reason}")]
                     if reason else [])
            # a case's quantities share one capture (measure's cache): one worker measures them all
            marks.append(pytest.mark.xdist_group(f"out-of-sample-{name}"))
            out.append(pytest.param(name, quantity, marks=marks, id=f"{name}-{quantity}"))
    return out


def test_every_figure_has_a_bound_within_its_target_or_is_a_documented_miss() -> None:
    for name in CASES:
        for quantity in QUANTITIES:
            missed = (name, quantity) in MISSED
            assert missed != (quantity in BOUNDS[name]), (name, quantity)
            assert missed or BOUNDS[name][quantity] <= TARGETS[quantity], (name, quantity)


def test_every_documented_miss_has_its_own_bound() -> None:
    assert set(MISS_BOUNDS) == set(MISSED)
    for (name, quantity), bound in MISS_BOUNDS.items():
        assert bound > TARGETS[quantity], (name, quantity)  # a miss: beyond its target, within its own bound


@pytest.mark.gl
@pytest.mark.parametrize(("name", "quantity"),
                         [pytest.param(name, quantity, marks=pytest.mark.xdist_group(f"out-of-sample-{name}"),
                                       id=f"{name}-{quantity}") for name, quantity in sorted(MISS_BOUNDS)])
def test_a_documented_miss_stays_within_its_bound(name: str, quantity: str, gl_ctx: moderngl.Context) -> None:
    figures = measure(gl_ctx, name)  # the capture its target's test measured (measure's cache)
    assert abs(getattr(figures, quantity)) < MISS_BOUNDS[(name, quantity)], f"{name}: {figures}"


@pytest.mark.gl
@pytest.mark.parametrize(("name", "quantity"), _params())
def test_capture_of_a_gpu_photograph(name: str, quantity: str, gl_ctx: moderngl.Context) -> None:
    figures = measure(gl_ctx, name)
    bound = BOUNDS[name].get(quantity, TARGETS[quantity])
    assert abs(getattr(figures, quantity)) < bound, f"{name}: {figures}"


@pytest.mark.parametrize(("environment", "exponent", "readme"), [("studio", 12.0, 11.8), ("city", 40.0, 42.8)])
def test_the_readmes_other_exponents(environment: str, exponent: float, readme: float) -> None:
    """README: "Other exponents: 12 → 11.8 (studio); 40 → 42.8 (city)" (the validation's CPU photograph,
    s changed). Measured 11.83 and 42.81: the CPU photograph samples each pixel's centre, the fit models
    a sensor that integrates its pixel (:func:`capture.lobe.specular_from_detail`).
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
