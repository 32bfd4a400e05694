"""The subsurface-scattering kernels of the skin (no GPU): d'Eon's profile and the taps built from it.

- :data:`SKIN_GAUSSIANS`: the skin diffusion profile as a sum of six Gaussians (d'Eon et al. 2007), used
  as is by the reference mode (Jimenez 2009: one separable blur per Gaussian).
- :func:`fast_kernel`: the fast mode's pre-integrated separable kernel of that profile (Jimenez 2015).
- :func:`reference_taps`: how many taps one reference-mode Gaussian pass needs (sub-texel taps).
- :func:`integer_radius`, :func:`tent_gaussian_weights`: the reference mode's whole-texel taps and their
  weights (the Gaussian convolved with the bilinear tent; ``sss_gauss3.frag`` computes the same per pixel).

Units: variances in mm², offsets in mm, ``sigma_texels`` in source texels (pixels of the blurred image).
"""

from __future__ import annotations

import math

import numpy as np

from render.errors import RenderError

#: d'Eon et al. 2007 (GPU Gems 3 ch. 14): the skin diffusion profile as a sum of Gaussians,
#: (variance mm², R, G, B weights). Each column sums to 1.
SKIN_GAUSSIANS: tuple[tuple[float, float, float, float], ...] = (
    (0.0064, 0.233, 0.455, 0.649),
    (0.0484, 0.100, 0.336, 0.344),
    (0.187, 0.118, 0.198, 0.0),
    (0.567, 0.113, 0.007, 0.007),
    (1.99, 0.358, 0.004, 0.0),
    (7.41, 0.078, 0.0, 0.0),
)
#: the most taps one reference-mode Gaussian pass takes
REFERENCE_TAPS = 13


def reference_taps(sigma_texels: float) -> int:
    """Taps of one reference-mode Gaussian pass.

    Enough to space the taps at most one source texel apart over ±3σ, with a 25 % margin for the nearer
    parts of the face. Taps closer than a texel would re-read the same bilinear interpolation: a narrow
    Gaussian costs fewer taps, not less accuracy (the kernel is normalised by its tap weights either way).

    Args:
        sigma_texels: the Gaussian's standard deviation in texels of the image it blurs (≥ 0; negative
            values count as 0).

    Returns:
        An odd tap count in [5, :data:`REFERENCE_TAPS`].
    """
    n = int(math.ceil(6.0 * max(sigma_texels, 0.0) * 1.25)) + 1
    n += 1 - n % 2
    return max(5, min(REFERENCE_TAPS, n))


#: the widest whole-texel reference Gaussian, in texels either side of the centre; a wider one (zoomed in)
#: takes :func:`reference_taps` sub-texel taps instead, so a pass's fetches stay bounded
INTEGER_RADIUS_MAX = 8
#: how much larger than at the camera's target distance a Gaussian may be on the nearest skin before its
#: whole-texel taps cut it short of ±3σ (measured: the nearest skin is 1.05× nearer than the target at the
#: studio's framing, 1.11× at 0.45× the distance; beyond, the texels past the radius hold below 1e-4 of it)
INTEGER_MARGIN = 1.05


def integer_radius(sigma_texels: float) -> int | None:
    """Whole-texel taps either side of the centre for one reference-mode Gaussian, or None when too wide.

    The Gaussian, truncated at ±3σ and convolved with the bilinear tent, reaches ``ceil(3σ)`` texels;
    :data:`INTEGER_MARGIN` covers the nearer parts of the face.

    Args:
        sigma_texels: the Gaussian's standard deviation in texels at the camera's target distance (≥ 0;
            negative values count as 0).

    Returns:
        The radius in [1, :data:`INTEGER_RADIUS_MAX`], or None above it (use sub-texel taps).
    """
    r = max(1, math.ceil(3.0 * max(sigma_texels, 0.0) * INTEGER_MARGIN))
    return r if r <= INTEGER_RADIUS_MAX else None


def tent_gaussian_weights(sigma_texels: float, radius: int) -> np.ndarray:
    """The whole-texel weights of a Gaussian of the bilinearly interpolated image (what sss_gauss3.frag computes).

    Sampling an image between its texels interpolates it bilinearly, i.e. convolves the texels with the tent
    ``max(0, 1 - |x|)``; the Gaussian of that interpolated image, truncated at ±3σ, is therefore a sum over
    whole texels with weights ``W[d] = ∫_{|x| ≤ 3σ} g(x) tent(x - d) dx``, exactly (in closed form from the
    antiderivatives of g and x·g).

    Args:
        sigma_texels: standard deviation in texels (> 0).
        radius: texels either side of the centre (≥ 1).

    Returns:
        float64 (2·radius + 1,): the weights of offsets -radius..radius, summing to 1 (normalised).
    """
    s = max(float(sigma_texels), 1e-3)
    x = np.minimum(np.abs(np.arange(-radius - 1, radius + 2, dtype=np.float64)), 3.0 * s)
    sign = np.sign(np.arange(-radius - 1, radius + 2))
    e = np.exp(-0.5 * (x / s) ** 2)
    erf = np.vectorize(math.erf, otypes=[np.float64])
    cdf = 0.5 + 0.5 * sign * erf(x / (s * math.sqrt(2.0)))  # Φ at the clamped whole texels
    q = -s / math.sqrt(2.0 * math.pi) * e  # the antiderivative of x·g(x) (even)
    d = np.arange(-radius, radius + 1, dtype=np.float64)
    i = np.arange(1, 2 * radius + 2)  # index of offset d in cdf / q
    w = ((q[i] - q[i - 1]) - (d - 1.0) * (cdf[i] - cdf[i - 1])
         + (d + 1.0) * (cdf[i + 1] - cdf[i]) - (q[i + 1] - q[i]))
    return np.asarray(w / w.sum())


def fast_kernel(taps: int, width: float = 1.0, exponent: float = 2.0, core_mm: float = 0.0) -> np.ndarray:
    """The pre-integrated separable kernel (Jimenez et al. 2015) of the d'Eon skin profile.

    Offsets are spaced as ``range·t|t|`` (denser near the centre, ``range`` = 3 σ of the widest Gaussian);
    each weight integrates the 1D profile over the tap's interval (midpoints to the neighbours). Taps
    closer than ``core_mm`` to the centre (below a pixel on screen) are merged into it, so the core can be
    applied at full resolution.

    Args:
        taps: the tap count, odd and ≥ 3 (the renderer uses 11, 17 or 25).
        width: scale of the profile (1 = d'Eon's measured skin; > 0).
        exponent: the spacing exponent (2 = quadratic; ≥ 1).
        core_mm: radius in mm within which taps merge into the centre (≥ 0).

    Returns:
        float32 (taps, 4): RGB weights (each channel sums to 1) and the offset in mm; row 0 is the centre.

    Raises:
        RenderError: ``taps`` is even or below 3.
    """
    if taps % 2 == 0 or taps < 3:
        raise RenderError(f"kernel taps must be odd and ≥ 3, got {taps}")
    sig = np.sqrt(np.array([g[0] for g in SKIN_GAUSSIANS])) * width
    w = np.array([g[1:] for g in SKIN_GAUSSIANS])  # (6, 3)
    rng = 3.0 * sig.max()
    t = np.linspace(-1.0, 1.0, taps)
    off = rng * np.sign(t) * np.abs(t) ** exponent
    edges = np.concatenate([[-np.inf], (off[1:] + off[:-1]) / 2.0, [np.inf]])
    # math.erf on a few dozen values: scipy.special's import alone cost half a second of the studio's start-up
    erf = np.vectorize(math.erf, otypes=[np.float64])

    def cdf(x: np.ndarray) -> np.ndarray:  # (n,) → (n, 3): the 1D profile's cumulative distribution
        z = x[:, None] / (np.sqrt(2.0) * sig[None, :])
        return (0.5 * (1.0 + erf(z))) @ w

    weights = cdf(edges[1:]) - cdf(edges[:-1])
    weights /= weights.sum(axis=0, keepdims=True)
    k = np.concatenate([weights, off[:, None]], axis=1)
    c = taps // 2
    core = np.abs(off) <= core_mm
    core[c] = True
    k[c, :3] = weights[core].sum(axis=0)
    k[core & (np.arange(taps) != c), :3] = 0.0
    return np.concatenate([k[c:c + 1], k[:c], k[c + 1:]], axis=0).astype(np.float32)
