"""The camera's rotation refined on the photograph's specular lobe (issue 14).

Landmarks fix the camera only loosely: a face's points are nearly planar and seen almost
orthographically, so with 1 px of noise on 22 landmarks the head's rotation about the camera's x and y
axes is uncertain by 0.4–1.5° (:func:`capture.camera.pose_covariance`, whose σ the errors measured
on GPU-drawn photographs match to within 25 %). The probe gives the flash in camera coordinates, so
that error turns the flash relative to the head by as much, and the specular lobe — what fixes s and
i_s — lands on other normals: out of sample it was the error left (s within 10 % in 45 of 45 scenes from
the true camera, in 35 from the noisy landmarks; 42 with this refinement, README).

The photograph itself says where the lobe is. After the first fit, the head is turned about the skin
pixels' centroid by a small rotation E (about the camera's x and y axes; the image of the head stays in
place, its normals turn relative to the camera and the flash) and the lobe is fitted again on the
photograph high-passed at 2 px (:class:`capture.phong.LobeHighPass`: albedo broader than 2 px drops out,
the lobe's curvature stays). The turn that fits best is weighed against the landmarks' own estimate: the
maximum a posteriori of

    ‖HP residual(E, s)‖² / (σ_r²·κ)  +  aᵀ Σ⁻¹ a,     a = (turn about x, turn about y) in degrees,

with σ_r² the high-passed residual's variance per value at the start, Σ the calibration's rotation
covariance and κ = :data:`RESIDUAL_CORRELATION` (the residual values are not independent: the skin's
texture at 2 px is correlated across neighbouring pixels). The pixels keep the surface points the
first rasterisation gave them, though a 1° turn moves a point 50 mm in front of or behind the pivot by
0.9 mm (nearly 2 px at the validation's framing): reading each point in the photograph where the turned
camera sees it was worse on the tuning scenes (rotation error RMS 0.76° and 0.88° about x and y against
0.43° and 0.85°; the photograph's texture, interpolated between pixels, blurs as the turn moves it, and
the fit prefers the blur), and interpolating the smooth geometry instead no better. The capture then
starts again from the turned camera, re-rasterised.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import least_squares

from .phong import Geometry, LobeHighPass, PhongParams

if TYPE_CHECKING:
    from .camera import Camera

#: The high-passed residual's values per independent sample (κ above). Measured on scenes that are not
#: the validation's (32 GPU-drawn photographs: s 10, 18, 32, 50, the head turned −20°, −8°, +12°, +22°,
#: the flash (6°, 3°) and (−3°, 7°) from the lens, their own landmark noise): the photograph's turn alone
#: (no prior), from the noisy landmarks' cameras, scattered about the truth by √κ times its least-squares
#: σ at κ = 1 — mean squared z 152 about x and 386 about y; 250 is about their mean.
RESIDUAL_CORRELATION = 250.0
#: The largest turn the refinement may make, degrees: four of the landmarks' standard deviations at
#: their loosest (1.5°, the validation's framing with the head turned 30°).
MAX_TURN_DEG = 6.0


#: Points that pin both angles to this (degrees, one standard deviation) leave nothing to refine: the
#: lobe alone places them to 0.2–0.7° at best (measured with the true camera), so it could not move the
#: estimate by a tenth of that. The automatic capture's own mesh fits its landmarks to ~0.01 px.
PINNED_DEG = 0.02


@dataclass
class PoseRefinement:
    """What :func:`refine_rotation` found.

    Attributes:
        camera: the refined camera. turn_deg: (2,) its turn from the calibrated camera about the camera's x
            and y axes (degrees).
        photometric_deg: (2,) the turn the photograph alone prefers (degrees, linearised at the result).
        photometric_sigma_deg: (2,) its standard deviation (degrees, with κ).
        sigma_deg: (2,) the posterior standard deviation of the turn (degrees).
        exponent: s at the refined turn (dimensionless). evaluations: lobe fits run.
    """

    camera: Camera
    turn_deg: np.ndarray
    photometric_deg: np.ndarray
    photometric_sigma_deg: np.ndarray
    sigma_deg: np.ndarray
    exponent: float
    evaluations: int


def refine_rotation(photo_lin: np.ndarray, positions: np.ndarray, normals: np.ndarray, camera: Camera,
                    light_camera: np.ndarray, params: PhongParams, rows: np.ndarray, cols: np.ndarray,
                    pivot: np.ndarray | None = None, turned_deg: np.ndarray | None = None,
                    correlation: float = RESIDUAL_CORRELATION) -> PoseRefinement | None:
    """Refine ``camera``'s rotation on the specular lobe (see the module docstring).

    Args:
        photo_lin: (H, W, 3) the photograph, linear RGB.
        positions: (P, 3) the skin pixels' surface points (mesh units), as the first rasterisation gave them.
        normals: (P, 3) the unit normals there.
        rows: (P,) their pixels' rows.
        cols: (P,) their pixels' columns.
        camera: the calibrated camera; its ``rotation_covariance_deg2`` is the landmarks' uncertainty.
        light_camera: (3,) unit direction towards the flash in camera coordinates (the probe's).
        params: the first fit (D, k, A, F; its s starts the search).
        pivot: (3,) the point turned about (mesh units); None: the surface points' centroid.
        turned_deg: (2,) how far ``camera`` is already turned from the calibrated one about ``pivot``
            (degrees; the prior stays centred on the calibration). None: not at all.
        correlation: κ (values per independent sample).

    Returns None when there is nothing to refine against (a camera given directly, no covariance) or
    no lobe on the skin.
    """
    if camera.rotation_covariance_deg2 is None:
        return None
    cov = np.asarray(camera.rotation_covariance_deg2, dtype=float)
    if np.sqrt(cov.diagonal()).max() < PINNED_DEG:
        return None
    prior = np.linalg.cholesky(np.linalg.inv(cov)).T  # aᵀΣ⁻¹a = |prior @ a|²
    pivot = positions.mean(axis=0) if pivot is None else np.asarray(pivot, dtype=float)
    offset = np.zeros(2) if turned_deg is None else np.asarray(turned_deg, dtype=float)
    light_camera = np.asarray(light_camera, dtype=float)
    evaluations = 0

    photo = photo_lin[rows, cols]

    def lobe_fit(theta: np.ndarray) -> LobeHighPass:
        nonlocal evaluations
        evaluations += 1
        cam = camera.turned(np.radians([theta[0], theta[1], 0.0]), pivot)
        view = cam.centre[None, :] - positions
        view /= np.linalg.norm(view, axis=1, keepdims=True)
        return LobeHighPass(photo, Geometry.from_vectors(normals, view, cam.R.T @ light_camera), params, rows, cols)

    start = lobe_fit(np.zeros(2))
    r0, _ = start.residual(float(params.exponent))
    if not np.all(np.isfinite(r0)) or not start.ok.any():
        return None
    sigma_r = float(np.sqrt(np.mean(r0[start.ok] ** 2)))
    if sigma_r <= 0:
        return None
    weight = 1.0 / (sigma_r * np.sqrt(correlation))

    def photometric(theta: np.ndarray) -> np.ndarray:
        res, _ = lobe_fit(theta).residual(float(np.exp(theta[2])))
        return np.where(np.isfinite(res), res, 0.0).ravel() * weight

    def posterior(theta: np.ndarray) -> np.ndarray:
        return np.concatenate([photometric(theta), prior @ (theta[:2] + offset)])

    bound = np.array([MAX_TURN_DEG, MAX_TURN_DEG, np.inf])
    x0 = np.array([0.0, 0.0, np.log(params.exponent)])
    fit = least_squares(posterior, x0, bounds=(-bound, bound), x_scale=np.array([0.5, 0.5, 0.1]),
                        diff_step=np.array([1e-2, 1e-2, 1e-3]), xtol=1e-3, ftol=1e-6)
    # The photograph's own preference and the posterior spread, from the same Jacobian.
    jp = fit.jac[:-2]
    info_photo = jp.T @ jp
    try:
        post_cov = np.linalg.inv(fit.jac.T @ fit.jac)
        photo_cov = np.linalg.inv(info_photo)
        photo_only = fit.x[:2] - (photo_cov @ (jp.T @ fit.fun[:-2]))[:2]
    except np.linalg.LinAlgError:
        post_cov = photo_cov = np.full((3, 3), np.nan)
        photo_only = np.full(2, np.nan)
    turn = fit.x[:2]
    return PoseRefinement(camera=camera.turned(np.radians([turn[0], turn[1], 0.0]), pivot), turn_deg=turn + offset,
                          photometric_deg=photo_only + offset, photometric_sigma_deg=np.sqrt(np.diag(photo_cov)[:2]),
                          sigma_deg=np.sqrt(np.diag(post_cov)[:2]),
                          exponent=float(np.exp(fit.x[2])), evaluations=evaluations)
