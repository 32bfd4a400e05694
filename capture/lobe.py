"""The specular lobe read from the photograph's fine structure: exponent s, intensity i_s, registration.

The Phong model itself and its joint fit are :mod:`capture.phong`; this module reads the specular part
(issue 14) from the photograph high-passed at a scale set by the sensor's pixel.

The exponent s and the specular intensity i_s: the paper reads s from the saturation around the
highlight and fits i_s jointly with D; both read albedo that varies under the lobe as part of it. Out of
sample (tests/capture/test_out_of_sample.py: photographs drawn on the GPU by another renderer) that put s
at 6.89 for 8 (−13.8 %), 28.46 for 24 with the flash 10° above the lens (+18.6 %) and 17.99 for 16 on the
1,143-triangle head (+12.4 %, i_s +15.5 %), all three exact on an untextured skin — and the scales that
limited it (a soft-L1 scale, a lobe support, a 3.5 mm high-pass) had been chosen on the validation's
scene. :func:`specular_from_detail` fits s and i_s on the photograph high-passed at
``LOBE_HIGH_PASS_PX`` (a scale set by the sensor's pixel, not by a scene); D is refitted with both fixed.
Out of sample s is then within 8 % on the sample head, the canonical face and the coarse head with the
flash above, beside, below and off-axis and s from 8 to 60 (from the true camera; with landmarks clicked
with 1 px of noise up to −10.6 %), i_s within 6.3 % (−10.6 % with the noisy landmarks and s 60). On the
validation's own CPU photograph, which samples each pixel's centre where the fit models a pixel's
integration, s comes out 5.7–6.0 % high. A camera calibrated from landmarks misregisters the head by a
fraction of a pixel, which the 2 px high-pass sees: the fit also registers the lobe (the geometry
shifted across the photograph; ``vectors`` of :func:`specular_from_detail`), so s and i_s no longer
pay for where the camera put the head's image. A camera calibrated from landmarks is also a fraction off
in distance, focal length and roll, which scales and rolls the head's image about the lobe (±0.2–0.4 px
across a narrow lobe): with ``similarity_prior`` (:func:`capture.pose.image_similarity_covariance`) the
registration scales and rolls the geometry too, within the calibration's uncertainty. i_s is read from
the lobe integrated over each pixel's square (:mod:`capture.pixel_lobe`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import ndimage
from scipy.optimize import least_squares, minimize_scalar
from scipy.spatial.transform import Rotation

from capture.covariance import cluster_covariance
from capture.phong import Geometry, PhongParams
from capture.pixel_lobe import integrated_lobe
from capture.reflectance import MAX_EXPONENT

#: The high-pass scale of :func:`specular_from_detail`, photograph pixels. The narrowest Gaussian whose
#: variance (4 px²) is 50 times a pixel's own (a photograph integrates over its pixel, a box of variance
#: 1/12 px²; the model samples the pixel's centre and is corrected for the box to second order): the
#: filter then sees what the sensor saw, and every albedo variation broader than it — on the skin, all
#: but the pores — drops out of the fit. Measured on the GPU-drawn photographs of
#: tests/capture/test_out_of_sample.py, the exponent moves as σ narrows the way the texture bias says
#: it should (s 8: 7.07 at 3 px, 7.43 at 2, 8.01 at 1) while the 1,143-triangle head's interpolated
#: normals leave the fit below 1.5 px (16 → 20.2 at 1 px).
LOBE_HIGH_PASS_PX = 2.0

#: How far :func:`specular_from_detail` may move the head's geometry across the photograph when it fits
#: the lobe's registration, pixels: the high-pass scale. A camera calibrated from landmarks misregisters
#: the head by a fraction of a pixel (with 1 px of noise on 22 landmarks: 0.1–0.4 px at the mean and
#: 0.2–0.7 px RMS over the skin, measured on GPU-drawn photographs), and a 2 px high-pass sees that: the
#: lobe's fine structure, which follows the head's normals, no longer lies on the photograph's. Past σ
#: the high-passed lobe no longer overlaps its own image, so the fit could not tell a shift from another
#: lobe.
LOBE_MAX_SHIFT_PX = LOBE_HIGH_PASS_PX
#: How far it may turn the head's normals to move the lobe (``fit_turn``; about two axes across the line of
#: sight), degrees: twice the landmarks' rotation uncertainty at its loosest (σ 1.5°, :func:`capture.camera.
#: pose_covariance` at the validation's framing with the head turned 30°). The lobe itself places the
#: turn to ~0.5° (:mod:`capture.pose`).
LOBE_MAX_TURN_DEG = 3.0
#: The lobe's own scale and roll (:func:`specular_from_detail`'s ``similarity_prior``): their squared
#: error over the cluster-robust variance, averaged — measured 5.9 (scale) and 3.1 (roll) on 16
#: development scenes of our own (s 10–50, the head turned −35° to +20°, four flash placements none a
#: validation's, their own landmark noise and sensor), against the misregistration the true camera gives.
#: The sandwich sees the residual's correlation, not the lobe model's bias (the texture under the lobe,
#: D's error); :mod:`capture.pose` measured the same for its turn (``MODEL_BIAS_VARIANCE``, 8.5).
SIMILARITY_BIAS_VARIANCE = 4.5


@dataclass
class DetailSpecular:
    """The specular lobe separated from the skin's albedo variation (:func:`specular_from_detail`).

    Attributes:
        specular: i_s (photograph units, like :attr:`PhongParams.specular`).
        exponent: s (dimensionless; the given one when the exponent was not fitted).
        sigma_px: the high-pass scale used (pixels). core_radius_px: the specular core's equivalent
        radius (pixels, at the exponent found). pixels: the skin pixels used.
        shift_px: (2,) how far the geometry was moved across the photograph to fit the lobe (x right,
        y down, pixels; zero when not fitted). turn_deg: (2,) the normals' turn about the two axes across
        the line of sight that moved the lobe (degrees; zero when not fitted). similarity: (2,) the
        image's scale (per cent) and roll (degrees) about the lobe that registered it (zero when not fitted).
    """

    specular: float
    exponent: float
    sigma_px: float
    core_radius_px: float
    pixels: int
    shift_px: np.ndarray = field(default_factory=lambda: np.zeros(2))
    turn_deg: np.ndarray = field(default_factory=lambda: np.zeros(2))
    similarity: np.ndarray = field(default_factory=lambda: np.zeros(2))


def _pixel_box_lobe(lobe: np.ndarray, rows: np.ndarray, cols: np.ndarray, shape: tuple[int, int],
                    interior: np.ndarray) -> np.ndarray:
    """The lobe averaged over each pixel's square, to second order: S + ∇²S / 24.

    ∇² is the 5-point Laplacian on the pixel grid (a unit box has variance 1/12 per axis). Only at
    ``interior`` pixels (all four neighbours on the skin); the others keep their centre value.
    """
    img = np.zeros(shape)
    img[rows, cols] = lobe
    lap = ndimage.laplace(img)[rows, cols]
    return np.where(interior, lobe + lap / 24.0, lobe)


def _bspline_weights(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cubic B-spline's weights of the coefficients at offsets −1..2 from floor(x), and their derivatives.

    ``t``: (P,) x − floor(x) in [0, 1). Returns two (4, P) arrays.
    """
    t2 = t * t
    w = np.stack([(1 - t) ** 3, 3 * t2 * t - 6 * t2 + 4, -3 * t2 * t + 3 * t2 + 3 * t + 1, t2 * t]) / 6.0
    dw = np.stack([-(1 - t) ** 2, 3 * t2 - 4 * t, -3 * t2 + 2 * t + 1, t2]) / 2.0
    return w, dw


def _spline_gradient(coefficients: np.ndarray, shape: tuple[int, int], coords: np.ndarray) -> np.ndarray:
    """The gradient of cubic splines at ``coords`` (2, P) (row, col; pixels), (P, C, 2): d/d row, d/d col.

    ``coefficients``: (H·W, C) the splines' coefficients (``ndimage.spline_filter``'s) of an image of
    ``shape`` (H, W). The derivative of ``ndimage.map_coordinates(order=3, prefilter=False)``'s interpolant;
    scipy has no derivative of its own, and one order-2 read of the coefficients' differences is the
    derivative only along one axis (across the other the spline stays cubic). Points within two pixels of
    the image's edge read the edge's coefficients.
    """
    h, w = shape
    floor = np.floor(coords)
    (wr, dwr), (wc, dwc) = _bspline_weights(coords[0] - floor[0]), _bspline_weights(coords[1] - floor[1])
    r0 = np.clip(floor[0].astype(np.intp) - 1, 0, h - 4)
    c0 = np.clip(floor[1].astype(np.intp) - 1, 0, w - 4)
    # Overlapping windows of four coefficients along a row, so each of the four rows is one gather.
    windows = np.lib.stride_tricks.as_strided(coefficients, shape=(len(coefficients) - 3, 4, coefficients.shape[1]),
                                              strides=(coefficients.strides[0],) + coefficients.strides, writeable=False)
    across = np.stack([wc.T, dwc.T], axis=2)  # (P, 4, 2)
    out = np.zeros((coords.shape[1], coefficients.shape[1], 2))
    for i in range(4):
        rows = np.matmul(windows[(r0 + i) * w + c0].transpose(0, 2, 1), across)  # (P, C, 2): value, d/d col
        out[:, :, 0] += dwr[i][:, None] * rows[:, :, 0]
        out[:, :, 1] += wr[i][:, None] * rows[:, :, 1]
    return out


class LobeHighPass:
    """The specular lobe's fit on the high-passed photograph (:func:`specular_from_detail`'s cost).

    Built once per geometry (the skin pixels' ``geo`` for the flash, ``params``' D, k, A, F): per pixel
    the ratio r = photo / D·L (D·L the fitted diffuse shading) and its high-pass HP(r) at σ = ``sigma_px``
    pixels (x minus its normalised Gaussian average over the unclipped lit skin pixels ``ok``); for an
    exponent s, :meth:`residual` gives the weighted residual HP(r) − i_s·HP(q), q = S·F / D·L with S the
    lobe averaged over the pixel (:func:`_pixel_box_lobe`), and the least-squares i_s (closed form,
    weights (D·L)², back to photograph units). ``rows``, ``cols``: the pixels' positions in the
    photograph, in the order of ``photo_rgb`` (P, 3, linear) and ``geo``.

    With ``vectors`` (the pixels' unit normals (P, 3), unit directions to the camera (P, 3) and the unit
    direction to the flash (3,), from which ``geo`` was made), :meth:`place` moves the lobe: the geometry
    read ``shift_px`` away across the photograph (normals and view directions interpolated by cubic
    splines — both are smooth, unlike the photograph, which is never resampled; bilinear reads made the
    shifted lobe smoother than the photograph, i_s +3 to +8 % on a test sphere) and the normals turned about two
    axes across the mean line of sight, as a slightly wrong camera would have them.
    """

    def __init__(self, photo_rgb: np.ndarray, geo: Geometry, params: PhongParams, rows: np.ndarray,
                 cols: np.ndarray, sigma_px: float = LOBE_HIGH_PASS_PX,
                 vectors: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> None:
        photo = np.asarray(photo_rgb, dtype=np.float64)
        self.sigma = max(0.5, float(sigma_px))
        self.params = params
        # Work on the skin's bounding box (plus the filter's reach), not the whole photograph.
        pad = int(np.ceil(4 * self.sigma)) + 1
        self.rows, self.cols = rows - rows.min() + pad, cols - cols.min() + pad
        self.shape = (int(self.rows.max()) + 1 + pad, int(self.cols.max()) + 1 + pad)
        ndl = np.clip(geo.n_dot_l, 0.0, None)
        self.rdv = np.where(geo.n_dot_l > 0, np.clip(geo.r_dot_v, 0.0, None), 0.0)
        dl = params.diffuse[None, :] * (params.ambient_scale * params.ambient_rgb[None, :]
                                        + params.flash_rgb[None, :] * ndl[:, None])
        self.ok = (photo.max(axis=1) < 0.98) & (geo.n_dot_l > 0) & (dl.min(axis=1) > 1e-6)
        self._flat = self.rows * self.shape[1] + self.cols  # the pixels' indices in the box, flattened
        on_skin = np.zeros(self.shape, dtype=bool)
        on_skin[self.rows, self.cols] = True
        self.interior = ndimage.binary_erosion(on_skin)[self.rows, self.cols]
        weight = np.zeros(self.shape)
        weight[self.rows[self.ok], self.cols[self.ok]] = 1.0
        self._wsum = np.maximum(self._blur(weight[..., None])[self.rows, self.cols, 0], 1e-12)
        self.inv_dl = np.where(self.ok[:, None], 1.0 / np.maximum(dl, 1e-6), 0.0)
        self.hr = self.high_pass(photo * self.inv_dl)
        self.sqrt_w = np.where(self.ok[:, None], dl, 0.0)
        #: (x, y) in the box's pixels: what :meth:`place` scales and rolls the image about.
        self.centre = np.array([self.cols.mean(), self.rows.mean()], dtype=float)
        self._vectors = None
        self._coefficients: np.ndarray | None = None
        self._placed: tuple[Any, ...] = ()
        #: (s, the weighted high-passed lobe, i_s, its squared norm) of the last :meth:`residual` at this
        #: placement with the centre-value lobe: what :meth:`jacobian` needs at the same point (least squares
        #: asks for the Jacobian where it last evaluated the residual). Cleared by :meth:`place`.
        self._last_lobe: tuple[float, np.ndarray, float, float] | None = None
        if vectors is not None:
            normals, view, light = (np.asarray(v, dtype=np.float64) for v in vectors)
            # Off the skin each image holds its nearest skin pixel's vector, so a shifted read at the
            # skin's edge interpolates between skin pixels only.
            _, nearest = ndimage.distance_transform_edt(~on_skin, return_indices=True)
            images = []
            for x in (normals, view):
                img = np.zeros(self.shape + (3,))
                img[self.rows, self.cols] = x
                img = img[nearest[0], nearest[1]]
                images.append(np.stack([ndimage.spline_filter(img[..., c], order=3, mode="nearest")
                                        for c in range(3)], axis=-1))
            axis = view.mean(axis=0)
            across = np.cross(axis, np.eye(3)[int(np.argmin(np.abs(axis)))])
            across /= np.linalg.norm(across)
            self._vectors = (images[0], images[1], light, np.stack([across, np.cross(axis / np.linalg.norm(axis),
                                                                                     across)]))

    def place(self, shift_px: np.ndarray, turn_deg: np.ndarray, similarity: np.ndarray = (0.0, 0.0)) -> None:
        """Move the model's lobe (needs ``vectors``; ValueError without them).

        The geometry is read ``shift_px`` (x right, y down, pixels) away across the photograph, scaled by
        ``similarity[0]`` per cent and turned by ``similarity[1]`` degrees in the image's plane about
        :attr:`centre` (a camera's distance, focal length and roll slightly off), and the normals turned
        by ``turn_deg`` (2,) degrees about the two axes across the line of sight; zeros give back the
        geometry as given.
        """
        if self._vectors is None:
            raise ValueError("LobeHighPass.place needs the geometry's vectors")
        nimg, vimg, light, axes = self._vectors
        scale, roll = 0.01 * float(similarity[0]), np.radians(float(similarity[1]))
        dx, dy = self.cols - self.centre[0], self.rows - self.centre[1]
        coords = np.array([self.rows + float(shift_px[1]) + scale * dy + roll * dx,
                           self.cols + float(shift_px[0]) + scale * dx - roll * dy])

        def read(img: np.ndarray) -> np.ndarray:
            return np.stack([ndimage.map_coordinates(img[..., c], coords, order=3, mode="nearest", prefilter=False)
                             for c in range(3)], axis=1)

        raw_n, raw_v = read(nimg), read(vimg)
        rotation = Rotation.from_rotvec(np.radians(np.asarray(turn_deg, dtype=float)) @ axes)
        normals = rotation.apply(raw_n / np.linalg.norm(raw_n, axis=1, keepdims=True))
        view = raw_v / np.linalg.norm(raw_v, axis=1, keepdims=True)
        geo = Geometry.from_vectors(normals, view, light)
        self.rdv = np.where(geo.n_dot_l > 0, np.clip(geo.r_dot_v, 0.0, None), 0.0)
        self._placed = (coords, raw_n, raw_v, rotation, normals, view, geo)
        self._last_lobe = None

    def jacobian(self, s: float) -> np.ndarray:
        """The Jacobian of :meth:`residual`'s residual (raveled, 3P) in shift x, y (pixels), scale (%), roll (°), log s.

        (3P, 5), at the placement of the last :meth:`place` (needs ``vectors``) and the exponent s, i_s in
        closed form as in :meth:`residual`: the chain rule through the geometry's cubic splines
        (:func:`_spline_gradient`), the normalisation, r·v, the lobe, the pixel's box and the high-pass —
        the function :meth:`residual` evaluates, differentiated exactly; finite differences re-read the
        six spline images once per parameter (measured against central differences: 3e-8 relative).
        """
        if self._vectors is None or not self._placed:
            raise ValueError("LobeHighPass.jacobian needs the geometry's vectors and a place first")
        coords, raw_n, raw_v, rotation, normals, view, geo = self._placed
        if self._coefficients is None:  # both splines' coefficients, (H·W, 6)
            self._coefficients = np.concatenate(self._vectors[:2], axis=-1).reshape(-1, 6)
        grads = _spline_gradient(self._coefficients, self.shape, coords)

        light = self._vectors[2]
        ndl, ndv = geo.n_dot_l, np.einsum("pc,pc->p", normals, view)
        inv_n, inv_v = 1.0 / np.linalg.norm(raw_n, axis=1), 1.0 / np.linalg.norm(raw_v, axis=1)
        d_rdv_image = np.empty((len(self.rows), 2))  # d r·v / d (row, col)
        for a in (0, 1):
            gn, gv = grads[:, 0:3, a], grads[:, 3:6, a]
            dn = rotation.apply((gn - (raw_n * inv_n[:, None]) * np.einsum("pc,pc->p", raw_n, gn)[:, None]
                                 * inv_n[:, None]) * inv_n[:, None])
            dv = (gv - view * np.einsum("pc,pc->p", view, gv)[:, None]) * inv_v[:, None]
            d_rdv_image[:, a] = 2.0 * ((dn @ light) * ndv + ndl * (np.einsum("pc,pc->p", dn, view)
                                                                  + np.einsum("pc,pc->p", normals, dv))) - dv @ light
        dy, dx = self.rows - self.centre[1], self.cols - self.centre[0]
        # d (row, col) / d parameter: shift x, shift y, scale (%), roll (degrees)
        d_rdv = np.stack([d_rdv_image[:, 1], d_rdv_image[:, 0],
                          0.01 * (d_rdv_image[:, 0] * dy + d_rdv_image[:, 1] * dx),
                          np.radians(1.0) * (d_rdv_image[:, 0] * dx - d_rdv_image[:, 1] * dy)], axis=1)
        lit = self.rdv > 0
        base = np.where(lit, self.rdv, 1.0)
        dlobe = np.concatenate([np.where(lit, s * base ** (s - 1.0), 0.0)[:, None] * d_rdv,
                                np.where(lit, s * np.log(base) * base ** s, 0.0)[:, None]], axis=1)
        if self._last_lobe is None or self._last_lobe[0] != s:
            self.residual(s)
        assert self._last_lobe is not None
        _, a, i_s, den = self._last_lobe
        if den <= 0:
            return np.zeros((a.size, 5))
        flash = self.params.flash_rgb[None, :] * self.inv_dl
        b = self.sqrt_w * self.hr
        boxed = np.stack([_pixel_box_lobe(dlobe[:, k], self.rows, self.cols, self.shape, self.interior)
                          for k in range(5)], axis=1)
        da = self.sqrt_w[:, None, :] * self.high_pass((boxed[:, :, None] * flash[:, None, :]).reshape(-1, 15)
                                                      ).reshape(-1, 5, 3)
        di = (np.einsum("pkc,pc->k", da, b) - 2.0 * i_s * np.einsum("pkc,pc->k", da, a)) / den
        return -(di[None, :, None] * a[:, None, :] + i_s * da).transpose(0, 2, 1).reshape(-1, 5)

    def high_pass(self, x: np.ndarray) -> np.ndarray:
        """X (P, C) minus its normalised Gaussian average (σ = :attr:`sigma` px) over the ``ok`` pixels."""
        img = np.zeros((self.shape[0] * self.shape[1], x.shape[1]))
        img[self._flat[self.ok]] = x[self.ok]
        blurred = self._blur(img.reshape(self.shape + (x.shape[1],))).reshape(img.shape)
        return x - blurred[self._flat] / self._wsum[:, None]

    def _blur(self, img: np.ndarray) -> np.ndarray:
        """``img`` (H, W, C) filtered by the Gaussian of σ = :attr:`sigma` px across its rows and columns.

        ``scipy.ndimage.gaussian_filter``'s own kernel (4 σ each side, normalised) and edge ('reflect'),
        through OpenCV's separable filter: the same sums to the last bit of a double (~1e-16), 2.5–4
        times faster (scipy's loop is not vectorised; this filter is most of the fit's time).
        """
        import cv2  # OpenCV is a dependency (pyproject.toml); imported where used, as in app/

        radius = int(4.0 * self.sigma + 0.5)
        kernel = np.exp(-0.5 * (np.arange(-radius, radius + 1) / self.sigma) ** 2)
        kernel /= kernel.sum()
        out = cv2.sepFilter2D(np.ascontiguousarray(img), cv2.CV_64F, kernel, kernel, borderType=cv2.BORDER_REFLECT)
        return out.reshape(img.shape)

    def residual(self, s: float, lobe: np.ndarray | None = None) -> tuple[np.ndarray, float]:
        """(the weighted residual (P, 3), photograph units; the least-squares i_s) for the exponent s.

        ``lobe``: (P,) the lobe already integrated over each pixel (:func:`capture.pixel_lobe.integrated_lobe`);
        None: its centre value to second order (:func:`_pixel_box_lobe`).
        """
        centre = lobe is None
        if lobe is None:
            lobe = _pixel_box_lobe(self.rdv ** s, self.rows, self.cols, self.shape, self.interior)
        hq = self.high_pass(lobe[:, None] * self.params.flash_rgb[None, :] * self.inv_dl)
        whq = self.sqrt_w * hq
        den = float((whq * whq).sum())
        i_s = float((whq * self.sqrt_w * self.hr).sum()) / den if den > 0 else 0.0
        if centre:
            self._last_lobe = (s, whq, i_s, den)
        if den <= 0:
            return np.full_like(hq, np.inf), 0.0
        return self.sqrt_w * (self.hr - i_s * hq), i_s

    def solve(self, s: float) -> tuple[float, float]:
        """(the weighted residual's sum of squares, the least-squares i_s) for the exponent s."""
        res, i_s = self.residual(s)
        return float((res * res).sum()), i_s


def specular_from_detail(photo_rgb: np.ndarray, geo: Geometry, params: PhongParams, rows: np.ndarray,
                         cols: np.ndarray, shape: tuple[int, int], fit_exponent: bool = True,
                         sigma_px: float = LOBE_HIGH_PASS_PX,
                         vectors: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                         fit_turn: bool = False, similarity_prior: np.ndarray | None = None) -> DetailSpecular | None:
    """The specular lobe (i_s, and s with ``fit_exponent``) fitted on the high-passed photograph.

    A departure from the paper, which reads s from the saturation around the highlight and fits i_s
    jointly with D. ``rows``, ``cols``: the skin pixels' positions in the photograph of ``shape`` (H, W),
    in the order of ``photo_rgb`` (P, 3, linear) and ``geo``; ``params``: a first fit (its D, k, A, F are
    used, and its s when the exponent is not fitted).

    Why: both read albedo that varies where the lobe falls as part of the lobe. The skin's texture —
    darker and redder towards the face's edges, blotches, a brighter nose — has variation at every
    scale, and wherever the lobe falls (it moves with the flash, the exponent and the head) some of it
    correlates with the lobe: on GPU-drawn photographs the paper's estimates missed s by −14 to +19 %
    and i_s by up to +22 %, and were exact on an untextured skin. Knowing the texture to 3 mm would
    suffice (measured with the drawn texture given to the fit: s 8 → 7.82, 24 → 24.15); it cannot be
    read under the lobe from one photograph (where the flash is reflected the skin's own colour is
    unknown, and the skin's redness varies along the same direction in colour as the flash's
    desaturation — per pixel the two are 100:1 ill-conditioned).

    How: per pixel, with D·L = D ⊙ (k·A + F·max(n·l, 0)) the fitted diffuse shading, the photograph is
    ``D·L ⊙ m + i_s·S·F`` with m the albedo's detail and S = max(r·v, 0)^s the lobe averaged over the
    pixel (:func:`_pixel_box_lobe`). Dividing by D·L and high-passing at σ = ``sigma_px`` removes m's
    variation broader than σ (HP(x) = x minus its normalised Gaussian average over the unclipped lit
    skin pixels): HP(r) = i_s·HP(q) + noise, r = photo / D·L, q = S·F / D·L. The lobe's curvature at the
    scale of a few pixels — shaped by the head's normals, which no albedo follows — stays. For each s
    the least-squares i_s is closed-form (weights w = (D·L)², back to photograph units); s minimises
    the residual over log s ∈ [0, ln ``MAX_EXPONENT``]: a 48-point grid, then a bounded Brent search
    around the best point (the cost can have more than one dip: the grid is what keeps it global).

    Where the lobe lies: with ``vectors`` (the pixels' unit normals (P, 3), unit directions to the camera
    (P, 3) and the unit direction to the flash (3,) that made ``geo``) the lobe's registration is fitted
    with s: the geometry read up to :data:`LOBE_MAX_SHIFT_PX` away across the photograph
    (:meth:`LobeHighPass.place`), least squares from the grid's s, so s and i_s no longer pay for where
    the camera put the head's image. A camera calibrated from landmarks misregisters the head by 0.1–0.7 px;
    at 2 px the lobe's fine structure (the head's normals) then misses the photograph's, and a lobe
    fitted where the camera put it comes out low in i_s (the overlap lost) and in s (a broader lobe
    overlaps more). The shift found matches the true misregistration at the lobe to ~0.1 px (measured
    on GPU-drawn photographs). Measured on 16 GPU-drawn photographs of our own (s 10, 16, 32, 50, the
    head turned −20° or +10°, the flash (6°, 3°) or (−3°, 7°) from the lens, shadows and the sensor's
    noise, landmarks with 1 px of noise; the estimator alone on the same inputs): s median 3.0 → 2.9 %,
    worst 7.0 → 4.7 %; i_s median 6.8 → 5.4 %, worst 15.7 → 13.2 %. From the true camera the shift
    found is ≤ 0.05 px and s, i_s move by ≤ 1 point.

    ``fit_turn`` also turns the normals (up to :data:`LOBE_MAX_TURN_DEG` about two axes across the line
    of sight), moving the lobe as a flash or a rotation a fraction of a degree off would. Off by default:
    the rotation is :mod:`capture.pose`'s to refine, weighed against the landmarks' own uncertainty, and
    unweighed here the skin's texture pulls it — on the 1,143-triangle head, from the true camera, it
    turned 0.96° and s went +1.3 → −6.0 % (shift alone −2.7 %); on the 16 scenes above it gained
    0.5 points of s median and i_s worst.

    ``similarity_prior`` (with ``vectors``): the camera's uncertainty in the image's scale (per cent) and
    roll (degrees) as a (2, 2) covariance (:func:`capture.pose.image_similarity_covariance`, from the
    landmarks). A camera's distance, focal length and roll a fraction off (0.2–0.4 %, 0.1–0.2° with 1 px
    of noise on 22 landmarks) scale and turn the head's image about any point, so the misregistration
    varies across a lobe: on a narrow lobe 60 px across by ±0.2–0.4 px, which one shift cannot follow (on
    16 development scenes a similarity — shift, scale, roll — left 0.01–0.2 px of the true
    misregistration over the lobe; a turn's parallax over the nose's depth, 0.03–0.38 px, no better than a
    shift alone). The fit then also scales and rolls the geometry about the lobe's centre: least squares
    without the prior gives the lobe's own (scale, roll) and its cluster-robust covariance
    (:func:`cluster_covariance` times :data:`SIMILARITY_BIAS_VARIANCE`), fused with the prior as two
    Gaussian measurements; shift and s follow to first order. On those 16 scenes (the estimator alone, the
    same inputs, a prior of σ 0.3 % and 0.15°): s worst 13.1 → 10.6 %, i_s worst 13.4 → 10.9 %, i_s
    median 6.3 → 5.3 %, s median 3.7 → 4.3 %; s and i_s then lie 0.8 and 0.5 points from what the exact
    misregistration (the true camera's, per pixel) gives, against 1.4 and 1.4 with the shift alone — and
    that exact registration's own s median is 5.2 %: the shift's lower median was partly errors that
    cancel. On the narrowest (s 50, the head turned −35°) s −12.1 → −8.5 %, the exact registration
    −8.6 %. A camera given directly has no prior, and the fit keeps to the shift.

    Returns None when the lobe has no core on unclipped skin (fewer than 20 pixels at half its peak).
    """
    lobe_hp = LobeHighPass(photo_rgb, geo, params, rows, cols, sigma_px, vectors)
    solve = lobe_hp.solve
    s = float(params.exponent)
    if fit_exponent:
        grid = np.linspace(0.0, np.log(MAX_EXPONENT), 48)
        costs = [solve(float(np.exp(g)))[0] for g in grid]
        best = int(np.argmin(costs))
        lo, hi = grid[max(best - 1, 0)], grid[min(best + 1, len(grid) - 1)]
        s = float(np.exp(minimize_scalar(lambda g: solve(float(np.exp(g)))[0], bounds=(lo, hi),
                                         method="bounded", options={"xatol": 1e-4}).x))
    placed = np.zeros(6)
    if vectors is not None:
        placed, s = _place_lobe(lobe_hp, s, fit_exponent, fit_turn, similarity_prior)
    ok, rdv = lobe_hp.ok, lobe_hp.rdv
    core = ok & (rdv ** s >= 0.5)
    if core.sum() < 20:
        return None
    # i_s from the lobe integrated over each pixel's square where the registration placed it (capture.pixel_lobe)
    placement = (placed[:2], placed[2:4], placed[4:])
    _, i_s = lobe_hp.residual(s, None if vectors is None else integrated_lobe(lobe_hp, s, placement))
    return DetailSpecular(specular=max(0.0, i_s), exponent=s, sigma_px=lobe_hp.sigma,
                          core_radius_px=float(np.sqrt(core.sum() / np.pi)), pixels=int(ok.sum()),
                          shift_px=placed[:2], turn_deg=placed[2:4], similarity=placed[4:])


def _place_lobe(lobe_hp: LobeHighPass, s: float, fit_exponent: bool, turn: bool,
                similarity_prior: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """The lobe's registration (and with ``turn`` its position) fitted with s (:func:`specular_from_detail`).

    Least squares over (shift x, y in pixels; turn about two axes in degrees; scale in per cent and roll
    in degrees about the lobe's centre; log s) from s and no offset, i_s in closed form at every step,
    within ±:data:`LOBE_MAX_SHIFT_PX`, ±:data:`LOBE_MAX_TURN_DEG` and four of the prior's σ. With
    ``similarity_prior`` the lobe's own scale and roll are fused with it (see
    :func:`specular_from_detail`) and the rest fitted again. Returns (the six offsets, s); ``lobe_hp`` is
    left placed there.
    """
    similar = similarity_prior is not None
    x = np.r_[np.zeros(6), np.log(s)]
    free = np.array([True, True, turn, turn, similar, similar, fit_exponent])
    reach = np.full(2, 1e-9)
    if similar:
        prior = np.asarray(similarity_prior, dtype=float)
        reach = 4.0 * np.sqrt(np.diag(prior))
        weight = lobe_hp.ok * lobe_hp.rdv ** s
        if weight.sum() > 0:  # scale and roll about the lobe's centre, where the shift then holds
            lobe_hp.centre = np.array([weight @ lobe_hp.cols, weight @ lobe_hp.rows]) / weight.sum()
    fit = _fit_placement(lobe_hp, x, free, reach)
    if similar:
        index = np.cumsum(free) - 1
        keep = free & ((np.arange(7) < 4) | (np.arange(7) == 6))
        sim, rest = index[4:6], index[keep]
        try:
            own = SIMILARITY_BIAS_VARIANCE * cluster_covariance(fit.jac, fit.fun, lobe_hp.rows, lobe_hp.cols)[
                np.ix_(sim, sim)]
            info = np.linalg.inv(own)
            fused = np.linalg.solve(info + np.linalg.inv(prior), info @ x[4:6])
            # The other parameters follow to first order (Gauss–Newton at the fit: a refit moved s by
            # < 0.3 % on the development scenes and cost as much again).
            jr, js = fit.jac[:, rest], fit.jac[:, sim]
            step = -np.linalg.solve(jr.T @ jr, jr.T @ (js @ (fused - x[4:6])))
        except np.linalg.LinAlgError:
            fused, step = np.zeros(2), np.zeros(len(rest))  # the lobe does not see them: the prior's mean
        limit = np.r_[LOBE_MAX_SHIFT_PX, LOBE_MAX_SHIFT_PX, LOBE_MAX_TURN_DEG, LOBE_MAX_TURN_DEG, 0, 0, np.inf]
        x[keep] = np.clip(x[keep] + step, -limit[keep], limit[keep])
        x[6] = float(np.clip(x[6], 0.0, np.log(MAX_EXPONENT)))
        x[4:6] = fused
        lobe_hp.place(x[:2], x[2:4], x[4:6])
    return x[:6].copy(), float(np.exp(x[6]))


def _fit_placement(lobe_hp: LobeHighPass, x: np.ndarray, free: np.ndarray, reach: np.ndarray) -> Any:
    """:func:`_place_lobe`'s least squares over the ``free`` entries of ``x`` (updated in place; see there).

    ``reach``: (2,) the bounds of the scale (per cent) and roll (degrees). Returns scipy's result.
    """
    def residual(xf: np.ndarray) -> np.ndarray:
        x[free] = xf
        lobe_hp.place(x[:2], x[2:4], x[4:6])
        res, _ = lobe_hp.residual(float(np.exp(x[6])))
        return np.where(np.isfinite(res), res, 0.0).ravel()

    def jacobian(xf: np.ndarray) -> np.ndarray:
        if not np.array_equal(x[free], xf):
            residual(xf)
        return np.nan_to_num(lobe_hp.jacobian(float(np.exp(x[6]))))[:, free[[0, 1, 4, 5, 6]]]

    limit = np.r_[LOBE_MAX_SHIFT_PX, LOBE_MAX_SHIFT_PX, LOBE_MAX_TURN_DEG, LOBE_MAX_TURN_DEG, reach]
    lb, ub = np.r_[-limit, 0.0][free], np.r_[limit, np.log(MAX_EXPONENT)][free]
    # Without the turn the Jacobian is the chain rule's (LobeHighPass.jacobian: one read of the splines'
    # gradient instead of one re-read of the six spline images per parameter). With it, finite differences:
    # steps of a hundredth of a pixel, of a degree and of a per cent, a thousandth of log s — far below
    # what the lobe resolves (~0.1 px, ~0.3°, a few % in s), far above the residual's rounding.
    fit = least_squares(residual, np.clip(x[free], lb, ub), bounds=(lb, ub),
                        x_scale=np.array([0.2, 0.2, 0.3, 0.3, 0.3, 0.15, 0.05])[free],
                        jac="2-point" if free[2] or free[3] else jacobian,
                        diff_step=np.array([1e-2, 1e-2, 1e-2, 1e-2, 1e-2, 1e-2, 1e-3])[free], xtol=1e-4)
    x[free] = fit.x
    lobe_hp.place(x[:2], x[2:4], x[4:6])
    return fit
