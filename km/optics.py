"""Kubelka–Munk optics of cosmetic layers (Huang et al. 2013, Eq. 1–4 and 6–7).

Units: S and K (scattering and absorption coefficients) per mm; thicknesses X and D in mm;
reflectances and transmittances are fractions in [0, 1]. Every function broadcasts its arguments
with numpy rules; spectral data have the wavelengths on the last axis.

Conventions for bad values (the same everywhere in this module):

- Forward functions (:func:`layer_rt`, :func:`over`, :func:`stack`, :func:`r_inf_from_ks`,
  :func:`ks_from_r_inf`, :func:`saunderson`, :func:`inverse_saunderson`) never raise on values: a NaN
  input or a value outside the documented domain gives NaN at that position (like ``np.sqrt(-1)``), and
  no numpy floating-point warning escapes. Infinities give the physical limit where it exists (an
  infinitely thick layer is opaque) and NaN where the limit is indeterminate (``0 * inf``).
- The inversion :func:`invert_sk` is about measured data: invalid data raise :class:`KMDomainError`
  naming the wavelengths (or indices) at fault, or with ``clip=True`` give NaN there and report them.
- :func:`mix` validates its concentrations and raises :class:`KMDomainError`.

The formulas are written in bounded, cancellation-free forms (see :func:`layer_rt`), so the results
are accurate to a few ulps over the whole domain, including the limits S → 0, K → 0, X → 0 and X → ∞.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from core.errors import SheerError

if TYPE_CHECKING:
    from collections.abc import Sequence

__all__ = [
    "KMDomainError",
    "SKInversion",
    "layer_rt",
    "over",
    "stack",
    "invert_sk",
    "r_inf_from_ks",
    "ks_from_r_inf",
    "saunderson",
    "inverse_saunderson",
    "mix",
]

FloatArray = NDArray[np.float64]

#: how many offending positions an error message lists before "… and N more"
_MAX_LISTED = 12


class KMDomainError(SheerError, ValueError):
    """Input outside the domain of a Kubelka–Munk formula; the message says what and where."""


def _f64(x: ArrayLike) -> FloatArray:
    return np.asarray(x, dtype=np.float64)


def _all_in(x: FloatArray, lo: float, hi: float) -> bool:
    """True when every element is in [lo, hi] (False when any is NaN); cheap reductions only."""
    if x.size == 0:
        return True
    return bool(x.min() >= lo) and bool(x.max() <= hi)


def _nan_where(arrays: list[FloatArray], bad: NDArray[np.bool_]) -> None:
    """Set NaN in place in each (already broadcast-shaped, writeable) array where ``bad`` is true."""
    if bad.any():
        for a in arrays:
            a[np.broadcast_to(bad, a.shape)] = np.nan


# ---------------------------------------------------------------------------------------------------
# Eq. 1–2: one homogeneous layer
# ---------------------------------------------------------------------------------------------------


def layer_rt(S: ArrayLike, K: ArrayLike, X: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Reflectance ``R0`` (over a black background) and transmittance ``T`` of one KM layer, Eq. 1–2.

    ========== ===================== ======================================================
    argument   unit                  domain
    ========== ===================== ======================================================
    S          1/mm                  [0, ∞]   scattering coefficient
    K          1/mm                  [0, ∞]   absorption coefficient
    X          mm                    [0, ∞]   layer thickness
    ========== ===================== ======================================================

    ========== ===================== ======================================================
    returns    unit                  range
    ========== ===================== ======================================================
    R0         1                     [0, 1)   reflectance of the layer alone (black background)
    T          1                     [0, 1]   diffuse transmittance
    ========== ===================== ======================================================

    The arguments broadcast; both results have the broadcast shape (wavelengths on the last axis).

    Eq. 1–2 as printed overflow (``sinh``/``cosh``) for thick layers and are 0/0 at S = 0 or K = 0. With
    ``α = S + K``, ``β = bS = sqrt(K (K + 2S))``, ``y = βX``, ``e = exp(−y)`` and ``m = 1 − e²``
    (computed as ``−expm1(−2y)``), multiplying numerator and denominator by ``2e·S/(α+β)`` gives::

        R0 = R∞ · m / (A·m + B·(1 + e²)),   T = 2B·e / (A·m + B·(1 + e²)),
        R∞ = S/(α+β),  A = α/(α+β),  B = β/(α+β)

    where every factor is bounded, so there is no overflow and no cancellation; thick layers tend to
    ``(R∞, 0)`` and S = 0 gives exactly ``(0, exp(−KX))``. When β = 0 (K = 0, or S = ∞) the exact
    pure-scatterer form ``R0 = SX/(1+SX)``, ``T = 1/(1+SX)`` is used, and the two forms join
    continuously as K → 0.

    Bad values: NaN or a negative S, K or X gives NaN at that position. ``X = ∞`` gives the opaque
    limit (R∞, 0); ``S = ∞`` (with X > 0) gives (1, 0) and ``K = ∞`` (with X > 0) gives (0, 0);
    ``X = 0`` with an infinite coefficient, and ``S = K = ∞``, are indeterminate and give NaN.
    S = K = 0 is a clear layer: (0, 1) at any thickness.
    """
    S_ = _f64(S)
    K_ = _f64(K)
    X_ = _f64(X)
    shape = np.broadcast_shapes(S_.shape, K_.shape, X_.shape)
    with np.errstate(all="ignore"):
        # --- per-(S, K) quantities: usually a small (n_wavelengths,) array --------------------------
        alpha = S_ + K_
        # κ = K/(S+K) and σ = S/(S+K) = 1 − κ, each from its own ratio (no cancellation in 1 − κ),
        # in forms that stay right when S or K is 0 or ∞ (S = ∞: κ = 0; K = ∞: κ = 1)
        kappa = 1.0 / (1.0 + S_ / K_)
        sigma = 1.0 / (1.0 + K_ / S_)
        clear = alpha == 0.0  # S = K = 0 (0/0 above): a clear layer, treated as κ = 0, σ = 1
        kappa = np.where(clear, 0.0, kappa)
        sigma = np.where(clear, 1.0, sigma)
        q = np.sqrt(kappa * (1.0 + sigma))  # β/α = sqrt(κ(2 − κ)) in [0, 1]
        inv1q = 1.0 / (1.0 + q)
        r_inf = sigma * inv1q
        A = inv1q
        B = q * inv1q
        beta = q * alpha
        # --- per texel and wavelength ----------------------------------------------------------------
        ny = np.multiply(-beta, X_, out=np.empty(shape))  # −y
        e = np.exp(ny, out=np.empty(shape))
        nm = np.multiply(ny, 2.0, out=ny)  # −2y; ny is not needed any more
        np.expm1(nm, out=nm)  # nm = −m = e² − 1 without cancellation
        den = np.multiply(e, e)
        den *= B
        den += B
        den -= A * nm
        R0 = np.multiply(nm, -r_inf, out=nm)
        R0 /= den
        T = np.multiply(e, 2.0 * B, out=e)
        T /= den
        zero_beta = q == 0.0
        if zero_beta.any():
            # pure scatterer (K = 0 or S = ∞): R0 = t/(1+t) and T = 1/(1+t) with t = (S+K)·X
            t = np.where(alpha == 0.0, 0.0, alpha * X_)
            R_s = sigma / (1.0 + 1.0 / t)
            T_s = 1.0 / (1.0 + t)
            zb = np.broadcast_to(zero_beta, shape)
            R0 = np.where(zb, R_s, R0)
            T = np.where(zb, T_s, T)

    R0 = np.asarray(R0, dtype=np.float64)
    T = np.asarray(T, dtype=np.float64)
    if not (_all_in(S_, 0.0, np.inf) and _all_in(K_, 0.0, np.inf) and _all_in(X_, 0.0, np.inf)):
        _nan_where([R0, T], ~((S_ >= 0.0) & (K_ >= 0.0) & (X_ >= 0.0)))
    return R0, T


# ---------------------------------------------------------------------------------------------------
# Eq. 3–4: layers over a background, and stacks of layers
# ---------------------------------------------------------------------------------------------------


def over(R: ArrayLike, T: ArrayLike, Rg: ArrayLike, R_bottom: ArrayLike | None = None) -> FloatArray:
    """Reflectance of a layer (or stack) over a background: ``R + T²·Rg / (1 − R_bottom·Rg)``.

    ========== ===== ===========================================================================
    argument   unit  domain
    ========== ===== ===========================================================================
    R          1     [0, 1]  reflectance of the layer seen from above (R0 of Eq. 1, or R_top)
    T          1     [0, 1]  transmittance of the layer
    Rg         1     [0, 1]  reflectance of the background (e.g. skin)
    R_bottom   1     [0, 1]  reflectance of the layer seen from below; defaults to ``R``, which is
                             right for one homogeneous layer; for a stack pass ``stack(...)[1]``
    ========== ===== ===========================================================================

    Returns the total reflectance in [0, 1] (unit 1), broadcast shape.

    Bad values: NaN or a value outside [0, 1] in any argument gives NaN there. Where
    ``R_bottom·Rg = 1`` the inter-reflection series diverges: the result is ``R`` when ``T = 0`` (no
    light reaches the background) and NaN otherwise (not a physical layer).
    """
    R_ = _f64(R)
    T_ = _f64(T)
    Rg_ = _f64(Rg)
    Rb_ = R_ if R_bottom is None else _f64(R_bottom)
    shape = np.broadcast_shapes(R_.shape, T_.shape, Rg_.shape, Rb_.shape)
    out = np.empty(shape, dtype=np.float64)
    with np.errstate(all="ignore"):
        den = 1.0 - Rb_ * Rg_
        np.multiply(T_, T_, out=out)
        out *= Rg_
        out /= den
        out += R_
        if not (den.size == 0 or bool(den.min() > 0.0)):
            # R_bottom·Rg = 1: no bounce series when nothing is transmitted, unphysical otherwise
            diverges = np.broadcast_to(den <= 0.0, shape)
            out[diverges] = np.nan
            out = np.where(diverges & (T_ == 0.0), R_, out)
    if not all(_all_in(a, 0.0, 1.0) for a in (R_, T_, Rg_, Rb_)):
        _nan_where([out], ~(_in01(R_) & _in01(T_) & _in01(Rg_) & _in01(Rb_)))
    return out


def _in01(x: FloatArray) -> NDArray[np.bool_]:
    return (x >= 0.0) & (x <= 1.0)


def stack(layers: Sequence[tuple[ArrayLike, ArrayLike]]) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Combine homogeneous layers, top first, into ``(R_top, R_bottom, T)`` (Eq. 3–4 generalised).

    ``layers`` is a sequence of ``(R0, T)`` pairs as returned by :func:`layer_rt`, ordered from the
    top (the side the light comes from) down. Each pair's arrays broadcast with all the others.

    ========== ===== ===========================================================================
    returns    unit  range
    ========== ===== ===========================================================================
    R_top      1     [0, 1]  reflectance of the stack seen from above (black background)
    R_bottom   1     [0, 1]  reflectance seen from below (what the skin sees); differs from R_top
                             when the layers differ
    T          1     [0, 1]  transmittance (the same in both directions)
    ========== ===== ===========================================================================

    Adding a layer 2 below a stack 1 (the multiple reflections between them are a geometric series;
    note Eq. 3 of the paper prints T₁·R₁·T₁, the correct term is T₁·R₂·T₁)::

        d = 1 − R1_bottom·R2
        R_top = R1_top + T1²·R2/d,   R_bottom = R2 + T2²·R1_bottom/d,   T = T1·T2/d

    so that ``over(R_top, T, Rg, R_bottom)`` equals nesting :func:`over` layer by layer from the
    bottom. An empty sequence is the identity ``(0, 0, 1)``.

    Bad values: NaN or a value outside [0, 1] gives NaN at that position in all three results.
    Where two facing layers are both perfect mirrors (R1_bottom = R2 = 1) the series between them
    diverges: a result is kept only where no light enters the gap (R_top = R1_top if T1 = 0,
    R_bottom = R2 if T2 = 0, T = 0 if either is 0) and is NaN otherwise. A layer pair that does not unpack into two values raises
    :class:`KMDomainError`.
    """
    pairs: list[tuple[FloatArray, FloatArray]] = []
    for i, layer in enumerate(layers):
        try:
            r, t = layer
        except (TypeError, ValueError) as exc:
            raise KMDomainError(f"stack: layer {i} (counting from the top) is not an (R0, T) pair") from exc
        pairs.append((_f64(r), _f64(t)))
    if not pairs:
        return np.zeros(()), np.zeros(()), np.ones(())

    with np.errstate(all="ignore"):
        r, t = pairs[0]
        bad = None if (_all_in(r, 0.0, 1.0) and _all_in(t, 0.0, 1.0)) else ~(_in01(r) & _in01(t))
        R_top = r.copy()
        R_bot = r.copy()
        T = t.copy()
        for r2, t2 in pairs[1:]:
            if not (_all_in(r2, 0.0, 1.0) and _all_in(t2, 0.0, 1.0)):
                b2 = ~(_in01(r2) & _in01(t2))
                bad = b2 if bad is None else bad | b2
            d = 1.0 - R_bot * r2
            degenerate = not (d.size == 0 or bool(d.min() > 0.0))
            inv_d = np.divide(1.0, d)
            new_top = T * T
            new_top *= r2
            new_top *= inv_d
            new_top += R_top
            new_bot = t2 * t2
            new_bot = new_bot * R_bot
            new_bot *= inv_d
            new_bot += r2
            new_T = T * t2
            new_T *= inv_d
            if degenerate:
                # R1_bottom = R2 = 1: a mirror under a mirror; physical layers then have T1 = T2 = 0
                dg = d <= 0.0
                new_top = np.where(dg & (T == 0.0), R_top + 0.0 * r2, np.where(dg, np.nan, new_top))
                new_bot = np.where(dg & (t2 == 0.0), r2 + 0.0 * R_bot, np.where(dg, np.nan, new_bot))
                new_T = np.where(dg & ((T == 0.0) | (t2 == 0.0)), 0.0, np.where(dg, np.nan, new_T))
            R_top, R_bot, T = new_top, new_bot, new_T
    if bad is not None:
        R_top, R_bot, T = (np.array(a, dtype=np.float64) for a in (R_top, R_bot, T))
        shape = np.broadcast_shapes(R_top.shape, bad.shape)
        R_top, R_bot, T = (np.broadcast_to(a, shape).copy() for a in (R_top, R_bot, T))
        _nan_where([R_top, R_bot, T], bad)
    return R_top, R_bot, T


# ---------------------------------------------------------------------------------------------------
# R∞ and K/S
# ---------------------------------------------------------------------------------------------------


def r_inf_from_ks(ks: ArrayLike) -> FloatArray:
    """Reflectance of an opaque layer from the ratio K/S: ``R∞ = 1 + K/S − sqrt((K/S)² + 2K/S)``.

    ======= ===== =============================    ======= ===== ==========
    arg     unit  domain                            returns unit  range
    ======= ===== =============================    ======= ===== ==========
    ks      1     [0, ∞]  K/S                       R∞      1     [0, 1]
    ======= ===== =============================    ======= ===== ==========

    Computed as ``1 / (1 + ks + sqrt(ks)·sqrt(ks + 2))`` (no cancellation for large K/S, no
    overflow). ``ks = 0`` → 1, ``ks = ∞`` → 0; NaN or negative → NaN.
    """
    k = _f64(ks)
    with np.errstate(all="ignore"):
        out = 1.0 / (1.0 + k + np.sqrt(k) * np.sqrt(k + 2.0))
    return out


def ks_from_r_inf(r_inf: ArrayLike) -> FloatArray:
    """The ratio K/S of an opaque layer from its reflectance: ``K/S = (1 − R∞)² / (2 R∞)``.

    ======= ===== ==================    ======= ===== ==========
    arg     unit  domain                returns unit  range
    ======= ===== ==================    ======= ===== ==========
    r_inf   1     [0, 1]  R∞            ks      1     [0, ∞]
    ======= ===== ==================    ======= ===== ==========

    ``R∞ = 1`` → 0, ``R∞ = 0`` → ∞; NaN or a value outside [0, 1] → NaN.
    """
    r = _f64(r_inf)
    with np.errstate(all="ignore"):
        out = (1.0 - r) ** 2 / (2.0 * r)
        out = np.where(_in01(r), out, np.nan)
    return out


# ---------------------------------------------------------------------------------------------------
# Saunderson correction (surface reflection of a measured sample)
# ---------------------------------------------------------------------------------------------------


def _check_k(k1: ArrayLike, k2: ArrayLike, where: str) -> tuple[FloatArray, FloatArray]:
    k1_ = _f64(k1)
    k2_ = _f64(k2)
    if not (_all_in(k1_, 0.0, 1.0) and _all_in(k2_, 0.0, 1.0)) or (k1_ >= 1.0).any() or (k2_ >= 1.0).any():
        raise KMDomainError(
            f"{where}: Saunderson coefficients must be in [0, 1): got k1={k1_.tolist()}, k2={k2_.tolist()}"
        )
    return k1_, k2_


def saunderson(R: ArrayLike, k1: ArrayLike, k2: ArrayLike) -> FloatArray:
    """Measured reflectance from the internal KM reflectance (Saunderson 1942).

    ``Rm = k1 + (1 − k1)(1 − k2)·R / (1 − k2·R)``

    ======= ===== ===================================================================
    arg     unit  domain
    ======= ===== ===================================================================
    R       1     [0, 1]   KM (internal) reflectance
    k1      1     [0, 1)   external surface reflection (≈ 0.04 for n = 1.5, directional)
    k2      1     [0, 1)   internal surface reflection of diffuse light (≈ 0.4–0.6)
    ======= ===== ===================================================================

    Returns ``Rm`` in [k1, 1] (unit 1). NaN or R outside [0, 1] → NaN; k1 or k2 outside [0, 1)
    raises :class:`KMDomainError` (they are constants, not data).
    """
    R_ = _f64(R)
    k1_, k2_ = _check_k(k1, k2, "saunderson")
    with np.errstate(all="ignore"):
        out = k1_ + (1.0 - k1_) * (1.0 - k2_) * R_ / (1.0 - k2_ * R_)
        out = np.where(_in01(R_), out, np.nan)
    return out


def inverse_saunderson(Rm: ArrayLike, k1: ArrayLike, k2: ArrayLike) -> FloatArray:
    """Internal KM reflectance from a measured one (inverse of :func:`saunderson`).

    ``R = (Rm − k1) / (1 − k1 − k2 + k2·Rm)``

    ======= ===== ================================  ======= ===== ==========================
    arg     unit  domain                            returns unit  range
    ======= ===== ================================  ======= ===== ==========================
    Rm      1     [0, 1] measured reflectance       R       1     [−k1/(1−k1−k2), 1]
    k1, k2  1     [0, 1) as in :func:`saunderson`
    ======= ===== ================================  ======= ===== ==========================

    A measured value below k1 gives a negative (unphysical) internal reflectance; it is returned as
    computed so that :func:`invert_sk` can report it. NaN or Rm outside [0, 1] → NaN.
    """
    Rm_ = _f64(Rm)
    k1_, k2_ = _check_k(k1, k2, "inverse_saunderson")
    with np.errstate(all="ignore"):
        out = (Rm_ - k1_) / (1.0 - k1_ - k2_ + k2_ * Rm_)
        out = np.where(_in01(Rm_), out, np.nan)
    return out


# ---------------------------------------------------------------------------------------------------
# Eq. 6–7: S and K from measurements
# ---------------------------------------------------------------------------------------------------


class SKInversion(tuple[FloatArray, FloatArray]):
    """``(S, K)`` as returned by :func:`invert_sk`; unpacks like a pair and also carries a report.

    Attributes: ``S`` and ``K`` (1/mm), ``invalid`` (bool array of the broadcast shape: True where
    the data were rejected and S, K are NaN; all False unless ``clip=True``) and ``report`` (a
    readable description of the rejected positions; ``""`` when none).
    """

    invalid: NDArray[np.bool_]
    report: str

    def __new__(cls, S: FloatArray, K: FloatArray, invalid: NDArray[np.bool_], report: str) -> SKInversion:
        """The pair ``(S, K)`` carrying its ``invalid`` mask and ``report``."""
        obj = super().__new__(cls, (S, K))
        obj.invalid = invalid
        obj.report = report
        return obj

    @property
    def S(self) -> FloatArray:
        """Scattering coefficient S per mm (the first element)."""
        return self[0]

    @property
    def K(self) -> FloatArray:
        """Absorption coefficient K per mm (the second element)."""
        return self[1]


def _positions(mask: NDArray[np.bool_], wavelengths: FloatArray | None) -> str:
    """Describe where ``mask`` is true: wavelengths (nm) when given, else indices."""
    if wavelengths is not None:
        cols = np.nonzero(mask.reshape(-1, mask.shape[-1]).any(axis=0))[0] if mask.ndim else np.array([0])
        items = [f"{wavelengths[c]:g}" for c in cols]
        unit = " nm"
    else:
        idx = np.argwhere(mask) if mask.ndim else np.zeros((1, 0), dtype=int)
        items = [str(int(i[0])) if len(i) == 1 else str(tuple(int(v) for v in i)) for i in idx]
        unit = ""
        if mask.ndim == 0:
            items = ["()"]
    more = len(items) - _MAX_LISTED
    text = ", ".join(items[:_MAX_LISTED]) + unit
    if more > 0:
        text += f" … and {more} more"
    return ("at " if wavelengths is not None else "at index ") + text


def invert_sk(
    R_inf: ArrayLike,
    R: ArrayLike,
    Rg: ArrayLike,
    D: ArrayLike,
    *,
    clip: bool = False,
    saunderson: tuple[float, float] | None = None,
    wavelengths: ArrayLike | None = None,
) -> SKInversion:
    """Scattering S and absorption K from measured reflectances, Eq. 6–7 (Kubelka's inversion).

    ============ ===== ===========================================================================
    argument     unit  domain
    ============ ===== ===========================================================================
    R_inf        1     (0, 1)   reflectance of an opaque layer of the material
    R            1     strictly between Rg and R_inf: a layer of thickness D over the background
    Rg           1     [0, 1]   reflectance of the background: black (Rg < R∞, as in the paper) or
                                white/light (Rg > R∞, contrast charts)
    D            mm    (0, ∞)   thickness of the thin layer
    clip         -     False: invalid data raise; True: NaN there, listed in ``.invalid``/``.report``
    saunderson   -     ``(k1, k2)``: the three measured reflectances are first converted to internal
                       ones with :func:`inverse_saunderson`; None: used as they are
    wavelengths  nm    optional, the last axis's wavelengths, used to name offending positions
    ============ ===== ===========================================================================

    ============ ===== ===========================================================================
    returns      unit  range
    ============ ===== ===========================================================================
    S            1/mm  (0, ∞)
    K            1/mm  (0, ∞)
    ============ ===== ===========================================================================

    The result is an :class:`SKInversion`: ``S, K = invert_sk(...)`` works, and it also has
    ``.invalid`` (bool mask) and ``.report`` (text).

    Eq. 6 takes ``coth⁻¹`` of ``(a − R)/b``, which is below 1 when the background is lighter than R∞
    (the principal branch is then complex). Writing ``coth⁻¹ x = ½ ln((x + 1)/(x − 1))``, the
    difference of Eq. 6 is the real logarithm of a positive ratio on both sides of R∞ (the ``iπ``
    parts cancel), which simplifies to the cancellation-free form::

        u = (R − Rg)(1 − R∞²) / ((1 − Rg·R∞)(R∞ − R))      (u > 0 for valid data)
        S = R∞ / ((1 − R∞²)·D) · log1p(u),   K = S·(1 − R∞)² / (2 R∞)   (Eq. 7: K = S(a − 1))

    Invalid data (NaN anywhere, R∞ outside (0, 1), Rg outside [0, 1], R not strictly between Rg and
    R∞, D not a finite positive number) raise :class:`KMDomainError` naming every kind of fault and
    the wavelengths at fault (or the indices, without ``wavelengths``).
    """
    ri = _f64(R_inf)
    r = _f64(R)
    rg = _f64(Rg)
    d = _f64(D)
    shape = np.broadcast_shapes(ri.shape, r.shape, rg.shape, d.shape)
    wl: FloatArray | None = None
    if wavelengths is not None:
        wl = _f64(wavelengths).reshape(-1)
        n_last = shape[-1] if shape else 1
        if wl.size != n_last:
            raise KMDomainError(
                f"invert_sk: {wl.size} wavelengths given but the data have {n_last} samples on the last axis"
            )
    with np.errstate(all="ignore"):
        nan_mask = np.broadcast_to(np.isnan(ri) | np.isnan(r) | np.isnan(rg) | np.isnan(d), shape)
    note = ""
    if saunderson is not None:
        try:
            k1, k2 = saunderson
        except (TypeError, ValueError) as exc:
            raise KMDomainError("invert_sk: saunderson must be a pair (k1, k2)") from exc
        ri, r, rg = (inverse_saunderson(x, k1, k2) for x in (ri, r, rg))
        note = f" (after the Saunderson correction k1={float(k1):g}, k2={float(k2):g})"

    with np.errstate(all="ignore"):
        bad_rinf = ~((ri > 0.0) & (ri < 1.0))
        bad_rg = ~((rg >= 0.0) & (rg <= 1.0))
        bad_r = ~(((rg < r) & (r < ri)) | ((ri < r) & (r < rg)))
        bad_d = ~((d > 0.0) & (d < np.inf))
        bad_rinf, bad_rg, bad_r, bad_d = (np.broadcast_to(b, shape) for b in (bad_rinf, bad_rg, bad_r, bad_d))
        invalid = bad_rinf | bad_rg | bad_r | bad_d | nan_mask

        u = (r - rg) * (1.0 - ri * ri) / ((1.0 - rg * ri) * (ri - r))
        L = np.log1p(u)
        S = np.array(np.broadcast_to(ri / ((1.0 - ri * ri) * d) * L, shape), dtype=np.float64)
        K = np.array(np.broadcast_to((1.0 - ri) / (2.0 * (1.0 + ri) * d) * L, shape), dtype=np.float64)

    report = ""
    if invalid.any():
        parts = []
        ok = ~nan_mask
        for name, mask in (
            ("NaN", nan_mask),
            ("R_inf outside (0, 1)", bad_rinf & ok),
            ("Rg outside [0, 1]", bad_rg & ok),
            ("R not strictly between Rg and R_inf", bad_r & ~bad_rinf & ~bad_rg & ok),
            ("D not a finite positive thickness", bad_d & ok),
        ):
            if mask.any():
                parts.append(f"{name} {_positions(mask, wl)}")
        report = f"invalid measurement{note}: " + "; ".join(parts)
        if not clip:
            raise KMDomainError("invert_sk: " + report)
        S[invalid] = np.nan
        K[invalid] = np.nan
    return SKInversion(S, K, np.array(invalid), report)


# ---------------------------------------------------------------------------------------------------
# Duncan's mixing rule
# ---------------------------------------------------------------------------------------------------


def mix(components: Sequence[tuple[ArrayLike, ArrayLike, ArrayLike]]) -> tuple[FloatArray, FloatArray]:
    """S and K of a mixture by Duncan's rule: ``S = Σ cᵢ Sᵢ / Σ cᵢ`` and likewise for K.

    ``components`` is a sequence of ``(concentration, S, K)``; the concentrations are normalised to
    sum to 1 (pass fractions, percentages or parts, whichever is handy). All arrays broadcast
    (concentrations may be per-texel arrays).

    ============== ===== =======================================
    argument       unit  domain
    ============== ===== =======================================
    concentration  1     [0, ∞), finite; the sum must be > 0
    S, K           1/mm  [0, ∞)
    ============== ===== =======================================

    Returns ``(S, K)`` in 1/mm, broadcast shape.

    Raises :class:`KMDomainError` for an empty sequence, a component that is not a triple, a
    negative, infinite or NaN concentration, concentrations summing to zero, or a negative S or K.
    NaN in S or K gives NaN in the result at that position (forward rule).
    """
    items = list(components)
    if not items:
        raise KMDomainError("mix: no components")
    cs, Ss, Ks = [], [], []
    for i, comp in enumerate(items):
        try:
            c, s, k = comp
        except (TypeError, ValueError) as exc:
            raise KMDomainError(f"mix: component {i} is not a (concentration, S, K) triple") from exc
        c_, s_, k_ = _f64(c), _f64(s), _f64(k)
        if not (np.isfinite(c_).all() and (c_ >= 0.0).all()):
            raise KMDomainError(f"mix: component {i} has a negative, infinite or NaN concentration")
        if (s_ < 0.0).any() or (k_ < 0.0).any():
            raise KMDomainError(f"mix: component {i} has a negative S or K")
        cs.append(c_)
        Ss.append(s_)
        Ks.append(k_)
    total = sum(cs[1:], start=cs[0])
    if (total <= 0.0).any():
        raise KMDomainError("mix: the concentrations sum to zero")
    with np.errstate(all="ignore"):
        S = sum((c * s for c, s in zip(cs, Ss)), start=np.zeros(())) / total
        K = sum((c * k for c, k in zip(cs, Ks)), start=np.zeros(())) / total
    return np.asarray(S, dtype=np.float64), np.asarray(K, dtype=np.float64)
