"""The biophysical skin model: sanity of the spectra, its range of skin tones, the fit's round trip, and an
independent check by adding-doubling (iadpython)."""

from __future__ import annotations

import math

import iadpython as iad
import numpy as np
import pytest

import km.skin as ks
from km.colour import delta_e2000
from km.optics import layer_rt, over, saunderson
from km.skin import (
    PARAM_RANGES,
    SkinError,
    SkinParams,
    fit_skin,
    ita_degrees,
    lab_of,
    skin_coefficients,
    skin_reflectance,
)
from km.spectra import DEFAULT_GRID, WavelengthGrid

WL = DEFAULT_GRID.wavelengths


def _random_params(rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
    out = {}
    for name, (lo, hi) in PARAM_RANGES.items():
        if name in ("melanin", "blood", "scattering"):
            out[name] = np.exp(rng.uniform(math.log(lo), math.log(hi), n))
        else:
            out[name] = rng.uniform(lo, hi, n)
    return out


def test_reflectance_is_a_fraction_everywhere_in_the_parameter_ranges() -> None:
    p = _random_params(np.random.default_rng(0), 400)
    corners = np.array(np.meshgrid(*[PARAM_RANGES[k] for k in PARAM_RANGES], indexing="ij")).reshape(5, -1)
    args = {k: np.concatenate([p[k], corners[i]]) for i, k in enumerate(PARAM_RANGES)}
    R = skin_reflectance(args["melanin"], args["blood"], args["oxygenation"], args["scattering"],
                         pheomelanin=args["pheomelanin"])
    assert R.shape == (400 + 32, len(WL))
    assert np.isfinite(R).all()
    assert R.min() > 0.0 and R.max() < 1.0


def test_more_melanin_darkens_at_every_wavelength() -> None:
    melanin = np.geomspace(*PARAM_RANGES["melanin"], 30)
    for blood, pheo in ((0.002, 0.0), (0.02, 0.3), (0.07, 1.0)):
        R = skin_reflectance(melanin, blood, pheomelanin=pheo)
        assert (np.diff(R, axis=0) < 0).all()
        assert (np.diff(lab_of(R)[:, 0]) < 0).all()


def _local_minima(values: np.ndarray) -> np.ndarray:
    return np.flatnonzero((values[1:-1] < values[:-2]) & (values[1:-1] < values[2:])) + 1


def test_blood_makes_the_haemoglobin_dips_near_542_and_577_nm() -> None:
    grid = WavelengthGrid(500.0, 620.0, 1.0)
    wl = grid.wavelengths
    with_blood = skin_reflectance(0.02, 0.04, oxygenation=0.9, grid=grid)
    dips = wl[_local_minima(with_blood)]
    assert any(abs(d - 542) <= 4 for d in dips), dips
    assert any(abs(d - 577) <= 4 for d in dips), dips
    # they are the blood's: relative to a nearly bloodless skin, blood takes most near the two bands,
    # and more the more blood
    bloodless = skin_reflectance(0.02, PARAM_RANGES["blood"][0], oxygenation=0.9, grid=grid)
    ratios = [skin_reflectance(0.02, b, oxygenation=0.9, grid=grid) / bloodless for b in (0.005, 0.02, 0.04)]
    for ratio in ratios:
        minima = wl[_local_minima(ratio)]
        assert any(abs(d - 542) <= 4 for d in minima) and any(abs(d - 577) <= 4 for d in minima), minima
    at_bands = [float(r[wl == 542.0][0]) for r in ratios]
    assert at_bands == sorted(at_bands, reverse=True) and at_bands[-1] < 0.85


def test_the_model_spans_very_light_to_dark_skin_tones() -> None:
    light = lab_of(skin_reflectance(PARAM_RANGES["melanin"][0], 0.005))
    dark = lab_of(skin_reflectance(0.3, 0.01))
    assert ita_degrees(light) > 55.0
    assert ita_degrees(dark) < -30.0
    # ITA falls steadily between them
    ita = ita_degrees(lab_of(skin_reflectance(np.geomspace(PARAM_RANGES["melanin"][0], 0.3, 20), 0.01)))
    assert (np.diff(ita) < 0).all()


def test_parameters_broadcast_like_numpy() -> None:
    m = np.array([[0.01, 0.05, 0.2], [0.02, 0.1, 0.4]])
    b = np.array([[0.005], [0.03]])
    R = skin_reflectance(m, b, 0.7, 1.2)
    assert R.shape == (2, 3, len(WL))
    for i in range(2):
        for j in range(3):
            np.testing.assert_allclose(R[i, j], SkinParams(m[i, j], b[i, 0], 0.7, 1.2).reflectance(), rtol=1e-14)


def test_constants_and_units() -> None:
    # Jacques' melanin at 500 nm: 6.6e11 · 500^-3.33 cm^-1 ≈ 6.6 /mm (per mm in km)
    c = skin_coefficients(1.0, 0.0, pheomelanin=0.0, grid=WavelengthGrid.from_wavelengths([500.0]))
    assert c["mua_epidermis"][0] == pytest.approx(6.6e11 * 500.0**-3.33 / 10.0, rel=1e-12)
    # whole blood at its 415 nm Soret peak absorbs thousands per cm (hundreds per mm)
    oxy, _ = ks.haemoglobin_absorption(WavelengthGrid.from_wavelengths([414.0]))
    assert 200.0 < oxy[0] < 400.0
    # Judd's internal diffuse reflectance: ≈ 0.596 for n = 1.5 (the textbook value), ≈ 0.53 for skin
    assert ks._surface_k2(1.5) == pytest.approx(0.596, abs=0.002)
    assert abs(ks.SURFACE_K2 - 0.529) < 0.002


def test_params_out_of_range_are_refused() -> None:
    with pytest.raises(SkinError, match="melanin must be a number in"):
        SkinParams(0.9, 0.01)
    with pytest.raises(SkinError, match="blood"):
        SkinParams(0.05, float("nan"))


def test_round_trip_at_the_priors_centre() -> None:
    """Skins with scattering 1 and pheomelanin 0.3 (the fit's prior centre) fit back to their parameters."""
    rng = np.random.default_rng(7)
    for _ in range(12):
        truth = SkinParams(melanin=float(np.exp(rng.uniform(math.log(0.004), math.log(0.4)))),
                           blood=float(np.exp(rng.uniform(math.log(0.002), math.log(0.06)))),
                           oxygenation=float(rng.uniform(0.5, 0.95)))
        fit = fit_skin(lab_of(truth.reflectance()), oxygenation=truth.oxygenation)
        assert fit.residual_de2000 < 0.5
        assert not fit.out_of_gamut
        assert fit.params.melanin == pytest.approx(truth.melanin, rel=0.02)
        assert fit.params.blood == pytest.approx(truth.blood, rel=0.02)
        assert fit.params.scattering == pytest.approx(1.0, rel=0.02)
        assert fit.params.pheomelanin == pytest.approx(0.3, abs=0.02)


def test_round_trip_with_every_parameter_free_reproduces_the_colour() -> None:
    """Lab cannot fix four parameters: the colour always comes back, the parameters up to the model's metamers."""
    rng = np.random.default_rng(11)
    for _ in range(10):
        truth = SkinParams(melanin=float(np.exp(rng.uniform(math.log(0.004), math.log(0.4)))),
                           blood=float(np.exp(rng.uniform(math.log(0.002), math.log(0.06)))),
                           scattering=float(rng.uniform(0.7, 1.5)), pheomelanin=float(rng.uniform(0.0, 0.8)))
        lab = lab_of(truth.reflectance())
        fit = fit_skin(lab)
        assert fit.residual_de2000 < 0.5
        assert float(delta_e2000(fit.lab, lab)) == pytest.approx(fit.residual_de2000)


def test_fit_from_linear_rgb_and_out_of_gamut() -> None:
    fit = fit_skin(linear_rgb=[0.30, 0.18, 0.12])
    assert fit.residual_de2000 < 0.5 and not fit.out_of_gamut
    green = fit_skin(linear_rgb=[0.0, 1.0, 0.0])
    assert green.out_of_gamut and green.residual_de2000 > 20.0
    js = green.to_json()
    assert js["out_of_gamut"] is True and len(js["reflectance"]) == len(WL)


@pytest.mark.parametrize("bad", [[50.0, 1.0], [float("nan"), 0.0, 0.0], [120.0, 0.0, 0.0]])
def test_fit_refuses_malformed_colours(bad: list[float]) -> None:
    with pytest.raises(SkinError, match="CIELAB"):
        fit_skin(bad)


def test_a_malformed_haemoglobin_table_is_reported(tmp_path) -> None:
    bad = tmp_path / "hb.csv"
    bad.write_text("# comment\nwavelength_nm,HbO2,Hb\n400,1,2\n402,x,3\n", encoding="utf-8")
    with pytest.raises(SkinError, match="hb.csv: expected a header and rows"):
        ks._read_haemoglobin(bad)


def _adding_doubling(mua_e: np.ndarray, mua_d: np.ndarray, musp: np.ndarray, d_e: float, n: float) -> np.ndarray:
    """Total diffuse reflectance of the two layers under a boundary of index n, by iadpython (isotropic, μs = μs′)."""
    out = []
    for i in range(mua_e.size):
        epi = iad.Sample(a=musp[i] / (mua_e[i] + musp[i]), b=(mua_e[i] + musp[i]) * d_e, g=0.0, n=n, quad_pts=8)
        der = iad.Sample(a=musp[i] / (mua_d[i] + musp[i]), b=(mua_d[i] + musp[i]) * 100.0, g=0.0, n=n, quad_pts=8)
        epi.update_quadrature()
        der.update_quadrature()
        Re, Te = iad.simple_layer_matrices(epi)
        Rd, Td = iad.simple_layer_matrices(der)
        R12, R21, T12, T21 = iad.add_layers(epi, Re, Re, Te, Te, Rd, Rd, Td, Td)
        R01, R10, T01, T10 = iad.start.boundary_layer(epi, top=True)
        R02, _, T02, _ = iad.add_slide_above(epi, R01, R10, T01, T10, R12, R21, T12, T21)
        out.append(epi.UX1_and_UXU(R02, T02)[2])  # URU: diffuse incidence, total reflection
    return np.array(out)


@pytest.mark.parametrize("melanin,blood", [(0.01, 0.005), (0.05, 0.01), (0.2, 0.02)])
def test_independent_check_by_adding_doubling(melanin: float, blood: float) -> None:
    """The KM model against iadpython's radiative transfer of the same layers (every 2nd wavelength).

    KM with Saunderson is an approximation of transport: measured here within 0.045 in reflectance and
    ΔE2000 3.5 (light skins within 1). For the comparison the surface's own (specular) diffuse reflectance
    r_e is added, since adding-doubling includes it; the product's model leaves it out (k1 = 0).
    """
    grid = WavelengthGrid(380.0, 780.0, 10.0)
    c = skin_coefficients(melanin, blood, grid=grid)
    ad = _adding_doubling(c["mua_epidermis"], c["mua_dermis"], c["musp"], ks.EPIDERMIS_MM, ks.SKIN_IOR)
    S = ks.KM_S_PER_MUSP * c["musp"]
    R_e, T_e = layer_rt(S, ks.KM_K_PER_MUA * c["mua_epidermis"], ks.EPIDERMIS_MM)
    R_d, _ = layer_rt(S, ks.KM_K_PER_MUA * c["mua_dermis"], np.inf)
    r_e = 1.0 - (1.0 - ks.SURFACE_K2) * ks.SKIN_IOR**2
    model = saunderson(over(R_e, T_e, R_d), r_e, ks.SURFACE_K2)
    assert np.abs(model - ad).max() < 0.045
    assert float(delta_e2000(lab_of(model, grid=grid), lab_of(ad, grid=grid))) < (1.0 if melanin < 0.1 else 3.5)
    # the product's spectrum is this one without the specular part
    np.testing.assert_allclose(skin_reflectance(melanin, blood, grid=grid),
                               saunderson(over(R_e, T_e, R_d), 0.0, ks.SURFACE_K2), rtol=1e-12)


def test_bad_values_give_nan_not_warnings() -> None:
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        R = skin_reflectance(np.array([np.nan, 0.05, -1.0]), np.array([0.01, np.inf, 0.01]))
    assert np.isnan(R[0]).all()
    assert np.isnan(R[1]).all()  # infinite blood is no volume fraction
    assert np.isnan(R[2]).all()  # neither is a negative melanin fraction
