"""Kubelka–Munk optics: reference values, limits, n-d inputs, nan/inf, domain errors, round trips.

References are computed independently of the implementation: Eq. 1–2 and Eq. 6 as printed in the
paper (sinh/cosh, coth⁻¹), evaluated with 60-digit ``decimal`` arithmetic or with complex ``cmath``,
and closed forms for the limits.
"""

from __future__ import annotations

import cmath
import itertools
import math
import warnings
from decimal import Decimal, localcontext
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

import km
from core.errors import SheerError
from km.optics import (
    KMDomainError,
    SKInversion,
    inverse_saunderson,
    invert_sk,
    ks_from_r_inf,
    layer_rt,
    mix,
    over,
    r_inf_from_ks,
    saunderson,
    stack,
)

if TYPE_CHECKING:
    from collections.abc import Callable

RTOL = 1e-13  # forward formulas against 60-digit references
RTOL_ROUND_TRIP = 1e-9  # the bound for inversions on well-conditioned data
SPECIALS = [-1.0, 0.0, 1.0, -np.inf, np.inf, np.nan]


def eq12_decimal(S: float, K: float, X: float) -> tuple[float, float]:
    """Eq. 1–2 of the paper, as printed, in 60-digit decimal arithmetic (S > 0)."""
    with localcontext() as ctx:
        ctx.prec = 60
        S_, K_, X_ = (Decimal(repr(float(v))) for v in (S, K, X))
        a = 1 + K_ / S_
        b = (a * a - 1).sqrt()
        y = b * S_ * X_
        sinh = (y.exp() - (-y).exp()) / 2
        cosh = (y.exp() + (-y).exp()) / 2
        den = a * sinh + b * cosh
        return float(sinh / den), float(b / den)


def r_inf_decimal(ks: float) -> float:
    """R∞ = 1 + K/S − sqrt((K/S)² + 2K/S) as written, with enough digits to survive the cancellation."""
    with localcontext() as ctx:
        ctx.prec = 700
        k = Decimal(repr(float(ks)))
        return float(1 + k - (k * k + 2 * k).sqrt())


def strict(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """Call ``fn`` with every numpy floating-point warning (and any warning) turned into an error."""
    with np.errstate(all="raise"), warnings.catch_warnings():
        warnings.simplefilter("error")
        return fn(*args, **kwargs)


# --------------------------------------------------------------------------------------------------
# layer_rt
# --------------------------------------------------------------------------------------------------

CASES = [
    (1.0, 1.0, 1.0),
    (10.0, 0.5, 0.02),
    (100.0, 3.0, 0.15),
    (0.3, 7.0, 2.0),
    (50.0, 1e-9, 0.1),
    (1e-9, 5.0, 0.1),
    (1e-3, 1e-3, 1e-3),
    (3.0, 1e-14, 0.2),
    (2e3, 1e-5, 0.05),
    (40.0, 12.0, 0.004),
]


@pytest.mark.parametrize(("S", "K", "X"), CASES)
def test_layer_rt_matches_eq_1_2_in_high_precision(S: float, K: float, X: float) -> None:
    R0, T = layer_rt(S, K, X)
    R_ref, T_ref = eq12_decimal(S, K, X)
    np.testing.assert_allclose(R0, R_ref, rtol=RTOL, atol=0)
    np.testing.assert_allclose(T, T_ref, rtol=RTOL, atol=0)


def test_layer_rt_thick_layer_keeps_relative_accuracy_of_tiny_transmittance() -> None:
    R0, T = layer_rt(5.0, 2.0, 30.0)  # bSX ≈ 147: T ≈ 1e-64
    R_ref, T_ref = eq12_decimal(5.0, 2.0, 30.0)
    np.testing.assert_allclose(R0, R_ref, rtol=RTOL)
    np.testing.assert_allclose(T, T_ref, rtol=200 * 2.2e-16)  # condition number of exp(−y) is y


def test_pure_absorber_S0_is_exact() -> None:
    K = np.array([0.0, 1e-300, 1e-6, 0.5, 3.0, 1e3])
    R0, T = strict(layer_rt, 0.0, K, 0.7)
    assert np.all(R0 == 0.0)
    np.testing.assert_allclose(T, np.exp(-K * 0.7), rtol=2e-16, atol=0)


def test_pure_scatterer_K0_is_exact() -> None:
    S = np.array([0.0, 1e-300, 1e-6, 0.5, 3.0, 1e3, 1e200])
    X = 0.3
    R0, T = strict(layer_rt, S, 0.0, X)
    SX = S * X
    np.testing.assert_allclose(R0, SX / (1 + SX), rtol=2e-16, atol=0)
    np.testing.assert_allclose(T, 1 / (1 + SX), rtol=2e-16, atol=0)


def test_zero_thickness_is_transparent() -> None:
    R0, T = strict(layer_rt, [0.0, 1.0, 50.0, 0.0, 1e6], [0.0, 1.0, 0.0, 5.0, 1e6], 0.0)
    np.testing.assert_array_equal(R0, 0.0)
    np.testing.assert_array_equal(T, 1.0)


@pytest.mark.parametrize(("S", "K", "X"), [(1e6, 1.0, 1e3), (1.0, 1e5, 10.0), (300.0, 20.0, 50.0),
                                           (1e12, 1e3, 1e6), (2.0, 1e-12, 1e9)])
def test_very_thick_or_scattering_layers_tend_to_r_inf_without_overflow(
        S: float, K: float, X: float) -> None:
    R0, T = strict(layer_rt, S, K, X)  # sinh(bSX) would overflow for all of these
    assert np.isfinite(R0) and np.isfinite(T)
    np.testing.assert_allclose(R0, r_inf_decimal(K / S), rtol=1e-12)
    assert T < 1e-300


def test_continuous_as_S_or_K_tends_to_zero() -> None:
    eps = 10.0 ** -np.arange(8, 300, 7.0)
    # S → 0 at K = 2, X = 0.4: R0 → 0 (R0 ≈ S·(1 − e^{−2KX})/(2K)) and T → exp(−KX)
    R0, T = strict(layer_rt, eps, 2.0, 0.4)
    np.testing.assert_allclose(R0, eps * (1 - math.exp(-1.6)) / 4.0, rtol=1e-6)
    assert np.all(np.abs(T - math.exp(-0.8)) <= 2.0 * eps + 2e-16)
    assert strict(layer_rt, 1e-310, 2.0, 0.4)[0] < 1e-309  # below the normal range: absolute accuracy
    # K → 0 at S = 3, X = 0.5: R0 → SX/(1+SX) = 0.6 and T → 0.4, the change is O(K)
    R0, T = strict(layer_rt, 3.0, eps, 0.5)
    assert np.all(np.abs(R0 - 0.6) <= eps + 2e-16)
    assert np.all(np.abs(T - 0.4) <= eps + 2e-16)
    R_ref = [eq12_decimal(3.0, k, 0.5)[0] for k in (1e-3, 1e-8)]
    np.testing.assert_allclose(strict(layer_rt, 3.0, [1e-3, 1e-8], 0.5)[0], R_ref, rtol=RTOL)


def test_layer_rt_energy_is_conserved_only_without_absorption() -> None:
    rng = np.random.default_rng(1)
    S, X = rng.uniform(0, 100, 200), rng.uniform(0, 1, 200)
    R0, T = layer_rt(S, 0.0, X)
    np.testing.assert_allclose(R0 + T, 1.0, rtol=1e-15)
    R0, T = layer_rt(S, rng.uniform(0.1, 10, 200), X)
    assert np.all(R0 + T < 1.0) and np.all(R0 >= 0) and np.all(T > 0)


def test_layer_rt_n_dimensional_equals_1d() -> None:
    rng = np.random.default_rng(2)
    S = rng.uniform(0, 80, (3, 4, 81))
    K = rng.uniform(0, 10, (3, 4, 81))
    X = rng.uniform(0, 0.2, (3, 4, 1))
    R0, T = layer_rt(S, K, X)
    assert R0.shape == T.shape == (3, 4, 81)
    for i, j in itertools.product(range(3), range(4)):
        r, t = layer_rt(S[i, j], K[i, j], X[i, j, 0])
        np.testing.assert_array_equal(R0[i, j], r)
        np.testing.assert_array_equal(T[i, j], t)
    r, t = layer_rt(float(S[1, 2, 5]), float(K[1, 2, 5]), float(X[1, 2, 0]))
    assert np.ndim(r) == 0 and r == R0[1, 2, 5] and t == T[1, 2, 5]


def test_layer_rt_broadcasts_spectra_against_thickness_maps() -> None:
    S, K = np.linspace(1, 50, 81), np.linspace(0.1, 5, 81)
    X = np.linspace(0, 0.1, 6)[:, None]
    R0, T = layer_rt(S, K, X)
    assert R0.shape == (6, 81)
    np.testing.assert_array_equal(R0[3], layer_rt(S, K, X[3, 0])[0])


def _layer_rt_expected_nan(S: float, K: float, X: float) -> bool:
    """The documented NaN cases of layer_rt."""
    if any(math.isnan(v) or v < 0 for v in (S, K, X)):
        return True
    if X == 0 and (math.isinf(S) or math.isinf(K)):
        return True
    return math.isinf(S) and math.isinf(K)


def test_layer_rt_nan_inf_robustness() -> None:
    for S, K, X in itertools.product(SPECIALS, repeat=3):
        R0, T = strict(layer_rt, S, K, X)
        if _layer_rt_expected_nan(S, K, X):
            assert np.isnan(R0) and np.isnan(T), (S, K, X, R0, T)
        else:
            assert 0.0 <= R0 <= 1.0 and 0.0 <= T <= 1.0, (S, K, X, R0, T)
    # the documented limits
    np.testing.assert_allclose(strict(layer_rt, 1.0, 1.0, np.inf), (r_inf_decimal(1.0), 0.0), rtol=1e-15)
    assert strict(layer_rt, np.inf, 1.0, 1.0) == (1.0, 0.0)
    assert strict(layer_rt, 1.0, np.inf, 1.0) == (0.0, 0.0)
    assert strict(layer_rt, 0.0, 0.0, np.inf) == (0.0, 1.0)
    assert strict(layer_rt, 1.0, 0.0, np.inf) == (1.0, 0.0)
    # the same in one vectorised call
    combos = np.array(list(itertools.product(SPECIALS, repeat=3))).T
    R0, T = strict(layer_rt, *combos)
    for n, (S, K, X) in enumerate(combos.T):
        r, t = strict(layer_rt, S, K, X)
        np.testing.assert_array_equal([R0[n], T[n]], [r, t])


# --------------------------------------------------------------------------------------------------
# over and stack
# --------------------------------------------------------------------------------------------------


def test_over_closed_form() -> None:
    assert over(0.2, 0.5, 0.4) == pytest.approx(0.2 + 0.25 * 0.4 / (1 - 0.2 * 0.4), rel=1e-15)
    assert over(0.2, 0.5, 0.4, R_bottom=0.6) == pytest.approx(0.2 + 0.25 * 0.4 / (1 - 0.6 * 0.4), rel=1e-15)
    assert over(0.3, 0.6, 0.0) == 0.3
    assert over(0.0, 1.0, 0.45) == pytest.approx(0.45, rel=1e-15)  # a clear layer


def test_over_single_layer_equals_km_layer_over_background() -> None:
    """Kubelka's closed form for a layer over a background (Kortüm), independent of Eq. 3."""
    S, K, X, Rg = 20.0, 2.0, 0.05, 0.35
    a = 1 + K / S
    b = math.sqrt(a * a - 1)
    bsx = b * S * X
    coth = math.cosh(bsx) / math.sinh(bsx)
    R_ref = (1 - Rg * (a - b * coth)) / (a - Rg + b * coth)
    R0, T = layer_rt(S, K, X)
    assert over(R0, T, Rg) == pytest.approx(R_ref, rel=1e-13)


def test_over_nan_inf_robustness() -> None:
    for R, T, Rg, Rb in itertools.product(SPECIALS, repeat=4):
        out = strict(over, R, T, Rg, Rb)
        valid = all(0.0 <= v <= 1.0 for v in (R, T, Rg, Rb))  # False for NaN
        if not valid or (Rb * Rg == 1.0 and T != 0.0):
            assert np.isnan(out), (R, T, Rg, Rb, out)
        else:
            assert np.isfinite(out), (R, T, Rg, Rb, out)
    assert strict(over, 1.0, 0.0, 1.0) == 1.0  # a mirror over a mirror, nothing transmitted


def test_over_n_dimensional_equals_1d() -> None:
    rng = np.random.default_rng(3)
    R, T, Rg = (rng.uniform(0, 0.5, (2, 5, 81)) for _ in range(3))
    out = over(R, T, Rg)
    for i, j in itertools.product(range(2), range(5)):
        np.testing.assert_array_equal(out[i, j], over(R[i, j], T[i, j], Rg[i, j]))


def _materials() -> list[tuple[float, float, float]]:
    return [(40.0, 0.8, 0.02), (5.0, 9.0, 0.01), (120.0, 0.2, 0.03), (15.0, 3.0, 0.05)]


def test_stack_equals_nested_over_for_unequal_layers() -> None:
    layers = [layer_rt(S, K, X) for S, K, X in _materials()]
    for n in (2, 3, 4):
        R_top, R_bottom, T = stack(layers[:n])
        for Rg in (0.0, 0.2, 0.55, 0.9, 1.0):
            nested = Rg
            for R0, T0 in reversed(layers[:n]):
                nested = over(R0, T0, nested)
            assert over(R_top, T, Rg, R_bottom=R_bottom) == pytest.approx(float(nested), rel=1e-14)
    R_top, R_bottom, T = stack(layers)
    assert abs(R_top - R_bottom) > 1e-3  # an asymmetric stack
    # using R_top alone in the denominator is wrong for unequal layers
    assert abs(over(R_top, T, 0.5) - over(R_top, T, 0.5, R_bottom=R_bottom)) > 1e-4


def test_stack_two_layers_is_corrected_eq_3_4() -> None:
    (R1, T1), (R2, T2) = layer_rt(40.0, 0.8, 0.02), layer_rt(5.0, 9.0, 0.01)
    R_top, R_bottom, t12 = stack([(R1, T1), (R2, T2)])
    d = 1 - R1 * R2
    assert R_top == pytest.approx(R1 + T1 * R2 * T1 / d, rel=1e-15)  # T1·R2·T1, not the printed T1·R1·T1
    assert R_bottom == pytest.approx(R2 + T2 * R1 * T2 / d, rel=1e-15)
    assert t12 == pytest.approx(T1 * T2 / d, rel=1e-15)


def test_stack_of_two_slices_of_one_material_is_the_thick_layer() -> None:
    S, K = np.linspace(1, 90, 81), np.linspace(0.05, 12, 81)
    R_top, R_bottom, T = stack([layer_rt(S, K, 0.013), layer_rt(S, K, 0.029), layer_rt(S, K, 0.008)])
    R_ref, T_ref = layer_rt(S, K, 0.05)
    np.testing.assert_allclose(R_top, R_ref, rtol=1e-13)
    np.testing.assert_allclose(R_bottom, R_ref, rtol=1e-13)
    np.testing.assert_allclose(T, T_ref, rtol=1e-13)


def test_stack_identity_single_and_order() -> None:
    assert tuple(map(float, stack([]))) == (0.0, 0.0, 1.0)
    R, T = layer_rt(10.0, 1.0, 0.1)
    np.testing.assert_array_equal(stack([(R, T)]), (R, R, T))
    a, b = layer_rt(40.0, 0.8, 0.02), layer_rt(5.0, 9.0, 0.01)
    top_ab, bottom_ab, T_ab = stack([a, b])
    top_ba, bottom_ba, T_ba = stack([b, a])
    assert top_ab == pytest.approx(bottom_ba, rel=1e-15) and bottom_ab == pytest.approx(top_ba, rel=1e-15)
    assert T_ab == pytest.approx(T_ba, rel=1e-15)
    with pytest.raises(KMDomainError, match="layer 1"):
        stack([a, (0.1, 0.2, 0.3)])  # type: ignore[list-item]


def test_stack_n_dimensional_and_broadcast() -> None:
    rng = np.random.default_rng(4)
    X = rng.uniform(0, 0.05, (3, 7, 1))
    layers = [layer_rt(np.full(81, S), np.full(81, K), X * f) for (S, K, _), f in zip(_materials(), (1, 2, 0.5))]
    R_top, R_bottom, T = stack(layers)
    assert R_top.shape == (3, 7, 81)
    i, j = 2, 4
    one = stack([(r[i, j], t[i, j]) for r, t in layers])
    for full, part in zip((R_top, R_bottom, T), one):
        np.testing.assert_array_equal(full[i, j], part)


def test_stack_nan_inf_robustness() -> None:
    for r1, t1, r2, t2 in itertools.product(SPECIALS, repeat=4):
        R_top, R_bottom, T = strict(stack, [(r1, t1), (r2, t2)])
        valid = all(0.0 <= v <= 1.0 for v in (r1, t1, r2, t2))
        if not valid:
            assert np.isnan(R_top) and np.isnan(R_bottom) and np.isnan(T), (r1, t1, r2, t2)
        elif r1 == 1.0 and r2 == 1.0:  # two facing mirrors: only what never enters the gap is defined
            assert (R_top == 1.0) if t1 == 0.0 else np.isnan(R_top)
            assert (R_bottom == 1.0) if t2 == 0.0 else np.isnan(R_bottom)
            assert (T == 0.0) if (t1 == 0.0 or t2 == 0.0) else np.isnan(T)
        else:
            assert np.isfinite(R_top) and np.isfinite(R_bottom) and np.isfinite(T), (r1, t1, r2, t2)


# --------------------------------------------------------------------------------------------------
# invert_sk
# --------------------------------------------------------------------------------------------------


def eq6_complex(R_inf: float, R: float, Rg: float, D: float) -> tuple[float, float]:
    """Eq. 6–7 as printed, with coth⁻¹ x = ½ log((x+1)/(x−1)) in complex arithmetic (real part)."""
    a = 0.5 * (1 / R_inf + R_inf)
    b = math.sqrt(a * a - 1)

    def acoth(x: float) -> complex:
        return 0.5 * cmath.log((x + 1) / (x - 1))

    diff = acoth((a - R) / b) - acoth((a - Rg) / b)
    assert abs(diff.imag) < 1e-12  # the iπ parts cancel
    S = diff.real / (b * D)
    return S, S * (a - 1)


SK_CASES = [(40.0, 0.8), (5.0, 9.0), (120.0, 0.2), (15.0, 3.0), (1.0, 1.0), (300.0, 30.0)]


@pytest.mark.parametrize("Rg", [0.0, 0.03, 0.5, 0.85, 1.0])
@pytest.mark.parametrize(("S", "K"), SK_CASES)
def test_invert_sk_round_trip_black_and_white(S: float, K: float, Rg: float) -> None:
    D = 0.15 if S < 100 else 0.01
    R0, T = layer_rt(S, K, D)
    R = over(R0, T, Rg)
    R_inf = r_inf_from_ks(K / S)
    # every case is well-conditioned: the layer is neither (almost) opaque nor (almost) invisible here
    assert abs(R - Rg) >= 1e-3 and abs(R_inf - R) >= 1e-3
    S_inv, K_inv = invert_sk(R_inf, R, Rg, D)
    assert S_inv == pytest.approx(S, rel=RTOL_ROUND_TRIP)
    assert K_inv == pytest.approx(K, rel=RTOL_ROUND_TRIP)
    S_ref, K_ref = eq6_complex(float(R_inf), float(R), Rg, D)
    assert S_inv == pytest.approx(S_ref, rel=1e-9) and K_inv == pytest.approx(K_ref, rel=1e-9)


def test_invert_sk_spectral_n_dimensional_round_trip_over_white() -> None:
    wl = np.arange(380, 781, 5.0)
    S = 30 + 20 * np.sin(wl / 50.0) ** 2
    K = 0.5 + 4 * np.exp(-0.5 * ((wl - 550) / 40) ** 2)
    D = np.array([[0.05], [0.1], [0.15]])
    Rg = np.array([[[0.02]], [[0.9]]])  # black and white contrast chart
    R0, T = layer_rt(S, K, D)
    R = over(R0, T, Rg)
    assert R.shape == (2, 3, 81)
    result = invert_sk(r_inf_from_ks(K / S), R, Rg, D, wavelengths=wl)
    assert isinstance(result, SKInversion) and not result.invalid.any() and result.report == ""
    np.testing.assert_allclose(result.S, np.broadcast_to(S, R.shape), rtol=RTOL_ROUND_TRIP)
    np.testing.assert_allclose(result.K, np.broadcast_to(K, R.shape), rtol=RTOL_ROUND_TRIP)
    S1, K1 = invert_sk(r_inf_from_ks(K / S), R[1, 2], 0.9, 0.15)
    np.testing.assert_array_equal(S1, result.S[1, 2])


def test_invert_sk_with_saunderson_round_trip() -> None:
    S, K, D, k1, k2 = np.array([20.0, 60.0]), np.array([2.0, 0.4]), 0.1, 0.04, 0.6
    R0, T = layer_rt(S, K, D)
    Rg_int = np.array([0.01, 0.8])
    R_int = over(R0, T, Rg_int)
    Rinf_int = r_inf_from_ks(K / S)
    measured = [saunderson(v, k1, k2) for v in (Rinf_int, R_int, Rg_int)]
    S_inv, K_inv = invert_sk(*measured, D, saunderson=(k1, k2))
    np.testing.assert_allclose(S_inv, S, rtol=RTOL_ROUND_TRIP)
    np.testing.assert_allclose(K_inv, K, rtol=RTOL_ROUND_TRIP)
    S_raw, _ = invert_sk(*measured, D)  # without the correction the answer is different
    assert not np.allclose(S_raw, S, rtol=1e-3)


def test_invert_sk_errors_name_the_wavelengths() -> None:
    wl = [400.0, 405.0, 410.0, 415.0, 420.0]
    R_inf = [0.5, 1.2, 0.5, 0.5, 0.5]
    R = [0.3, 0.3, 0.6, np.nan, 0.3]
    with pytest.raises(KMDomainError) as info:
        invert_sk(R_inf, R, 0.0, 0.1, wavelengths=wl)
    msg = str(info.value)
    assert isinstance(info.value, ValueError) and isinstance(info.value, SheerError)
    assert "R_inf outside (0, 1) at 405 nm" in msg
    assert "R not strictly between Rg and R_inf at 410 nm" in msg
    assert "NaN at 415 nm" in msg
    assert "400" not in msg and "420" not in msg
    with pytest.raises(KMDomainError, match=r"index 1\b"):
        invert_sk(R_inf, R, 0.0, 0.1)
    with pytest.raises(KMDomainError, match="D not a finite positive thickness at 400, 405"):
        invert_sk(0.5, 0.3, 0.0, [0.0, -1.0, 0.1], wavelengths=[400, 405, 410])
    with pytest.raises(KMDomainError, match="between"):
        invert_sk(0.5, 0.2, 0.2, 0.1)  # R equals Rg
    with pytest.raises(KMDomainError, match="between"):
        invert_sk(0.5, 0.7, 0.6, 0.1)  # white background but R outside (R∞, Rg)
    with pytest.raises(KMDomainError, match="3 wavelengths given"):
        invert_sk([0.5, 0.5], [0.3, 0.3], 0.0, 0.1, wavelengths=[400, 405, 410])


def test_invert_sk_clip_returns_nan_and_reports() -> None:
    wl = [400.0, 405.0, 410.0]
    result = invert_sk([0.5, 1.2, 0.5], [0.3, 0.3, 0.6], 0.0, 0.1, clip=True, wavelengths=wl)
    S, K = result
    np.testing.assert_array_equal(result.invalid, [False, True, True])
    assert np.isfinite(S[0]) and np.isnan(S[1:]).all() and np.isnan(K[1:]).all()
    assert "405 nm" in result.report and "410 nm" in result.report
    S_ok, K_ok = invert_sk(0.5, 0.3, 0.0, 0.1)
    assert S[0] == S_ok and K[0] == K_ok


def test_invert_sk_nan_inf_robustness() -> None:
    values = [-1.0, 0.0, 0.3, 0.6, 1.0, -np.inf, np.inf, np.nan]
    for ri, r, rg, d in itertools.product(values, repeat=4):
        result = strict(invert_sk, ri, r, rg, d, clip=True)
        valid = (0 < ri < 1) and (0 <= rg <= 1) and (rg < r < ri or ri < r < rg) and (0 < d < np.inf)
        if valid:
            assert not result.invalid and result.S > 0 and result.K > 0 and np.isfinite(result.S)
        else:
            assert result.invalid and np.isnan(result.S) and np.isnan(result.K) and result.report
            with pytest.raises(KMDomainError):
                strict(invert_sk, ri, r, rg, d)


# --------------------------------------------------------------------------------------------------
# R∞ ↔ K/S, Saunderson, mix
# --------------------------------------------------------------------------------------------------


def test_r_inf_and_ks_reference_and_round_trip() -> None:
    ks = np.array([0.0, 1e-12, 1e-6, 0.02, 0.5, 1.0, 7.0, 1e6, 1e12, 1e300])
    ref = [r_inf_decimal(k) for k in ks]
    np.testing.assert_allclose(strict(r_inf_from_ks, ks), ref, rtol=1e-14)
    assert strict(r_inf_from_ks, np.inf) == 0.0
    r = np.array([1e-9, 0.01, 0.2, 0.5, 0.9, 1.0])
    np.testing.assert_allclose(strict(ks_from_r_inf, r), (1 - r) ** 2 / (2 * r), rtol=1e-15)
    np.testing.assert_allclose(strict(r_inf_from_ks, strict(ks_from_r_inf, r)), r, rtol=1e-12)
    assert strict(ks_from_r_inf, 0.0) == np.inf
    # K/S of layer_rt's opaque limit
    assert strict(layer_rt, 12.0, 3.0, np.inf)[0] == pytest.approx(strict(r_inf_from_ks, 0.25), rel=1e-15)


def test_r_inf_and_ks_nan_inf_robustness() -> None:
    out = strict(r_inf_from_ks, SPECIALS)
    np.testing.assert_array_equal(out, [np.nan, 1.0, strict(r_inf_from_ks, 1.0), np.nan, 0.0, np.nan])
    out = strict(ks_from_r_inf, SPECIALS)
    np.testing.assert_array_equal(out, [np.nan, np.inf, 0.0, np.nan, np.nan, np.nan])


def test_saunderson_closed_form_round_trip_and_domain() -> None:
    k1, k2 = 0.04, 0.6
    R = np.array([0.0, 0.1, 0.5, 1.0])
    Rm = strict(saunderson, R, k1, k2)
    np.testing.assert_allclose(Rm, k1 + (1 - k1) * (1 - k2) * R / (1 - k2 * R), rtol=1e-15)
    assert Rm[0] == pytest.approx(k1) and Rm[-1] == pytest.approx(1.0)
    np.testing.assert_allclose(strict(inverse_saunderson, Rm, k1, k2), R, atol=1e-15)
    assert strict(saunderson, 0.3, 0.0, 0.0) == 0.3
    np.testing.assert_array_equal(np.isnan(strict(saunderson, SPECIALS, k1, k2)), [1, 0, 0, 1, 1, 1])
    np.testing.assert_array_equal(np.isnan(strict(inverse_saunderson, SPECIALS, k1, k2)), [1, 0, 0, 1, 1, 1])
    with pytest.raises(KMDomainError, match="Saunderson"):
        strict(saunderson, 0.3, 1.0, 0.5)
    with pytest.raises(KMDomainError, match="Saunderson"):
        strict(inverse_saunderson, 0.3, 0.04, np.nan)


def test_mix_duncan_rule() -> None:
    S1, K1 = np.array([10.0, 20.0]), np.array([1.0, 2.0])
    S2, K2 = np.array([30.0, 0.0]), np.array([0.0, 8.0])
    S, K = mix([(1.0, S1, K1), (3.0, S2, K2)])
    np.testing.assert_allclose(S, 0.25 * S1 + 0.75 * S2, rtol=1e-15)
    np.testing.assert_allclose(K, 0.25 * K1 + 0.75 * K2, rtol=1e-15)
    S_pct, _ = mix([(25.0, S1, K1), (75.0, S2, K2)])
    np.testing.assert_allclose(S_pct, S, rtol=1e-15)
    np.testing.assert_array_equal(mix([(0.4, S1, K1)])[0], S1)
    c = np.array([[0.0], [0.5], [1.0]])  # per-texel concentrations
    S_map, _ = mix([(c, S1, K1), (1 - c, S2, K2)])
    assert S_map.shape == (3, 2)
    np.testing.assert_allclose(S_map[0], S2) and np.testing.assert_allclose(S_map[2], S1)


@pytest.mark.parametrize(("components", "match"), [
    ([], "no components"),
    ([(1.0, 1.0)], "triple"),
    ([(-1.0, 1.0, 1.0), (2.0, 1.0, 1.0)], "component 0"),
    ([(1.0, 1.0, 1.0), (np.nan, 1.0, 1.0)], "component 1"),
    ([(np.inf, 1.0, 1.0)], "component 0"),
    ([(0.0, 1.0, 1.0), (0.0, 2.0, 2.0)], "sum to zero"),
    ([(1.0, -1.0, 1.0)], "negative S or K"),
])
def test_mix_validation(components: list, match: str) -> None:
    with pytest.raises(KMDomainError, match=match):
        mix(components)


def test_mix_nan_propagates() -> None:
    S, K = mix([(1.0, [1.0, np.nan], [1.0, 1.0]), (1.0, [3.0, 1.0], [1.0, 1.0])])
    assert S[0] == 2.0 and np.isnan(S[1]) and np.all(K == 1.0)


def test_public_names_are_exported_lazily() -> None:
    for name in ("KMDomainError", "layer_rt", "over", "stack", "invert_sk", "mix", "r_inf_from_ks",
                 "ks_from_r_inf", "saunderson", "inverse_saunderson"):
        assert getattr(km, name) is getattr(__import__("km.optics", fromlist=[name]), name)
