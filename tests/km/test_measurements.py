"""Import of R∞/R/Rg measurements from CSV and X-Rite/CGATS files, and CSV export."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import km
from km.material import Material
from km.measurement_files import import_file, read_cgats
from km.measurements import MeasurementImportError, export_csv, read_csv

DATA = Path(__file__).resolve().parents[1] / "data" / "materials"
GRID = np.arange(380.0, 781.0, 5.0)


def _triplet(s: np.ndarray, k: np.ndarray, d_mm: float, rg: float = 0.05) -> tuple[np.ndarray, ...]:
    r0, t = km.layer_rt(s, k, d_mm)
    rgv = np.full(s.shape, rg)
    return km.r_inf_from_ks(k / s), km.over(r0, t, rgv), rgv


def _write_csv(path: Path, wl: np.ndarray, cols: tuple[np.ndarray, ...], header: str = "", fmt: str = "r") -> None:
    lines = [header.rstrip("\n")] if header else []
    lines.append("wavelength,R_inf,R,Rg")
    for i, w in enumerate(wl):
        vals = [repr(float(c[i])) if fmt == "r" else format(float(c[i]), fmt) for c in cols]
        lines.append(",".join([f"{w:g}", *vals]))
    path.write_text("\n".join(lines) + "\n")


def test_csv_on_the_grid_recovers_s_and_k_exactly(tmp_path: Path) -> None:
    s = 30.0 * (560.0 / GRID)
    k = 5.0 + 4.0 * np.sin(GRID / 40.0)
    path = tmp_path / "peach.csv"
    _write_csv(path, GRID, _triplet(s, k, 0.15), header="# D_mm: 0.15\n# category: blush\n# illuminant: D55")
    result = read_csv(path)
    assert result.rejected == [] and len(result.accepted) == 1
    m = result.accepted[0]
    assert m.name == "peach" and m.category == "blush" and m.source == "measured"
    assert "peach.csv" in m.provenance and "D = 0.15 mm" in m.provenance
    np.testing.assert_allclose(m.S, s, rtol=1e-9)
    np.testing.assert_allclose(m.K, k, rtol=1e-9)
    assert m.measurement is not None and m.measurement.D_mm == 0.15 and m.measurement.illuminant == "D55"
    assert m.thickness_um == 10.0  # the blush default


def test_thickness_argument_overrides_the_header_and_is_required(tmp_path: Path) -> None:
    s = np.full(GRID.size, 20.0)
    k = np.full(GRID.size, 2.0)
    path = tmp_path / "x.csv"
    _write_csv(path, GRID, _triplet(s, k, 0.1), header="# D_mm: 0.15")
    m = read_csv(path, thickness_mm=0.1, name="Given", category="Foundation").accepted[0]
    assert m.name == "Given" and m.category == "foundation"
    np.testing.assert_allclose(m.S, s, rtol=1e-9)
    _write_csv(path, GRID, _triplet(s, k, 0.1))
    with pytest.raises(MeasurementImportError, match="thickness D is not given"):
        read_csv(path)
    with pytest.raises(MeasurementImportError, match="--thickness-mm"):
        read_csv(path, thickness_mm=-1.0)


def test_csv_bad_rows_are_each_reported() -> None:
    result = read_csv(DATA / "rose_bad_rows.csv")
    assert len(result.accepted) == 1
    m = result.accepted[0]
    assert (m.name, m.category) == ("Test Rose", "blush")
    rejected = dict(result.rejected)
    assert rejected["line 12"] == "R 'abc' is not a number"
    assert "2 values" in rejected["line 17"]
    assert "outside [0, 1]" in rejected["line 22"] and "percent" in rejected["line 22"]
    assert rejected["line 33"] == "Rg is nan"
    assert "repeats line 29" in rejected["line 30"]
    assert "R is not strictly between Rg and R∞" in rejected["Test Rose: 600 nm"]
    assert "380–395 nm and 705–780 nm" in rejected["Test Rose"]
    assert len(result.rejected) == 7
    # the material covers the measured range except the wavelength that could not be inverted
    assert m.wavelengths[0] == 400 and m.wavelengths[-1] == 700 and 600.0 not in m.wavelengths
    assert m.wavelengths.size == 60
    assert result.notes == ["ignored column comment"]
    report = result.report()
    assert "line 12: R 'abc' is not a number" in report and "+ Test Rose" in report


def test_csv_with_nothing_importable(tmp_path: Path) -> None:
    path = tmp_path / "bad.csv"
    path.write_text("# D_mm: 0.15\nwavelength,R_inf,R,Rg\n500,0.5,0.6,0.05\n510,x,0.5,0.05\n")
    result = read_csv(path)
    assert result.accepted == []
    assert ("line 4", "R_inf 'x' is not a number") in result.rejected
    assert any("at least 2" in reason for _, reason in result.rejected)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("", "no header row"),
        ("# only a comment\n", "no header row"),
        ("wavelength,R_inf,R\n500,0.5,0.4\n", "no Rg column"),
        ("nm,R_inf,R,Rg,rg\n", "more than one Rg column"),
    ],
)
def test_csv_unreadable_files(tmp_path: Path, text: str, words: str) -> None:
    path = tmp_path / "f.csv"
    path.write_text(text)
    with pytest.raises(MeasurementImportError, match=words):
        read_csv(path, thickness_mm=0.15)


def test_missing_and_binary_files(tmp_path: Path) -> None:
    with pytest.raises(MeasurementImportError, match="no such measurement file"):
        import_file(tmp_path / "none.csv")
    os.mkfifo(tmp_path / "pipe.csv")
    with pytest.raises(MeasurementImportError, match="not a regular file"):
        import_file(tmp_path / "pipe.csv")
    (tmp_path / "b.csv").write_bytes(b"\x00\x01\x02")
    with pytest.raises(MeasurementImportError, match="not a text file"):
        import_file(tmp_path / "b.csv")


def test_semicolon_csv_and_saunderson(tmp_path: Path) -> None:
    s = np.full(GRID.size, 25.0)
    k = np.linspace(1.0, 9.0, GRID.size)
    ri, r, rg = _triplet(s, k, 0.15)
    k1, k2 = 0.04, 0.6
    measured = [km.saunderson(x, k1, k2) for x in (ri, r, rg)]
    lines = ["# D_mm = 0.15", f"# saunderson_k1: {k1}", f"# saunderson_k2: {k2}", "Wavelength (nm);R inf;R;Rg"]
    lines += [";".join([f"{w:g}"] + [repr(float(c[i])) for c in measured]) for i, w in enumerate(GRID)]
    path = tmp_path / "s.csv"
    path.write_text("\n".join(lines) + "\n")
    m = read_csv(path).accepted[0]
    np.testing.assert_allclose(m.S, s, rtol=1e-8)
    np.testing.assert_allclose(m.K, k, rtol=1e-8)
    assert m.measurement is not None and m.measurement.saunderson == (k1, k2)


def test_cgats_two_materials_in_percent_with_bad_samples() -> None:
    result = import_file(DATA / "two_shades_cgats.txt", category="lipstick")
    assert [m.name for m in result.accepted] == ["Coral Cream", "Deep Plum"]
    for m in result.accepted:
        assert m.category == "lipstick" and m.measurement is not None
        assert m.measurement.D_mm == 0.1 and m.measurement.instrument == "i1Pro 2 (fixture)"
        assert m.measurement.illuminant == "D50"
        assert m.wavelengths[0] == 400 and m.wavelengths[-1] == 700
        assert m.measurement.R_inf.max() <= 1.0
    # the fixture was made with S = 5·(560/λ) for Coral Cream: the recovered S agrees (4-digit data)
    coral = result.accepted[0]
    on_measured = np.isin(coral.wavelengths, np.arange(400.0, 701.0, 10.0))
    np.testing.assert_allclose(coral.S[on_measured], 5.0 * 560.0 / coral.wavelengths[on_measured], rtol=2e-2)
    rejected = dict(result.rejected)
    assert rejected["line 19"] == "SPECTRAL_NM410 'oops' is not a finite number"
    assert "role" in rejected["sample 'Mystery sample'"]
    assert rejected["material 'Lonely Shade'"] == "missing the R and Rg samples"
    assert any("percent" in n for n in result.notes)


def test_cgats_name_only_for_one_material() -> None:
    with pytest.raises(MeasurementImportError, match="--name can only be used"):
        read_cgats(DATA / "two_shades_cgats.txt", name="One")


def test_xrite_nm_fields_and_missing_thickness() -> None:
    path = DATA / "xrite_single.txt"
    with pytest.raises(MeasurementImportError, match="thickness D is not given"):
        import_file(path)
    result = import_file(path, thickness_mm=0.15, name="Spectrolino sample")
    assert [m.name for m in result.accepted] == ["Spectrolino sample"]
    m = result.accepted[0]
    assert m.measurement is not None and m.measurement.instrument == "Spectrolino"
    np.testing.assert_allclose(m.S[::2], 8.0 * 560.0 / m.wavelengths[::2], rtol=2e-2)


def test_cgats_without_spectral_fields(tmp_path: Path) -> None:
    path = tmp_path / "lab.txt"
    path.write_text("CGATS.17\nBEGIN_DATA_FORMAT\nSAMPLE_ID LAB_L LAB_A LAB_B\nEND_DATA_FORMAT\nBEGIN_DATA\n"
                    "1 50 0 0\nEND_DATA\n")
    with pytest.raises(MeasurementImportError, match="no spectral fields"):
        import_file(path, thickness_mm=0.15)


def test_export_then_import_round_trip(tmp_path: Path) -> None:
    m = km.default_library().get("Blush Rose")
    path = export_csv(m, tmp_path / "rose.csv")
    text = path.read_text()
    assert text.startswith("# name: Blush Rose\n") and "S_per_mm" in text
    back = read_csv(path)
    assert back.rejected == [] and back.notes == ["ignored columns s_per_mm, k_per_mm"]
    b = back.accepted[0]
    assert (b.name, b.category, b.source) == ("Blush Rose", "blush", "modelled")
    assert "Original provenance: Modelled, not measured" in b.provenance
    np.testing.assert_allclose(b.S, m.S, rtol=1e-8)
    np.testing.assert_allclose(b.K, m.K, rtol=1e-8, atol=1e-12)


def test_export_of_a_material_without_measurement(tmp_path: Path) -> None:
    s = np.full(GRID.size, 10.0)
    k = np.linspace(0.5, 5.0, GRID.size)
    m = Material(name="Bare", category="other", wavelengths=GRID, S=s, K=k)
    back = read_csv(export_csv(m, tmp_path / "bare.csv")).accepted[0]
    np.testing.assert_allclose(back.S, s, rtol=1e-8)
    np.testing.assert_allclose(back.K, k, rtol=1e-8)


def _decimal_comma_lines(wl: np.ndarray, cols: tuple[np.ndarray, ...], sep: str) -> list[str]:
    """Data rows as a spreadsheet in a decimal-comma locale (German, French) writes them."""
    return [sep.join([f"{w:g}"] + [repr(float(c[i])).replace(".", ",") for c in cols]) for i, w in enumerate(wl)]


@pytest.mark.parametrize("sep", [";", "\t"])
def test_decimal_commas_read_as_decimals_where_the_comma_cannot_separate_columns(tmp_path: Path, sep: str) -> None:
    s = 30.0 * (560.0 / GRID)
    k = 5.0 + 4.0 * np.sin(GRID / 40.0)
    cols = _triplet(s, k, 0.15)
    lines = ["# D_mm: 0,15", sep.join(["Wavelength (nm)", "R_inf", "R", "Rg"])]
    path = tmp_path / "de.csv"
    path.write_text("\n".join(lines + _decimal_comma_lines(GRID, cols, sep)) + "\n", encoding="utf-8")
    result = read_csv(path)
    assert result.rejected == [] and len(result.accepted) == 1
    m = result.accepted[0]
    assert m.measurement is not None and m.measurement.D_mm == 0.15
    np.testing.assert_allclose(m.S, s, rtol=1e-9)  # the same numbers as a file written with '.'
    np.testing.assert_allclose(m.K, k, rtol=1e-9)


def test_quoted_decimal_commas_in_a_comma_separated_file(tmp_path: Path) -> None:
    s, k = np.full(GRID.size, 20.0), np.full(GRID.size, 2.0)
    cols = _triplet(s, k, 0.1)
    rows = [",".join([f"{w:g}"] + [f'"{float(c[i])!r}"'.replace(".", ",") for c in cols]) for i, w in enumerate(GRID)]
    path = tmp_path / "quoted.csv"
    path.write_text("\n".join(["# D_mm: 0.1", "wavelength,R_inf,R,Rg", *rows]) + "\n", encoding="utf-8")
    m = read_csv(path).accepted[0]
    np.testing.assert_allclose(m.S, s, rtol=1e-9)
    np.testing.assert_allclose(m.K, k, rtol=1e-9)


def test_unquoted_decimal_commas_in_a_comma_separated_file_are_refused_in_one_line(tmp_path: Path, capsys) -> None:
    from app.cli import main

    cols = _triplet(np.full(GRID.size, 20.0), np.full(GRID.size, 2.0), 0.1)
    path = tmp_path / "ambiguous.csv"
    path.write_text("\n".join(["# D_mm: 0,1", "wavelength,R_inf,R,Rg", *_decimal_comma_lines(GRID, cols, ",")])
                    + "\n", encoding="utf-8")
    library = tmp_path / "lib.json"
    assert main(["materials", "import", str(path), "--library", str(library)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"sheer: error: {path}: line 3: ") and "\n" not in err, err
    assert "decimal commas in a comma-separated file" in err
    assert not library.exists()  # nothing was saved
