"""Coverage (km.coverage): each material states its hiding, the library's modelling respects it, and a layer
as applied is composed as the renderer composes it.

- the classes' bounds, the statement's checks and its JSON (a class that does not match its contrast ratio,
  a ratio outside [0, 1], unknown keys: refused, naming the field); a material that states none gets the one
  its S and K give, saying so; an edit of S, K or the thickness recomputes it, a rename keeps it;
- a version-1 library (no coverage) loads through the 1 → 2 migration with the coverage its S and K give;
- the default library: a cream lipstick at its default thickness over the sample head's bare lip lands
  within ΔE2000 3 of its bullet (R∞), as the renderer composes it and spectrally; sheer ones show the lip;
  foundations are of their class; the reference skin and lip are the sample head's.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

import km
from km.colour import delta_e2000, linear_rgb_to_lab, spectrum_to_rgb
from km.coverage import (
    FULL_MIN,
    REFERENCE_LIP_SRGB,
    REFERENCE_SKIN_SRGB,
    SHEER_MAX,
    Coverage,
    coverage_class,
    hex_to_linear,
    reference_background,
)
from km.library import Library, LibraryError
from km.material import Material, MaterialError

if TYPE_CHECKING:
    from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]
WL = np.arange(380.0, 781.0, 5.0)


def de(a: np.ndarray, b: np.ndarray) -> float:
    """ΔE2000 of two linear sRGB colours."""
    return float(delta_e2000(linear_rgb_to_lab(a), linear_rgb_to_lab(b)))


def grey(name: str = "Grey", s: float = 50.0, k: float = 20.0, **kw: object) -> Material:
    return Material(name=name, category="eyeshadow", wavelengths=WL, S=np.full(WL.size, s), K=np.full(WL.size, k),
                    thickness_um=10.0, max_thickness_um=40.0, **kw)  # type: ignore[arg-type]


def builder(monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    spec = importlib.util.spec_from_file_location("build_default_library", ROOT / "scripts" / "build_default_library.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, mod)
    spec.loader.exec_module(mod)
    return mod


# ---------------------------------------------------------------------------------------------- the statement

def test_classes_and_their_bounds() -> None:
    assert (SHEER_MAX, FULL_MIN) == (0.5, 0.9)
    assert [coverage_class(x) for x in (0.0, 0.5, 0.51, 0.89, 0.9, 1.0)] == ["sheer", "sheer", "medium", "medium",
                                                                            "full", "full"]


@pytest.mark.parametrize(("data", "words"), [
    ({"class": "opaque", "contrast_ratio": None, "provenance": ""}, "coverage.class: must be one of"),
    ({"class": "full", "contrast_ratio": 0.6, "provenance": ""}, "coverage.class: 'full' does not match"),
    ({"class": "full", "contrast_ratio": 1.2, "provenance": ""}, "coverage.contrast_ratio: must be a number in [0, 1]"),
    ({"class": "full", "contrast_ratio": True, "provenance": ""}, "coverage.contrast_ratio"),
    ({"class": "full", "contrast_ratio": 0.95}, "coverage: missing field provenance"),
    ({"class": "full", "contrast_ratio": 0.95, "provenance": "", "x": 1}, "coverage: unknown field x"),
    ("full", "coverage: must be an object or null"),
])
def test_a_bad_statement_is_refused_naming_the_field(data: object, words: str) -> None:
    good = grey().to_json()
    good["coverage"] = data
    with pytest.raises(MaterialError) as info:
        Material.from_json(good, where="materials[2]")
    assert f"materials[2].{words}" in str(info.value)


def test_a_class_alone_is_a_statement_and_round_trips() -> None:
    m = grey(coverage=Coverage("medium", None, "the maker says medium"))
    back = Material.from_json(json.loads(json.dumps(m.to_json())))
    assert back == m and back.coverage == Coverage("medium", None, "the maker says medium")


def test_a_material_that_states_none_gets_what_its_s_and_k_give() -> None:
    m = grey()
    cr = m.contrast_ratio()
    assert 0.0 < cr < 1.0 and m.coverage.contrast_ratio == pytest.approx(cr, abs=1e-4)
    assert m.coverage.level == coverage_class(m.coverage.contrast_ratio)
    assert "computed from S and K" in m.coverage.provenance and "states none" in m.coverage.provenance
    data = m.to_json()
    data["coverage"] = None  # a file that states none
    loaded = Material.from_json(data)
    assert loaded.coverage.contrast_ratio == m.coverage.contrast_ratio and "not stated in the file" in \
        loaded.coverage.provenance
    # thicker hides more; a clear layer hides nothing; a black absorber hides everything
    assert m.contrast_ratio(40.0) > cr
    assert grey(s=0.0, k=0.0).contrast_ratio() == 0.0 and grey(s=0.0, k=1e6).contrast_ratio() == 1.0


def test_an_optical_edit_recomputes_the_coverage_a_rename_keeps_it() -> None:
    stated = Coverage("full", 0.99, "the maker's claim")
    m = grey(s=400.0, k=150.0, coverage=stated)
    assert m.replace(name="Grey 2").coverage == stated
    assert m.on_wavelengths(np.arange(380.0, 781.0, 10.0)).coverage == stated  # the same product
    for change in ({"S": m.S * 0.01}, {"K": m.K * 0.5}, {"thickness_um": 1.0}):
        edited = m.replace(**change)
        assert edited.coverage != stated and edited.coverage.contrast_ratio == pytest.approx(
            edited.contrast_ratio(), abs=1e-4), change
    assert m.replace(S=m.S * 0.01, coverage=stated).coverage == stated  # unless given


def test_a_version_1_library_loads_with_the_coverage_its_s_and_k_give(tmp_path: Path) -> None:
    lib = Library([grey("A"), grey("B", s=5.0)], name="old")
    data = json.loads(lib.dumps())
    assert data["schema_version"] == 2
    data["schema_version"] = 1
    for m in data["materials"]:
        del m["coverage"]
    path = tmp_path / "old.json"
    path.write_text(json.dumps(data))
    loaded = Library.load(path)
    for m in loaded:
        assert m.coverage.contrast_ratio == pytest.approx(m.contrast_ratio(), abs=1e-4)
        assert "not stated in the file" in m.coverage.provenance
    assert json.loads(path.read_text()) == data  # loading never rewrites the file
    assert json.loads(loaded.dumps())["schema_version"] == 2
    data["materials"][0]["S"] = "x"  # a damaged old file is refused after the migration, naming the field
    path.write_text(json.dumps(data))
    with pytest.raises(LibraryError, match=r"materials\[0\]\.S: must be a list"):
        Library.load(path)


# ---------------------------------------------------------------------------------------------- the library

def test_the_reference_skin_and_lip_are_the_sample_heads() -> None:
    """The medians of the sample head's albedo over its skin and lips regions, within 2 sRGB codes."""
    from painting import Document

    doc = Document.from_head(resolution=1024)
    atlas = doc.atlas_at(1024)
    albedo = doc.head.albedo
    assert albedo.shape[:2] == (1024, 1024)
    for region, ref in (("skin", REFERENCE_SKIN_SRGB), ("lips", REFERENCE_LIP_SRGB)):
        sel = (doc.region_values(region, 1024) >= 0.95) & atlas.coverage
        median = np.median(albedo[sel].astype(float), axis=0)
        want = np.array([int(ref[i:i + 2], 16) for i in (1, 3, 5)], float)
        assert np.abs(median - want).max() <= 2.0, (region, median, ref)


def test_every_default_material_states_its_coverage_with_provenance() -> None:
    for m in km.default_library():
        c = m.coverage
        assert c.contrast_ratio is not None and c.level == coverage_class(c.contrast_ratio), m.name
        assert c.provenance.startswith("Modelled, stated for the kind of product"), m.name
        assert f"contrast ratio {c.contrast_ratio:g}" in m.provenance and "hides" in m.provenance, m.name


def test_a_cream_lipstick_as_applied_is_its_bullet_and_a_sheer_one_shows_the_lip(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Full-coverage lipsticks at 15 µm over the sample head's bare lip: within ΔE2000 3 of R∞, as the
    renderer composes it (RGB) and spectrally (the lip upsampled by Jakob 2019); over a paler lip they stay
    put (≤ 1), where a sheer one changes with the lip (≥ 3) and stays away from its bullet."""
    from km.optics import over

    b = builder(monkeypatch)
    lip = reference_background("lipstick")
    pale = hex_to_linear("#D89A92")
    lip_spectrum = b.reflectance_from_hex(REFERENCE_LIP_SRGB)
    full = [m for m in km.default_library() if m.category == "lipstick" and m.coverage.level == "full"]
    sheer = [m for m in km.default_library() if m.category == "lipstick" and m.coverage.level == "sheer"]
    assert len(full) >= 8 and "Lipstick Classic Red" in [m.name for m in full] and sheer
    report = {}
    for m in full:
        bullet = m.swatch_rgb("opaque", encoded=False)
        r0, t = m.rt()
        spectral = spectrum_to_rgb(over(r0, t, lip_spectrum), m.wavelengths)
        report[m.name] = (de(m.applied_rgb(lip), bullet), de(spectral, bullet))
        assert max(report[m.name]) <= 3.0, (m.name, report[m.name])
        assert m.contrast_ratio() >= FULL_MIN
        assert de(m.applied_rgb(lip), m.applied_rgb(pale)) <= 1.0, m.name
    for m in sheer:
        assert m.contrast_ratio() <= SHEER_MAX
        assert de(m.applied_rgb(lip), m.applied_rgb(pale)) >= 3.0, m.name
        assert de(m.applied_rgb(lip), m.swatch_rgb("opaque", encoded=False)) >= 3.0, m.name
    print("lipsticks on the bare lip, ΔE2000 to the bullet (renderer, spectral):",
          {k: tuple(round(x, 2) for x in v) for k, v in report.items()})


def test_foundations_and_the_eye_products_are_of_their_class() -> None:
    """Foundations light (sheer: they even the skin, which shows through), every shade hiding alike (before,
    the deep shades hid almost nothing: Espresso's contrast ratio was 0.05, Porcelain's 0.37); eyeliners full,
    eye shadows medium: the plum shadow on the lid reads plum (within ΔE2000 5 of its pan), the brown liner
    is its own colour."""
    lib = km.default_library()
    for m in lib.by_category("foundation"):
        assert m.coverage.level == "sheer" and m.contrast_ratio() == pytest.approx(0.35, abs=1e-3), m.name
    skin = reference_background("eyeshadow")
    for m in lib.by_category("eyeliner"):
        assert m.coverage.level == "full" and de(m.applied_rgb(skin), m.swatch_rgb("opaque", encoded=False)) <= 2.0
    plum = lib.get("Eyeshadow Plum")
    assert plum.coverage.level == "medium" and de(plum.applied_rgb(skin), plum.swatch_rgb("opaque", encoded=False)) <= 5.0
    # a sheer blush still reads on the skin: at its default thickness it moves the skin by ΔE2000 ≥ 5
    for m in lib.by_category("blush"):
        assert m.coverage.level == "sheer" and de(m.applied_rgb(skin), skin) >= 5.0, m.name
