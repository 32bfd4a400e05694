"""The shade finder: the match against synthetic made-up skins and a brute-force search, metamerism,
targets, lights, coverage and the gap shade."""

from __future__ import annotations

import numpy as np
import pytest

from km.colour import delta_e2000
from km.library import Library, default_library
from km.optics import mix, over
from km.skin import fit_skin, ita_degrees, lab_of, skin_reflectance
from shade.coverage import coverage, sample_skins
from shade.match import (
    METAMERISM_DE2000,
    ShadeBank,
    ShadeError,
    foundations,
    make_target,
    match_shades,
    resolve_light,
)


@pytest.fixture(scope="module")
def lib() -> Library:
    return default_library()


@pytest.fixture(scope="module")
def bank(lib: Library) -> ShadeBank:
    return ShadeBank.from_materials(foundations(lib))


SKINS = {"light": (0.01, 0.008), "medium": (0.06, 0.012), "dark": (0.25, 0.015)}


def test_foundations_are_the_foundation_category(lib: Library) -> None:
    names = [m.name for m in foundations(lib)]
    assert names and all(lib.get(n).category == "foundation" for n in names)
    assert len(names) == sum(m.category == "foundation" for m in lib)


def test_a_library_without_foundation_is_refused(lib: Library) -> None:
    only_lips = Library([m for m in lib if m.category == "lipstick"], name="lips only")
    with pytest.raises(ShadeError, match="lips only: no foundation in the library.*lipstick"):
        foundations(only_lips)


@pytest.mark.parametrize("skin", sorted(SKINS))
@pytest.mark.parametrize("index", range(6))
def test_a_made_up_skin_as_target_returns_its_foundation_and_thickness(bank: ShadeBank, lib: Library,
                                                                         skin: str, index: int) -> None:
    """Foundation X at thickness t over skin Y, rendered by km's KM, is found first with t within 10 %."""
    melanin, blood = SKINS[skin]
    skin_r = skin_reflectance(melanin, blood)
    material = lib.get(bank.names[index])
    for t in (16.0, 35.0, 60.0):
        R0, T = material.rt(t)
        target = over(R0, T, skin_r)
        ranked = match_shades(skin_r, target, bank)
        assert ranked[0].name == material.name, (t, [(r.name, round(r.de2000, 3)) for r in ranked])
        assert ranked[0].thickness_um == pytest.approx(t, rel=0.10)
        assert ranked[0].de2000 < 0.05


def _brute_force(bank: ShadeBank, skin_r: np.ndarray, target: np.ndarray, illuminant: str
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Each foundation's best ΔE2000 and thickness on a 0.05 µm grid over its range."""
    target_lab = lab_of(target, illuminant)
    best_de, best_t = [], []
    for m in range(len(bank.names)):
        t = np.arange(bank.t_lo_um[m], bank.t_hi_um[m] + 1e-9, 0.05)
        made = bank.made_up(np.broadcast_to(skin_r, (t.size, skin_r.size)), np.repeat(t[:, None], len(bank.names), 1))
        de = delta_e2000(lab_of(made[:, m], illuminant), target_lab)
        best_de.append(de.min())
        best_t.append(t[np.argmin(de)])
    return np.array(best_de), np.array(best_t)


@pytest.mark.parametrize("illuminant", ["D65", "A"])
@pytest.mark.parametrize("target_name", ["own", "lighter", "warmer"])
def test_ranking_equals_a_brute_force_search(bank: ShadeBank, illuminant: str, target_name: str) -> None:
    skin = fit_skin([58.0, 11.0, 16.0])
    target = make_target(target_name, skin)
    ranked = match_shades(skin.reflectance, target.reflectance, bank, illuminant=illuminant)
    de_bf, t_bf = _brute_force(bank, skin.reflectance, target.reflectance, illuminant)
    by_name = {r.name: r for r in ranked}
    for m, name in enumerate(bank.names):
        assert by_name[name].de2000 <= de_bf[m] + 1e-3  # never worse than the grid
        assert by_name[name].de2000 == pytest.approx(de_bf[m], abs=2e-3)
        assert by_name[name].thickness_um == pytest.approx(t_bf[m], abs=0.3)
    assert [r.name for r in ranked] == [bank.names[i] for i in np.argsort(de_bf, kind="stable")]


def test_metamerism_is_flagged_for_a_shade_that_matches_only_in_daylight(lib: Library) -> None:
    """A foundation with narrow absorption bands under F11's emission lines: close in D65, far under F11."""
    beige = lib.get("Foundation Beige")
    wl = np.asarray(beige.wavelengths)
    bands = sum(np.exp(-0.5 * ((wl - c) / 3.0) ** 2) for c in (435.0, 545.0, 610.0))
    spiky = beige.replace(name="Foundation Spiky", K=beige.K + 50.0 * bands)
    skin = skin_reflectance(0.06, 0.012)
    R0, T = beige.rt(30.0)
    ranked = match_shades(skin, over(R0, T, skin), ShadeBank.from_materials([beige, spiky]),
                          lights=("D65", "F11", "A"))
    by_name = {r.name: r for r in ranked}
    assert set(by_name["Foundation Spiky"].de2000_by_illuminant) == {"D65", "F11", "A"}
    assert by_name["Foundation Spiky"].metameric
    assert by_name["Foundation Spiky"].de2000_by_illuminant["F11"] > by_name["Foundation Spiky"].de2000 + 5.0
    assert not by_name["Foundation Beige"].metameric
    for r in ranked:
        spread = max(r.de2000_by_illuminant.values()) - min(r.de2000_by_illuminant.values())
        assert r.metameric == (spread > METAMERISM_DE2000)


def test_targets(bank: ShadeBank) -> None:
    skin = fit_skin([60.0, 10.0, 15.0])
    assert make_target("own", skin).reflectance is skin.reflectance
    lighter = make_target("lighter", skin)
    assert lighter.lab[0] == pytest.approx(skin.lab[0] + 3.0, abs=0.1)
    assert make_target("lab:55,12,18", skin).lab == pytest.approx([55.0, 12.0, 18.0], abs=0.1)
    assert make_target("rgb:180,130,100", skin).fit is not None
    for bad, message in (("pinker", "unknown target"), ("lab:1,2", "three numbers"), ("rgb:300,0,0", "0..255")):
        with pytest.raises(ShadeError, match=message):
            make_target(bad, skin)


def test_lights_by_name_and_from_a_spectrum_file(tmp_path, bank: ShadeBank) -> None:
    assert resolve_light("F11") == "F11"
    led = tmp_path / "store-led.csv"
    wl = np.arange(380, 781, 5)
    power = np.exp(-0.5 * ((wl - 450) / 12) ** 2) + 0.8 * np.exp(-0.5 * ((wl - 590) / 60) ** 2)
    led.write_text("wavelength_nm,power\n" + "".join(f"{w},{p:.6f}\n" for w, p in zip(wl, power)), encoding="utf-8")
    name = resolve_light(str(led))
    assert name.startswith("file:store-led.csv:") and resolve_light(str(led)) == name
    skin = skin_reflectance(0.03, 0.01)
    ranked = match_shades(skin, skin, bank, lights=("D65", name, "A"))
    assert all(np.isfinite(r.de2000_by_illuminant[name]) for r in ranked)
    bad = tmp_path / "bad.csv"
    bad.write_text("380,1\n390,-2\n", encoding="utf-8")
    with pytest.raises(ShadeError, match="bad.csv: a light spectrum needs"):
        resolve_light(str(bad))
    with pytest.raises(ShadeError, match="unknown light 'TL99'"):
        resolve_light("TL99")


def test_coverage_of_a_population(bank: ShadeBank) -> None:
    cov = coverage(bank, 96, seed=3)
    assert cov.best_de2000.shape == (96,)
    assert cov.ita_deg.max() > 55.0 and cov.ita_deg.min() < -30.0  # light to dark
    # each skin's best is the minimum over the library (checked against the match of that skin)
    for i in (0, 40, 95):
        p = {k: v[i] for k, v in cov.params.items()}
        skin = skin_reflectance(p["melanin"], p["blood"], p["oxygenation"], p["scattering"],
                                pheomelanin=p["pheomelanin"])
        first = match_shades(skin, skin, bank)[0]
        assert cov.names[cov.best[i]] == first.name
        assert cov.best_de2000[i] == pytest.approx(first.de2000, abs=1e-9)
    assert ita_degrees(cov.lab) == pytest.approx(cov.ita_deg)
    js = cov.to_json()
    assert js["skins"] == 96 and sum(js["best_counts"].values()) == 96


def test_the_gap_shade_is_a_duncan_mixture_that_serves_the_gap_better(bank: ShadeBank) -> None:
    cov = coverage(bank, 128, seed=1)
    gap = cov.gap
    assert gap is not None and gap.gap_skins.size > 0
    assert all(cov.best_de2000[gap.gap_skins] > cov.threshold)
    assert sum(gap.recipe.values()) == pytest.approx(1.0)
    S, K = mix([(c, bank.S[bank.names.index(n)], bank.K[bank.names.index(n)]) for n, c in gap.recipe.items()])
    np.testing.assert_allclose(gap.S, S, rtol=1e-12)
    np.testing.assert_allclose(gap.K, K, rtol=1e-12)
    assert gap.mean_de_after < gap.mean_de_before


def test_population_is_reproducible_and_in_range() -> None:
    a, b = sample_skins(50, seed=4), sample_skins(50, seed=4)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
    assert a["melanin"].min() >= 0.005 and a["melanin"].max() <= 0.40
    with pytest.raises(ShadeError, match="1 to 1,000,000 skins"):
        sample_skins(0)
