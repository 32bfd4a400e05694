"""The ambient light per surface direction, from the mirror-ball probe (issue 14).

A constant ambient A (the probe's mean radiance) is what a matte surface receives *on average over its
normals*; a surface with normal n receives the irradiance E(n) = ∫ L(ω) max(n·ω, 0) dω of the
environment, and shows A(n) = E(n)/π where a constant term would show A. The probe records L(ω) at the
photograph's exposure (an orthographic mirror ball is an equal-area map of the directions: every pixel
of the ball subtends 4π / N of the N pixels on it), so E(n) is measured, not modelled.

Ramamoorthi & Hanrahan (2001): E(n) is to within a few per cent its projection on the nine real
spherical harmonics of degree ≤ 2 (the clamped cosine's higher bands are small), E_lm = Â_l L_lm with
Â = (π, 2π/3, π/4) per band. So the probe's radiance is projected on those nine functions by the
ball's own quadrature, and A(n) = max(Σ E_lm Y_lm(n), 0)/π — whose mean over all normals is the
environment's mean radiance, the constant A, so the fit's ambient scale k keeps its meaning (k = 1:
photometrically consistent).

The flash is not ambient light: its core and halo on the ball (the directions within a few degrees of
the lens) take the median of the ring around them (:func:`capture.probe.analyse_probe`'s
``background``), and the cap behind the ball (ρ ≥ 0.97, the directions within 28° of the optical axis
pointing away from the camera, which the rim shows too obliquely to trust) the mean of the measured
ring just inside it (0.90 ≤ ρ < 0.97): the nearest directions measured. Clipped lamps count at their
clipped value, and the ball's reflectance divides the radiance, as for the constant A.

The coefficients are in the probe's camera coordinates (x right, y down, z forward): the probe is shot
by the photograph's camera, so a world normal n reads A(R n) with R the camera's world → camera rotation.

The basis and the cosine's convolution are :mod:`core.sh`'s, which the renderer's environment lighting
(:mod:`render.lights`) uses too.
"""

from __future__ import annotations

import math

import numpy as np

from core.sh import SH_COSINE, sh9_basis

#: The ball's outer rim left out of the measurement (normalised radius), as for the constant ambient.
RIM_RHO = 0.97
#: The ring inside the rim whose mean stands for the cap behind the ball (normalised radius).
RIM_RING_RHO = 0.90


def ball_reflections(dx: np.ndarray, dy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The reflected viewing directions of an orthographic mirror ball, and which points are on it.

    ``dx``, ``dy``: normalised ball coordinates (radius 1, broadcast together); returns the directions
    (..., 3) in camera coordinates and a bool (...) mask of the points on the ball.
    """
    dx, dy = np.broadcast_arrays(dx, dy)
    rr = dx ** 2 + dy ** 2
    nz = -np.sqrt(np.clip(1 - rr, 0, 1))
    n = np.stack([dx, dy, nz], axis=-1)
    view = np.array([0.0, 0.0, 1.0])
    return view - 2 * (n @ view)[..., None] * n, rr < 1.0


def probe_irradiance_sh(image: np.ndarray, ball: tuple[float, float, float], environment: np.ndarray,
                        flash: np.ndarray, background: np.ndarray, reflectance: float = 1.0) -> np.ndarray:
    """The environment's irradiance as nine SH coefficients (9, 3), from a mirror-ball photograph.

    Args:
        image: (H, W, 3) the probe, linear RGB in the photograph's units (clipped where the sensor clips).
        ball: (cx, cy, r) the ball's circle in pixels.
        environment: bool (H, W) the pixels measured as environment (on the ball, outside the rim,
            the flash's core and halo).
        flash: bool (H, W) the flash's core and halo (and the ring between them and the environment).
        background: (3,) the radiance standing in for the directions ``flash`` hides (photograph units,
            before dividing by the reflectance).
        reflectance: the ball's reflectance, 0 < reflectance ≤ 1.

    Returns:
        E_lm (9, 3) in photograph units × steradian-weighted (E(n) = Σ E_lm Y_lm(n), photograph units × π
        for a unit-radiance sky), in the probe's camera coordinates.
    """
    img = np.asarray(image, dtype=np.float64)
    h, w = img.shape[:2]
    cx, cy, r = ball
    yy, xx = np.mgrid[0:h, 0:w]
    dx = (xx + 0.5 - cx) / r
    dy = (yy + 0.5 - cy) / r
    directions, on_ball = ball_reflections(dx, dy)
    rho = np.sqrt(dx ** 2 + dy ** 2)
    radiance = np.zeros((h, w, 3))
    radiance[environment] = img[environment]
    radiance[flash & on_ball & ~environment] = np.asarray(background, dtype=np.float64)
    ring = environment & (rho >= RIM_RING_RHO)
    cap = on_ball & (rho >= RIM_RHO)
    radiance[cap] = img[ring].mean(axis=0) if ring.any() else img[environment].mean(axis=0)
    # Equal area: each pixel on the ball subtends 4π / N steradians.
    d_omega = 4.0 * math.pi / float(on_ball.sum())
    radiance_sh = np.einsum("pk,pc->kc", sh9_basis(directions[on_ball]), radiance[on_ball]) * d_omega
    return radiance_sh * SH_COSINE[:, None] / reflectance


def ambient_per_normal(irradiance_sh: np.ndarray, normals_camera: np.ndarray) -> np.ndarray:
    """A(n) = max(E(n), 0)/π (P, 3), photograph units, for unit normals in the probe's camera coordinates (P, 3)."""
    return np.clip(sh9_basis(normals_camera) @ np.asarray(irradiance_sh, dtype=np.float64), 0.0, None) / math.pi
