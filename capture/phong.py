"""The Phong skin model of Paris et al. 2003 (§4) and the fit of its parameters to the photograph.

Per pixel, in linear RGB (photograph units, the sensor saturating at 1):

    I = D ⊙ (k·A(n) + F·max(n·l, 0)) + i_s·F·max(r·v, 0)^s,        r = 2(n·l)n − l

with D the skin's diffuse (= ambient) colour, A(n) the ambient light measured on the probe: the paper's
constant A (the probe's mean radiance) or, when the geometry carries it (:class:`Geometry`'s ``ambient``,
``capture(directional_ambient=True)``), the environment's irradiance E(n)/π for the pixel's normal
(:mod:`capture.ambient`; its mean over all normals is A), k the ambient
intensity relative to the flash, F the flash colour (luminance 1), i_s the specular intensity (white
specular: no spectral distortion) and s the exponent (first estimated from the saturation around the
highlight, :mod:`capture.reflectance`, then fitted with i_s on the high-passed photograph,
:func:`specular_from_detail`).

The fit minimises the L2 difference in CIE Luv (colour-science, D65) between the photograph and the
model over skin pixels. The paper's "varying-step gradient descent, coarse to fine" is done with
``scipy.optimize.least_squares`` (trust-region reflective: a gradient method whose step adapts), run on
1/16, then 1/4, then all skin pixels, each level starting where the previous one ended.

The ambient intensity k: the probe measures A in the photograph's units (same camera, exposure and
flash) and the flash is set to luminance 1 in those units (the paper's convention, §4.1), so the two are
photometrically consistent at k = 1, which the fit keeps by default. The paper then optimises k on the
photograph; we found that step biased: the photograph cannot tell ambient light from albedo that varies
with n·l, and a real albedo does (the sample head's: correlation 0.55 between the albedo's luminance and
n·l over the skin — the periphery is darker and redder). On the synthetic ground truth (true k = 1):
with the true A, D comes out within ΔE2000 0.09 at k = 1 but 0.43–0.57 at k = 0.5 and 0.70–0.89 at
k = 0.25 (studio, lobby), and the photograph alone prefers k = 0.59–0.86 in five environments and
0.015 in the studio (whose probe misses 63 % of the ambient in clipped softboxes). ``fit_ambient=True``
still runs the paper's step, and :func:`photo_ambient_scale` reports the k the photograph alone would
choose.

The exponent s and the specular intensity i_s are then read from the highlight's fine structure,
registered on the photograph: :mod:`capture.lobe`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import colour
import numpy as np
from scipy.optimize import least_squares, minimize_scalar

_SRGB = colour.RGB_COLOURSPACES["sRGB"]
_M_RGB_TO_XYZ = np.asarray(_SRGB.matrix_RGB_to_XYZ)
_D65 = np.asarray(_SRGB.whitepoint)


def linear_rgb_to_luv(rgb: np.ndarray) -> np.ndarray:
    """Linear sRGB (..., 3) in [0, 1] → CIE L*u*v* (L in 0..100), D65 white (colour-science)."""
    xyz = np.asarray(rgb, dtype=np.float64) @ _M_RGB_TO_XYZ.T
    return np.asarray(colour.XYZ_to_Luv(xyz, _D65))


def linear_rgb_to_lab(rgb: np.ndarray) -> np.ndarray:
    """Linear sRGB (..., 3) → CIE L*a*b* (D65), for ΔE2000."""
    xyz = np.asarray(rgb, dtype=np.float64) @ _M_RGB_TO_XYZ.T
    return np.asarray(colour.XYZ_to_Lab(xyz, _D65))


def delta_e2000(rgb_a: np.ndarray, rgb_b: np.ndarray) -> np.ndarray:
    """CIEDE2000 between two linear sRGB arrays (..., 3)."""
    return np.asarray(colour.delta_E(linear_rgb_to_lab(rgb_a), linear_rgb_to_lab(rgb_b), method="CIE 2000"))


@dataclass
class Geometry:
    """Per-pixel geometry of the skin pixels (world / mesh coordinates).

    Attributes:
        n_dot_l: (P,) n·l (unclamped). r_dot_v: (P,) r·v (unclamped). Both for the flash direction.
        ambient: (P, 3) the ambient light each pixel's normal receives, A(n) = E(n)/π (photograph
            units, :func:`capture.ambient.ambient_per_normal`), which k scales instead of the constant
            ``PhongParams.ambient_rgb``; None = the constant (the paper's model).
    """

    n_dot_l: np.ndarray
    r_dot_v: np.ndarray
    ambient: np.ndarray | None = None

    @classmethod
    def from_vectors(cls, normals: np.ndarray, view: np.ndarray, light: np.ndarray,
                     ambient: np.ndarray | None = None) -> Geometry:
        """From unit normals (P, 3), unit directions to the camera (P, 3) and to the light (3,) or (P, 3).

        ``ambient``: each pixel's A(n) (P, 3, photograph units), or None for the constant.
        """
        light = np.broadcast_to(np.asarray(light, dtype=float), normals.shape)
        ndl = np.einsum("pc,pc->p", normals, light)
        r = 2 * ndl[:, None] * normals - light
        rdv = np.einsum("pc,pc->p", r, view)
        return cls(n_dot_l=ndl, r_dot_v=rdv, ambient=ambient)

    def subset(self, idx: np.ndarray | slice) -> Geometry:
        """The geometry of the pixels ``idx`` (an index array, a bool mask or a slice over P)."""
        return Geometry(self.n_dot_l[idx], self.r_dot_v[idx], None if self.ambient is None else self.ambient[idx])

    def ambient_light(self, params: PhongParams) -> np.ndarray:
        """k·A(n) (P, 3), or k·A (1, 3) without a per-pixel ambient: photograph units."""
        amb = params.ambient_rgb[None, :] if self.ambient is None else self.ambient
        return params.ambient_scale * amb


@dataclass
class PhongParams:
    """The fitted skin and light parameters (see the module docstring; linear RGB, photograph units).

    Attributes:
        diffuse: (3,) D. specular: i_s. exponent: s. ambient_scale: k.
        flash_rgb: (3,) F (luminance 1). ambient_rgb: (3,) A (as measured on the probe).
    """

    diffuse: np.ndarray
    specular: float
    exponent: float
    ambient_scale: float
    flash_rgb: np.ndarray = field(default_factory=lambda: np.ones(3))
    ambient_rgb: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def to_json(self) -> dict[str, Any]:
        """The parameters as JSON numbers and lists (face.json's ``phong``; units in capture.face)."""
        return {
            "diffuse_rgb": self.diffuse.tolist(), "specular_intensity": self.specular,
            "exponent": self.exponent, "ambient_scale": self.ambient_scale,
            "flash_rgb": self.flash_rgb.tolist(), "ambient_rgb": self.ambient_rgb.tolist(),
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> PhongParams:
        """The parameters from :meth:`to_json`'s dict; KeyError, TypeError or ValueError if malformed."""
        return cls(diffuse=np.asarray(d["diffuse_rgb"], float), specular=float(d["specular_intensity"]),
                   exponent=float(d["exponent"]), ambient_scale=float(d["ambient_scale"]),
                   flash_rgb=np.asarray(d["flash_rgb"], float), ambient_rgb=np.asarray(d["ambient_rgb"], float))


def shade(p: PhongParams, geo: Geometry, clip: bool = True) -> np.ndarray:
    """The model's linear RGB (P, 3) at the pixels of ``geo`` (clipped to [0, 1] like a sensor)."""
    ndl = np.clip(geo.n_dot_l, 0.0, None)
    spec = np.where(geo.n_dot_l > 0, np.clip(geo.r_dot_v, 0.0, None) ** p.exponent, 0.0)
    light = geo.ambient_light(p) + p.flash_rgb[None, :] * ndl[:, None]
    out = p.diffuse[None, :] * light + p.specular * spec[:, None] * p.flash_rgb[None, :]
    return np.clip(out, 0.0, 1.0) if clip else out


@dataclass
class FitResult:
    """A Phong fit's outcome.

    Attributes:
        params: the fitted parameters.
        rms_luv: the residual, RMS over the pixels of the CIE Luv distance (D65, L in 0..100).
        l2_luv: the paper's residual, the L2 norm of that distance over the pixels.
        evaluations: model evaluations used.
    """

    params: PhongParams
    rms_luv: float
    l2_luv: float
    evaluations: int


def fit_phong(photo_rgb: np.ndarray, geo: Geometry, exponent: float, flash_rgb: np.ndarray,
              ambient_rgb: np.ndarray, start: np.ndarray | None = None, start_k: float = 1.0,
              levels: tuple[int, ...] = (16, 4, 1), fit_ambient: bool = False,
              fix_specular: bool = False) -> FitResult:
    """Fit D (3) and i_s in CIE Luv with the ambient scale k fixed at ``start_k``.

    With ``fit_ambient``, then k alone and D, i_s once more (the paper's order; biased, see the module
    docstring). Bounds: D ∈ [10⁻⁴, 4] per channel, i_s ∈ [0, 10], k ∈ [10⁻³, 10³].

    Args:
        photo_rgb: (P, 3) linear RGB of the skin pixels (photograph units, [0, 1]).
        geo: their geometry for the flash.
        exponent: s, fixed (dimensionless, ≥ 1).
        flash_rgb: (3,) the probe's flash colour F (linear, luminance 1).
        ambient_rgb: (3,) the probe's ambient light A (photograph units).
        start: initial (D_r, D_g, D_b, i_s); None = a neutral guess.
        start_k: k (dimensionless, ambient relative to the probe's measurement), or its start value.
        levels: pixel subsampling strides, coarse to fine.
        fit_ambient: also optimise k on the photograph.
        fix_specular: keep i_s at its start value (``start[3]``) and fit D alone.
    """
    target = linear_rgb_to_luv(np.clip(photo_rgb, 0, 1))
    flash = np.asarray(flash_rgb, dtype=float)
    amb = np.asarray(ambient_rgb, dtype=float)
    x = np.array([0.5, 0.5, 0.5, 0.1]) if start is None else np.asarray(start, dtype=float).copy()
    k = float(start_k)
    nev = 0

    def params(xv: np.ndarray, kv: float) -> PhongParams:
        return PhongParams(diffuse=xv[:3], specular=float(xv[3]), exponent=exponent, ambient_scale=kv,
                           flash_rgb=flash, ambient_rgb=amb)

    def resid(xv: np.ndarray, kv: float, idx: slice | np.ndarray) -> np.ndarray:
        nonlocal nev
        nev += 1
        g = geo.subset(idx)
        return (linear_rgb_to_luv(shade(params(xv, kv), g)) - target[idx]).ravel()

    lb = np.array([1e-4, 1e-4, 1e-4, 0.0])
    ub = np.array([4.0, 4.0, 4.0, 10.0])
    x = np.clip(x, lb + 1e-6, ub - 1e-6)
    free = slice(0, 3) if fix_specular else slice(0, 4)

    def resid_free(xf: np.ndarray, kv: float, idx: slice | np.ndarray) -> np.ndarray:
        return resid(np.r_[xf, x[len(xf):]], kv, idx)

    n = len(target)
    for stride in levels:
        idx = np.arange(0, n, stride)
        x[free] = least_squares(resid_free, x[free], args=(k, idx), bounds=(lb[free], ub[free]), x_scale="jac",
                                xtol=1e-6, ftol=1e-8).x
    full = np.arange(n)
    if fit_ambient and np.any(amb > 0):
        def cost_k(logk: float) -> float:
            r = resid(x, float(np.exp(logk)), full)
            return float(r @ r)

        k = float(np.exp(minimize_scalar(cost_k, bounds=(np.log(1e-3), np.log(1e3)), method="bounded",
                                         options={"xatol": 1e-4}).x))
        x[free] = least_squares(resid_free, x[free], args=(k, full), bounds=(lb[free], ub[free]), x_scale="jac",
                                xtol=1e-8, ftol=1e-10).x
    r = resid(x, k, full).reshape(-1, 3)
    d = np.sqrt((r ** 2).sum(axis=1))
    return FitResult(params=params(x, k), rms_luv=float(np.sqrt(np.mean(d ** 2))),
                     l2_luv=float(np.sqrt((d ** 2).sum())), evaluations=nev)


def photo_ambient_scale(photo_rgb: np.ndarray, geo: Geometry, params: PhongParams) -> float | None:
    """The ambient scale k the photograph alone prefers (dimensionless; None without ambient light).

    D and i_s are refitted for each k and the Luv cost minimised over log k ∈ [ln 10⁻³, ln 10³], on at
    most ~6,000 pixels. A diagnostic — reported beside the k used, never used itself (see the module
    docstring).
    """
    if not np.any(np.asarray(params.ambient_rgb) > 0):
        return None
    stride = max(1, len(photo_rgb) // 6000)
    sel = np.arange(0, len(photo_rgb), stride)
    res = fit_phong(np.asarray(photo_rgb)[sel], geo.subset(sel), params.exponent, params.flash_rgb,
                    params.ambient_rgb, start=np.r_[params.diffuse, params.specular],
                    start_k=params.ambient_scale, levels=(1,), fit_ambient=True)
    return float(res.params.ambient_scale)


def robustness(photo_rgb: np.ndarray, geo: Geometry, exponent: float, flash_rgb: np.ndarray,
               ambient_rgb: np.ndarray, starts: int = 200, seed: int = 0,
               max_pixels: int = 6000, fit_ambient: bool = False) -> dict[str, Any]:
    """The fit's spread over random starts: the relative standard deviation of each parameter.

    The fit runs from ``starts`` random starting points of the four skin parameters (D ∈ U(0.05, 1)³,
    i_s ∈ U(0, 1), generator seeded with ``seed``; k starts at 1 as in a normal capture, and stays there
    unless ``fit_ambient``). Returns ``starts``, ``relative_std`` (std / |mean|, dimensionless, per
    parameter, k included), ``max_relative_std`` and ``mean`` (per parameter). Uses at most
    ``max_pixels`` skin pixels (evenly strided) so 200 starts stay within seconds.
    """
    rng = np.random.default_rng(seed)
    stride = max(1, len(photo_rgb) // max_pixels)
    sel = np.arange(0, len(photo_rgb), stride)
    g = geo.subset(sel)
    rows = []
    for _ in range(starts):
        st = np.r_[rng.uniform(0.05, 1.0, 3), rng.uniform(0.0, 1.0)]
        res = fit_phong(photo_rgb[sel], g, exponent, flash_rgb, ambient_rgb, start=st, levels=(4, 1),
                        fit_ambient=fit_ambient)
        p = res.params
        rows.append(np.r_[p.diffuse, p.specular, p.ambient_scale])
    a = np.asarray(rows)
    rel = a.std(axis=0) / np.maximum(np.abs(a.mean(axis=0)), 1e-9)
    names = ["diffuse_r", "diffuse_g", "diffuse_b", "specular_intensity", "ambient_scale"]
    return {"starts": starts, "relative_std": dict(zip(names, rel.tolist())),
            "max_relative_std": float(rel.max()), "mean": dict(zip(names, a.mean(axis=0).tolist()))}
