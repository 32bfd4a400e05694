"""The lobe registration's fit is the same function, computed faster (capture.lobe, issue 14).

The registration's least squares uses :meth:`capture.lobe.LobeHighPass.jacobian` (the chain rule) instead of
finite differences, and the high-pass filters through OpenCV instead of scipy: both must give what they
replace.
"""

from __future__ import annotations

from functools import cache

import numpy as np
from scipy import ndimage

from bench.capture_synthetic import light_from_camera, validation_camera
from capture.lobe import LobeHighPass
from capture.phong import Geometry, PhongParams, shade
from capture.pipeline import pixel_data
from painting.head import load_head


@cache
def _lobe() -> LobeHighPass:
    """The sample head, untextured, shaded by the model from the validation's camera (256²), s 30."""
    head = load_head()
    camera = validation_camera(256)
    light = light_from_camera(camera, 6.0, 3.0)
    params = PhongParams(diffuse=np.array([0.46, 0.31, 0.245]), specular=0.18, exponent=30.0, ambient_scale=1.0,
                         flash_rgb=np.ones(3), ambient_rgb=np.full(3, 0.05))
    pix = pixel_data(head, camera)
    sel = np.einsum("pc,pc->p", pix.normals, pix.view) > 0.25
    normals, view = pix.normals[sel], pix.view[sel]
    geo = Geometry.from_vectors(normals, view, light)
    photo = np.clip(shade(params, geo, clip=False), 0.0, 1.0)
    return LobeHighPass(photo, geo, params, pix.rows[sel], pix.cols[sel], vectors=(normals, view, light))


def test_the_registrations_jacobian_is_the_residuals_derivative() -> None:
    """Against central differences, away from zero (shifted, scaled and rolled about an off-centre point).

    Measured on a development scene: 2e-8 to 4e-8 relative (the differences' own truncation); the
    quadratic spline of the coefficients' differences, which scipy reads, gave 5–12 % (it is the
    derivative along one axis only).
    """
    lobe = _lobe()
    lobe.centre = lobe.centre + np.array([5.0, -7.0])
    x = np.array([0.3, -0.2, 0.4, -0.15, np.log(24.0)])

    def residual(x: np.ndarray) -> np.ndarray:
        lobe.place(x[:2], np.zeros(2), x[2:4])
        return lobe.residual(float(np.exp(x[4])))[0].ravel()

    residual(x)
    jac = lobe.jacobian(24.0)
    for k, h in enumerate((1e-4, 1e-4, 1e-4, 1e-4, 1e-5)):
        step = np.zeros(5)
        step[k] = h
        central = (residual(x + step) - residual(x - step)) / (2 * h)
        assert np.linalg.norm(jac[:, k] - central) < 1e-5 * np.linalg.norm(central), k


def test_the_high_pass_filters_as_scipy_does() -> None:
    """The Gaussian average through OpenCV is scipy's ``gaussian_filter`` (kernel, reach, edges) to rounding."""
    lobe = _lobe()
    rng = np.random.default_rng(5)
    img = rng.standard_normal(lobe.shape + (4,))
    img[rng.random(lobe.shape) < 0.4] = 0.0
    expected = np.stack([ndimage.gaussian_filter(img[..., c], lobe.sigma) for c in range(4)], axis=-1)
    np.testing.assert_allclose(lobe._blur(img), expected, rtol=0, atol=1e-14)
