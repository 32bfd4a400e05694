"""km.Material and km.Measurement: validation, JSON round trip, optics and display colour."""

from __future__ import annotations

import json
import math
from typing import TYPE_CHECKING

import numpy as np
import pytest

import km
from core.errors import SheerError
from km.material import Material, MaterialError, Measurement

if TYPE_CHECKING:
    from collections.abc import Callable

WL = np.arange(380.0, 781.0, 5.0)


def make_material(**changes: object) -> Material:
    rng = np.random.default_rng(7)
    values: dict[str, object] = dict(
        name="Test Rose", category="blush", wavelengths=WL, S=rng.uniform(1.0, 40.0, WL.size),
        K=rng.uniform(0.0, 20.0, WL.size), thickness_um=12.5, max_thickness_um=50.0, roughness=0.4, ior=1.5,
        source="modelled", provenance="made up for a test",
    )
    values.update(changes)
    return Material(**values)  # type: ignore[arg-type]


def make_measurement(m: Material, d_mm: float = 0.15) -> Measurement:
    r0, t = km.layer_rt(m.S, m.K, d_mm)
    rg = np.full(WL.size, 0.04)
    return Measurement(WL, m.r_inf(), km.over(r0, t, rg), rg, d_mm, instrument="none", illuminant="D55")


def test_arrays_are_read_only_float64_copies() -> None:
    s = np.linspace(1, 2, WL.size)
    m = make_material(S=s)
    s[0] = 99.0
    assert m.S[0] == 1.0 and m.S.dtype == np.float64
    with pytest.raises(ValueError):
        m.S[0] = 5.0
    with pytest.raises(AttributeError):
        m.name = "x"  # type: ignore[misc]


@pytest.mark.parametrize(
    ("changes", "field", "words"),
    [
        ({"S": np.r_[np.ones(12), np.nan, np.ones(68)]}, "S[12]", "finite"),
        ({"K": np.r_[np.ones(3), -0.5, np.ones(77)]}, "K[3]", "negative"),
        ({"S": np.ones(80)}, "S", "80 values"),
        ({"wavelengths": np.r_[WL[:10], WL[9], WL[11:]]}, "wavelengths[10]", "increase"),
        ({"wavelengths": WL * 100}, "wavelengths[0]", "above"),
        ({"name": "  "}, "name", "empty"),
        ({"name": 5}, "name", "string"),
        ({"category": "Lip Stick"}, "category", "lowercase"),
        ({"source": "guessed"}, "source", "measured"),
        ({"thickness_um": 60.0}, "thickness_um", "50"),
        ({"thickness_um": 0.0}, "thickness_um", "> 0"),
        ({"roughness": 0.0}, "roughness", "> 0"),
        ({"ior": math.inf}, "ior", "finite"),
        ({"ior": True}, "ior", "number"),
        ({"measurement": "yes"}, "measurement", "Measurement"),
    ],
)
def test_constructor_rejects_bad_values(changes: dict, field: str, words: str) -> None:
    with pytest.raises(MaterialError) as info:
        make_material(**changes)
    assert info.value.field == field
    assert words in str(info.value)
    assert isinstance(info.value, ValueError) and isinstance(info.value, SheerError)


def test_json_round_trip_is_bit_identical_and_stable() -> None:
    m = make_material()
    meas = make_measurement(m)
    m = m.replace(measurement=Measurement(WL, meas.R_inf, meas.R, meas.Rg, 0.15, "CS-2000", "D55", (0.04, 0.6)))
    data = m.to_json()
    assert list(data) == ["name", "category", "source", "provenance", "wavelengths", "S", "K", "thickness_um",
                          "max_thickness_um", "roughness", "ior", "measurement", "coverage"]
    assert list(data["measurement"]) == ["wavelengths", "R_inf", "R", "Rg", "D_mm", "instrument", "illuminant",
                                         "saunderson"]
    back = Material.from_json(json.loads(json.dumps(data)))
    assert back == m
    for name in ("wavelengths", "S", "K"):
        assert getattr(back, name).tobytes() == getattr(m, name).tobytes()
    assert back.measurement is not None and m.measurement is not None
    assert back.measurement.R.tobytes() == m.measurement.R.tobytes()
    assert back.measurement.saunderson == (0.04, 0.6)


def _good_json() -> dict:
    m = make_material()
    return json.loads(json.dumps(make_material(measurement=make_measurement(m)).to_json()))


@pytest.mark.parametrize(
    ("mutate", "field", "words"),
    [
        (lambda d: d.pop("K"), "materials[3]", "missing field K"),
        (lambda d: d.update(colour="#fff"), "materials[3]", "unknown field colour"),
        (lambda d: d["S"].__setitem__(12, -1.0), "materials[3].S[12]", "negative"),
        (lambda d: d["S"].__setitem__(12, float("nan")), "materials[3].S[12]", "finite"),
        (lambda d: d["K"].__setitem__(2, "0.5"), "materials[3].K[2]", "number"),
        (lambda d: d["K"].__setitem__(2, True), "materials[3].K[2]", "number"),
        (lambda d: d.update(S=d["S"][:-1]), "materials[3].S", "80 values"),
        (lambda d: d.update(S="1,2,3"), "materials[3].S", "list"),
        (lambda d: d.update(thickness_um="20"), "materials[3].thickness_um", "number"),
        (lambda d: d.update(name=None), "materials[3].name", "string"),
        (lambda d: d["measurement"]["R"].__setitem__(4, 1.5), "materials[3].measurement.R[4]", "above 1"),
        (lambda d: d["measurement"].update(Rg=d["measurement"]["Rg"][:5]), "materials[3].measurement.Rg", "5 values"),
        (lambda d: d["measurement"].update(D_mm=0), "materials[3].measurement.D_mm", "> 0"),
        (lambda d: d["measurement"].update(saunderson={"k1": 0.04}), "materials[3].measurement.saunderson",
         "missing field k2"),
        (lambda d: d["measurement"].update(saunderson={"k1": 0.04, "k2": 1.0}),
         "materials[3].measurement.saunderson.k2", "< 1"),
        (lambda d: d["measurement"].pop("illuminant"), "materials[3].measurement", "missing field illuminant"),
    ],
)
def test_from_json_names_the_field(mutate: Callable[[dict], object], field: str, words: str) -> None:
    data = _good_json()
    mutate(data)
    with pytest.raises(MaterialError) as info:
        Material.from_json(data, where="materials[3]")
    assert info.value.field == field, str(info.value)
    assert words in info.value.reason
    assert str(info.value).startswith(field + ":")


def test_from_json_rejects_non_objects() -> None:
    with pytest.raises(MaterialError, match="material: must be an object"):
        Material.from_json([1, 2])


def test_layer_optics_match_km() -> None:
    m = make_material()
    r0, t = m.rt()
    r0_ref, t_ref = km.layer_rt(m.S, m.K, 12.5e-3)
    np.testing.assert_array_equal(r0, r0_ref)
    np.testing.assert_array_equal(t, t_ref)
    # several thicknesses at once broadcast to (n, wavelengths)
    r0s, ts = m.rt(np.array([5.0, 12.5, 40.0]))
    assert r0s.shape == (3, WL.size)
    np.testing.assert_array_equal(r0s[1], r0)
    assert np.all(np.diff(r0s, axis=0) > 0) and np.all(np.diff(ts, axis=0) < 0)
    np.testing.assert_allclose(m.r_inf(), km.r_inf_from_ks(m.K / m.S), rtol=1e-15)
    over_white = m.reflectance_over("white")
    over_black = m.reflectance_over("black")
    assert np.all(over_white > over_black)
    np.testing.assert_array_equal(over_black, r0)
    with pytest.raises(MaterialError):
        m.reflectance_over("grey")
    with pytest.raises(MaterialError):
        m.rt(-1.0)


def test_measurement_inversion_recovers_s_and_k() -> None:
    m = make_material()
    meas = make_measurement(m)
    s, k = meas.invert()
    np.testing.assert_allclose(s, m.S, rtol=1e-9)
    np.testing.assert_allclose(k, m.K, rtol=1e-9)


def test_swatch_of_a_grey_is_grey() -> None:
    # constant K/S gives a constant R∞; a constant reflectance ρ is (ρ, ρ, ρ) in linear sRGB under D65
    ks = km.ks_from_r_inf(0.18)
    m = make_material(S=np.full(WL.size, 50.0), K=np.full(WL.size, 50.0 * ks))
    lin = m.swatch_rgb("opaque", encoded=False)
    np.testing.assert_allclose(lin, [0.18, 0.18, 0.18], atol=1e-3)
    enc = m.swatch_rgb("opaque")
    np.testing.assert_allclose(enc, [0.4613] * 3, atol=2e-3)  # sRGB encoding of 0.18
    assert m.swatch_hex() == "#767676"
    # over black a thin layer is darker than opaque, over white lighter
    assert m.swatch_rgb("black", 5.0).mean() < enc.mean() < m.swatch_rgb("white", 5.0).mean()
    # a given background spectrum
    bg = np.linspace(0.2, 0.6, WL.size)
    assert m.swatch_rgb(bg, 5.0).shape == (3,)


def test_replace_validates_and_equality() -> None:
    m = make_material()
    assert m.replace(name="Other").name == "Other"
    assert m.replace() == m and m.replace(name="Other") != m
    with pytest.raises(MaterialError):
        m.replace(thickness_um=-1.0)
    with pytest.raises(TypeError):
        m.replace(colour="red")


def test_on_wavelengths_resamples() -> None:
    m = make_material(S=np.linspace(1, 81, WL.size), K=np.zeros(WL.size))
    m2 = m.on_wavelengths(np.arange(400.0, 701.0, 10.0))
    assert m2.wavelengths.size == 31
    np.testing.assert_allclose(m2.S, 1 + (m2.wavelengths - 380) / 5)


def test_json_schema_agrees_with_the_validator() -> None:
    import jsonschema  # a required dependency: a missing one fails here

    from km.material import MATERIAL_JSON_SCHEMA

    jsonschema.Draft202012Validator.check_schema(MATERIAL_JSON_SCHEMA)
    validator = jsonschema.Draft202012Validator(MATERIAL_JSON_SCHEMA)
    for m in km.default_library():
        assert not list(validator.iter_errors(m.to_json())), m.name
    good = _good_json()
    assert not list(validator.iter_errors(good))
    for mutate in (lambda d: d.pop("K"), lambda d: d.update(colour=1), lambda d: d["S"].__setitem__(0, -1.0),
                   lambda d: d.update(source="guess"), lambda d: d["measurement"].update(D_mm=0),
                   lambda d: d.update(category="Lip Stick")):
        data = _good_json()
        mutate(data)
        assert list(validator.iter_errors(data))
        with pytest.raises(MaterialError):
            Material.from_json(data)
