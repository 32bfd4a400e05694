"""The camera's rotation refined on the photograph's specular lobe (issue 14).

Landmarks fix the camera only loosely: a face's points are nearly planar and seen almost
orthographically, so with 1 px of noise on 22 landmarks the head's rotation about the camera's x and y
axes is uncertain by 0.4–1.5° (:func:`capture.camera.pose_covariance`, whose σ the errors measured
on GPU-drawn photographs match to within 25 %). The probe gives the flash in camera coordinates, so
that error turns the flash relative to the head by as much, and the specular lobe — what fixes s and
i_s — lands on other normals.

The photograph itself says where the lobe is. After the first fit, the head is turned about the skin
pixels' centroid by a small rotation E (about the camera's x and y axes; :meth:`Camera.turned` keeps the
pivot's image in place) and the lobe is fitted again on the photograph high-passed at 2 px
(:class:`capture.lobe.LobeHighPass`: albedo broader than 2 px drops out, the lobe's curvature stays).

**What a turn changes at a pixel.** The turned camera sees, at each pixel, another surface point: a point
d in front of the pivot moves by about d·|E| in the image (1.7 px per degree 50 mm in front, at the
bench's framing). Where the surface curves, that move changes the normal under the pixel by as much as
the turn itself, and in the opposite sense on a convex face (a sphere turned about its own centre shows
the same normals at every pixel). So each pixel reads its normal and surface point from the first
rasterisation where the turned camera moved them from (:class:`Surface`, bilinear between pixel
centres: the geometry is smooth, and the photograph itself is never resampled). Keeping each pixel's
first surface point and only turning its normal (an earlier refinement) moved the lobe by a
full turn per degree wherever it lay: its preferred turn followed the truth with a slope of 0.25–0.31
(correlation 0.26–0.41) on 32 development scenes; reading the moved geometry, 0.88–1.12 (correlation
0.67–0.72) on 48.

Pixels within :data:`BORDER_PX` of a fold or an occluding edge (the nose over the cheek, the lips'
line) are left out of the fit: reading geometry across one blends two surfaces (normals up to 110° off
where the re-rasterisation has them right), and on the development scenes turned 25–35° those pixels
alone put the photograph's turn 4.5–6.3 of its σ off (2.7–3.2 without them).

**The weighing.** The photograph's own turn â (the lobe fit without a prior) has the covariance of an
M-estimator whose residuals are correlated between neighbouring pixels — the skin's texture at 2 px and
the high-pass itself: the cluster-robust ("sandwich") covariance H⁻¹ (Σ_b g_b g_bᵀ) H⁻¹, H = JᵀJ the
cost's curvature and g_b = J_bᵀ r_b the residual's score summed over blocks of :data:`capture.covariance.BLOCK_PX` pixels
(nearly independent blocks), per photograph. That sees the residual's correlation but not the lobe
model's own bias (the skin's texture under the lobe, D's error, the first-order read): on 48
development scenes (s 10–50, the head turned ±10° to ±35°, four flash placements, their own landmark
noise and sensor; none the validation's) the photograph's turn was off by 3.0 and 2.8 of those σ (RMS,
about x and y), so the covariance is scaled by the mean squared ratio, :data:`MODEL_BIAS_VARIANCE`. It
is combined with the landmarks' Gaussian N(0, Σ) (Σ the calibration's ``rotation_covariance_deg2``) as
two Gaussian measurements of the same turn: a = (C⁻¹ + Σ⁻¹)⁻¹ C⁻¹ â. (An earlier version weighed the whole
high-passed residual by one constant, κ = 250 values per independent sample, on that helper's 32 scenes;
its turn followed the truth with a slope of 0.25–0.31, so the weight hardly mattered.)

**A third measurement: the face's outline** (:mod:`capture.contour`). The occluding contour of the cheek
and jaw lies behind the pivot, so a turn moves it in the image where it hardly moves the landmarks; its
edge, fitted along the contour's normals, gives a turn ĉ (tight about the camera's y axis, loose about x)
with its own covariance K. The outline also moves with the landmark calibration's other errors (focal
length and distance, scale, translation), so ĉ measures A·δ, δ the calibration's whole error: with the
calibration's 7 × 7 covariance Σ₇ the three are fused over δ (:func:`_fuse`: δ ~ N(μ, Σ₇), â ≈ δ_xy with
C, ĉ ≈ A·δ with K) and the turn is the posterior's δ_xy; without Σ₇, as three Gaussians of the turn,
a = (C⁻¹ + Σ⁻¹ + K⁻¹)⁻¹ (C⁻¹ â + K⁻¹ ĉ). On the 48 development scenes above the refined camera's rotation
error went from 0.35 / 0.69 / 0.97° (median / p90 / max) to 0.23 / 0.45 / 0.74°, its RMS about x and y
0.29 / 0.32 → 0.24 / 0.16°, the flash's direction 0.38 / 0.73 / 0.94° → 0.30 / 0.48 / 0.86°.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np
from scipy import ndimage
from scipy.optimize import least_squares

from capture.covariance import cluster_covariance
from capture.lobe import LobeHighPass
from capture.phong import Geometry, PhongParams

if TYPE_CHECKING:
    from capture.camera import Camera

#: The largest turn the refinement may make, degrees: four of the landmarks' standard deviations at
#: their loosest (1.5°, the validation's framing with the head turned 30°). The photograph's own turn
#: reaching it means its lobe does not place the head: the landmarks' camera is kept.
MAX_TURN_DEG = 6.0
#: A pixel whose surface point lies this many pixel footprints (depth / focal length) from a neighbour's,
#: or whose normal turns by more than :data:`CREASE_DEG` from it, borders another surface (the nose over
#: the cheek, the lips' line): reading geometry between the two would blend them. On one continuous
#: surface neighbours are a footprint apart, and 10 only at 84° from the view (skin is fitted to 87°).
JUMP_FOOTPRINTS = 10.0
#: See :data:`JUMP_FOOTPRINTS`: the nose's ridge (radius ~5 mm) turns its normal by ~6° per pixel at the
#: bench's framing (0.5 mm per pixel); folds where the surface changes, by tens of degrees.
CREASE_DEG = 30.0
#: Skin pixels within this many pixels of such a border are left out of the refinement's fit: a turn
#: of the landmarks' error (≤ 1.5°) moves a point 50 mm from the pivot by ≤ 2.6 px at the bench's
#: framing, so their reads could cross it.
BORDER_PX = 3
#: The photograph's turn's squared error over its cluster-robust variance, averaged (the module docstring):
#: measured 3.0² and 2.8² about x and y on 48 development scenes (none a validation's); 4–16 gave the
#: same errors there to ±0.05° at the median.
MODEL_BIAS_VARIANCE = 8.5
#: Points that pin both angles to this (degrees, one standard deviation) leave nothing to refine: the
#: lobe alone places them to 0.2–0.7° at best (measured with the true camera), so it could not move the
#: estimate by a tenth of that. The automatic capture's own mesh fits its landmarks to ~0.01 px.
PINNED_DEG = 0.02


class TurnMeasurement(Protocol):
    """Another measurement of the camera's turn (:class:`capture.contour.ContourTurn`).

    Attributes:
        turn_deg: (2,) the turn about the camera's x and y axes it asks for (degrees).
        covariance_deg2: (2, 2) its covariance (degrees²).
        alias: (2, 7) the turn it reads per unit of each landmark calibration parameter (rotation in
            degrees, translation, log f; :attr:`Camera.parameter_covariance`'s order), or None.
    """

    turn_deg: np.ndarray
    covariance_deg2: np.ndarray
    alias: np.ndarray | None


def pinned(camera: Camera) -> bool:
    """Whether ``camera``'s points pin its rotation (a covariance with both σ below :data:`PINNED_DEG`).

    The automatic capture's head, built from the photograph's own landmarks, registers to it to ~0.01 px.
    """
    cov = camera.rotation_covariance_deg2
    return cov is not None and float(np.sqrt(np.asarray(cov, dtype=float).diagonal()).max()) < PINNED_DEG


def image_similarity_covariance(camera: Camera, depth: float) -> np.ndarray | None:
    """How uncertain the landmarks leave the head's image scale (per cent) and roll (degrees): (2, 2).

    From the calibration's covariance (:attr:`Camera.parameter_covariance`: rotation vector, translation,
    log f): the scale of the image at the head is f / Z, so its log moves by δlog f − δt_z / Z (``depth``:
    Z, the head's distance along the optical axis, mesh units), and the roll is the rotation about the
    optical axis. The prior of :func:`capture.lobe.specular_from_detail`'s ``similarity_prior``; None for
    a camera given directly (no covariance).
    """
    cov = camera.parameter_covariance
    if cov is None:
        return None
    gain = np.zeros((2, 7))
    gain[0, 5], gain[0, 6] = -100.0 / float(depth), 100.0
    gain[1, 2] = np.degrees(1.0)
    return np.asarray(gain @ np.asarray(cov, dtype=float) @ gain.T)


@dataclass
class Surface:
    """The head's surface as a camera's rasterisation saw it, readable between pixel centres.

    Attributes:
        normals: (3, h, w) unit normals (mesh coordinates) over the covered pixels' bounding box, 0 elsewhere.
        positions: (3, h, w) surface points (mesh units), 0 elsewhere.
        covered: (h, w) 1.0 where a pixel is covered, else 0.0.
        row0, col0: the box's first row and column in the photograph.
    """

    normals: np.ndarray
    positions: np.ndarray
    covered: np.ndarray
    row0: int
    col0: int

    @classmethod
    def from_pixels(cls, rows: np.ndarray, cols: np.ndarray, normals: np.ndarray, positions: np.ndarray) -> Surface:
        """From the covered pixels (rows, cols: (N,) indices) and their normals and points ((N, 3))."""
        r0, c0 = int(rows.min()), int(cols.min())
        shape = (int(rows.max()) - r0 + 1, int(cols.max()) - c0 + 1)
        nrm = np.zeros((3, *shape))
        pos = np.zeros((3, *shape))
        cov = np.zeros(shape)
        nrm[:, rows - r0, cols - c0] = np.asarray(normals, dtype=float).T
        pos[:, rows - r0, cols - c0] = np.asarray(positions, dtype=float).T
        cov[rows - r0, cols - c0] = 1.0
        return cls(normals=nrm, positions=pos, covered=cov, row0=r0, col0=c0)

    def continuous(self, rows: np.ndarray, cols: np.ndarray, camera: Camera, reach_px: int = BORDER_PX) -> np.ndarray:
        """Bool (P,): the pixels (rows, cols) farther than ``reach_px`` from a border of the surface.

        A border: an uncovered pixel (or the box's edge), or a neighbour whose point lies
        :data:`JUMP_FOOTPRINTS` pixel footprints away (the depth in ``camera`` over its focal length) or
        whose normal turns by more than :data:`CREASE_DEG`.
        """
        cov = self.covered > 0
        border = ~cov
        border[[0, -1], :] = True
        border[:, [0, -1]] = True
        pos, nrm = self.positions, self.normals
        depth = camera.to_camera(pos.reshape(3, -1).T)[:, 2].reshape(cov.shape)
        footprint = np.abs(depth) / float(camera.K[0, 0])
        cos_crease = np.cos(np.radians(CREASE_DEG))
        for here, there in (((slice(None), slice(1, None)), (slice(None), slice(None, -1))),
                            ((slice(1, None), slice(None)), (slice(None, -1), slice(None)))):
            gap = np.linalg.norm(pos[(slice(None), *here)] - pos[(slice(None), *there)], axis=0)
            fold = np.einsum("c...,c...->...", nrm[(slice(None), *here)], nrm[(slice(None), *there)]) < cos_crease
            jump = cov[here] & cov[there] & ((gap > JUMP_FOOTPRINTS * footprint[here]) | fold)
            border[here] |= jump
            border[there] |= jump
        near = ndimage.binary_dilation(border, structure=np.ones((2 * reach_px + 1,) * 2, dtype=bool))
        return ~near[rows - self.row0, cols - self.col0]

    def sample(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(unit normals (P, 3), points (P, 3)) at image positions x, y ((P,) pixels; pixel j covers [j, j + 1)).

        Bilinear over the covered pixels only (a normalised interpolation: uncovered neighbours carry no
        weight); a position with no covered neighbour reads (0, 0, 0) for both.
        """
        coords = np.stack([np.asarray(y, dtype=float) - 0.5 - self.row0, np.asarray(x, dtype=float) - 0.5 - self.col0])
        weight = ndimage.map_coordinates(self.covered, coords, order=1, mode="constant")
        safe = np.maximum(weight, 1e-9)
        nrm = np.stack([ndimage.map_coordinates(c, coords, order=1, mode="constant") for c in self.normals], axis=1)
        pos = np.stack([ndimage.map_coordinates(c, coords, order=1, mode="constant") for c in self.positions],
                       axis=1) / safe[:, None]
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)
        return nrm, pos


def _fuse(photo_deg: np.ndarray, info_photo: np.ndarray, prior_cov: np.ndarray, offset: np.ndarray,
          calibration_cov: np.ndarray | None, contour: TurnMeasurement | None) -> tuple[np.ndarray, np.ndarray]:
    """The turn (2,) and its covariance (2, 2) (degrees, the frame of the camera refined) from the measurements.

    The photograph's turn ``photo_deg`` (information ``info_photo``) and the landmarks' N(−``offset``,
    ``prior_cov``) as two Gaussians; a contour measurement as a third. When the contour says how the
    calibration's other parameters read as a turn (``alias``) and the calibration's whole covariance is
    known (``calibration_cov``: 7 × 7, radians, mesh units, log f), the fusion is over all seven: the
    contour measures alias · δ, the lobe δ's rotation about x and y, the landmarks δ ~ N(μ, Σ₇); the turn
    is the posterior's rotation about x and y (the rest is left to the landmarks).
    """
    if contour is None or contour.alias is None or calibration_cov is None:
        info_prior = np.linalg.inv(prior_cov)
        info_contour = np.zeros((2, 2)) if contour is None else np.linalg.inv(contour.covariance_deg2)
        seen = np.zeros(2) if contour is None else info_contour @ contour.turn_deg
        post = np.linalg.inv(info_photo + info_prior + info_contour)
        return post @ (info_photo @ photo_deg - info_prior @ offset + seen), post
    units = np.diag([*(np.degrees(1.0),) * 3, 1.0, 1.0, 1.0, 1.0])
    info = np.linalg.inv(units @ np.asarray(calibration_cov, dtype=float) @ units.T)
    prior_mean = np.zeros(7)
    prior_mean[:2] = -offset
    pick = np.eye(7)[:2]
    info_contour = np.linalg.inv(contour.covariance_deg2)
    alias = np.asarray(contour.alias, dtype=float)
    total = info + pick.T @ info_photo @ pick + alias.T @ info_contour @ alias
    post = np.linalg.inv(total)
    mean = post @ (info @ prior_mean + pick.T @ info_photo @ photo_deg + alias.T @ info_contour @ contour.turn_deg)
    return mean[:2], post[:2, :2]


@dataclass
class PoseRefinement:
    """What :func:`refine_rotation` found.

    Attributes:
        camera: the refined camera. turn_deg: (2,) its turn from the calibrated camera about the camera's x
            and y axes (degrees).
        photometric_deg: (2,) the turn the photograph alone prefers (degrees).
        photometric_sigma_deg: (2,) its standard deviation (degrees; the cluster-robust covariance times
            :data:`MODEL_BIAS_VARIANCE`).
        sigma_deg: (2,) the posterior standard deviation of the turn (degrees).
        exponent: s of the photograph's own fit (dimensionless). evaluations: lobe fits run.
        contour_deg: (2,) the turn the occluding contour alone asks for (degrees; :mod:`capture.contour`),
            or None without that cue. contour_sigma_deg: (2,) its standard deviation (degrees), or None.
    """

    camera: Camera
    turn_deg: np.ndarray
    photometric_deg: np.ndarray
    photometric_sigma_deg: np.ndarray
    sigma_deg: np.ndarray
    exponent: float
    evaluations: int
    contour_deg: np.ndarray | None = None
    contour_sigma_deg: np.ndarray | None = None


def refine_rotation(photo_lin: np.ndarray, surface: Surface, camera: Camera, light_camera: np.ndarray,
                    params: PhongParams, rows: np.ndarray, cols: np.ndarray, pivot: np.ndarray | None = None,
                    turned_deg: np.ndarray | None = None, contour: TurnMeasurement | None = None) -> PoseRefinement | None:
    """Refine ``camera``'s rotation on the specular lobe (see the module docstring).

    Args:
        photo_lin: (H, W, 3) the photograph, linear RGB.
        surface: the head as ``camera``'s rasterisation saw it (every covered pixel).
        camera: the calibrated camera; its ``rotation_covariance_deg2`` is the landmarks' uncertainty.
        light_camera: (3,) unit direction towards the flash in camera coordinates (the probe's).
        params: the first fit (D, k, A, F; its s starts the search).
        rows: (P,) the skin pixels' rows (those the lobe is fitted on).
        cols: (P,) their columns.
        pivot: (3,) the point turned about (mesh units); None: the skin pixels' surface points' centroid.
        turned_deg: (2,) how far ``camera`` is already turned from the calibrated one about ``pivot``
            (degrees; the prior stays centred on the calibration). None: not at all.
        contour: the turn of ``camera`` about ``pivot`` the photograph's occluding contour asks for
            (:func:`capture.contour.contour_turn`), fused as a third Gaussian measurement; None: without it.

    Returns None when there is nothing to refine against (a camera given directly, no covariance), no
    lobe on the skin, or a lobe that does not place the head (its own turn at :data:`MAX_TURN_DEG`).
    """
    if camera.rotation_covariance_deg2 is None or pinned(camera):
        return None
    cov = np.asarray(camera.rotation_covariance_deg2, dtype=float)
    keep = surface.continuous(rows, cols, camera)
    if keep.sum() < 200:
        return None
    rows, cols = rows[keep], cols[keep]
    centre_x, centre_y = cols + 0.5, rows + 0.5
    normals, positions = surface.sample(centre_x, centre_y)
    pivot = positions.mean(axis=0) if pivot is None else np.asarray(pivot, dtype=float)
    offset = np.zeros(2) if turned_deg is None else np.asarray(turned_deg, dtype=float)
    light_camera = np.asarray(light_camera, dtype=float)
    seen, _ = camera.project(positions)
    photo = photo_lin[rows, cols]
    evaluations = 0
    # The lobe fits of the last few turns: the least squares' finite difference in log s asks again for the
    # turn it last evaluated (a fit depends on the turn alone; the exponent is the residual's argument).
    fitted: dict[bytes, LobeHighPass] = {}

    def lobe_fit(theta: np.ndarray) -> LobeHighPass:
        nonlocal evaluations
        evaluations += 1
        key = np.asarray(theta[:2], dtype=float).tobytes()
        if key not in fitted:
            fitted[key] = _lobe_fit(theta)
            while len(fitted) > 4:
                del fitted[next(iter(fitted))]
        return fitted[key]

    def _lobe_fit(theta: np.ndarray) -> LobeHighPass:
        cam = camera.turned(np.radians([theta[0], theta[1], 0.0]), pivot)
        if theta[0] == 0.0 and theta[1] == 0.0:
            nrm, pos = normals, positions
        else:
            # The point the turned camera sees at a pixel is the one the first camera saw where the turn
            # moved it from (to first order in the turn: the move is smooth across the image).
            moved, _ = cam.project(positions)
            nrm, pos = surface.sample(centre_x - (moved[:, 0] - seen[:, 0]), centre_y - (moved[:, 1] - seen[:, 1]))
        view = cam.centre[None, :] - pos
        view /= np.linalg.norm(view, axis=1, keepdims=True)
        return LobeHighPass(photo, Geometry.from_vectors(nrm, view, cam.R.T @ light_camera), params, rows, cols)

    start = lobe_fit(np.zeros(2))
    if not start.ok.any() or not np.all(np.isfinite(start.residual(float(params.exponent))[0])):
        return None

    def photometric(theta: np.ndarray) -> np.ndarray:
        res, _ = lobe_fit(theta).residual(float(np.exp(theta[2])))
        return np.where(np.isfinite(res), res, 0.0).ravel()

    bound = np.array([MAX_TURN_DEG, MAX_TURN_DEG, np.inf])
    x0 = np.array([0.0, 0.0, np.log(params.exponent)])
    fit = least_squares(photometric, x0, bounds=(-bound, bound), x_scale=np.array([0.5, 0.5, 0.1]),
                        diff_step=np.array([1e-2, 1e-2, 1e-3]), xtol=1e-3, ftol=1e-6)
    if np.any(np.abs(fit.x[:2]) >= MAX_TURN_DEG - 1e-3):
        return None
    try:
        photo_cov = MODEL_BIAS_VARIANCE * cluster_covariance(fit.jac, fit.fun, rows, cols)[:2, :2]
        info_photo = np.linalg.inv(photo_cov)
        turn, post_cov = _fuse(fit.x[:2], info_photo, cov, offset, camera.parameter_covariance, contour)
    except np.linalg.LinAlgError:
        return None
    photo_only = fit.x[:2]
    return PoseRefinement(camera=camera.turned(np.radians([turn[0], turn[1], 0.0]), pivot), turn_deg=turn + offset,
                          photometric_deg=photo_only + offset, photometric_sigma_deg=np.sqrt(np.diag(photo_cov)),
                          sigma_deg=np.sqrt(np.diag(post_cov)), exponent=float(np.exp(fit.x[2])),
                          evaluations=evaluations,
                          contour_deg=None if contour is None else contour.turn_deg + offset,
                          contour_sigma_deg=None if contour is None else np.sqrt(np.diag(contour.covariance_deg2)))
