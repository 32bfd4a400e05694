"""Kubelka–Munk measurements: (R∞, R, Rg at thickness D) imported from CSV and exported as CSV.

This module holds the CSV reader and writer and the checks and inversion every importer shares;
:mod:`km.measurement_files` reads X-Rite/CGATS and detects a file's format. Imported triplets are inverted
to materials (S and K per mm).

CSV
---
One header row naming the columns, then one row per wavelength; ``#`` lines before the header carry
metadata as ``# key: value`` (or ``key = value``). Columns (names are case-insensitive, units in
brackets are ignored, extra columns are ignored): ``wavelength`` (nm; also ``wavelength_nm``, ``nm``, ``lambda``), ``R_inf`` (also ``Rinf``,
``R∞``), ``R`` (also ``R_black``), ``Rg`` (also ``R_g``). Reflectances are fractions in [0, 1].
Metadata keys: ``D_mm`` (thickness of the R sample in mm; ``--thickness-mm`` overrides it), ``name``,
``category``, ``instrument``, ``illuminant``, ``saunderson_k1``, ``saunderson_k2``, ``source``
(``measured``, the default, or ``modelled``) and ``provenance``. Comma, semicolon
or tab separated. Numbers are read the same in every locale: ``.`` is the decimal separator, and so is a
``,`` between digits where it cannot be a column separator — a semicolon- or tab-separated file (as a
spreadsheet in a decimal-comma locale such as German or French writes it: ``400;0,5;0,3;0,05``), a quoted
value, a ``# D_mm: 0,15`` line. In a comma-separated file an unquoted decimal comma splits a value in two:
a row with more values than the header has columns is refused in one line (never read as other numbers).
:func:`export_csv` writes this format (plus S and K columns), so an export imports.

X-Rite / CGATS (ISO 28178, ANSI CGATS.17)
-----------------------------------------
A ``BEGIN_DATA_FORMAT`` block naming the fields (spectral fields ``SPECTRAL_NM380``, ``SPECTRAL_NM_380``
or X-Rite's ``nm380``), and a ``BEGIN_DATA`` block with one sample per row. Each material needs three
samples whose ``SAMPLE_NAME`` (else ``SAMPLE_ID``) ends in its role: ``"<material> R_inf"``,
``"<material> R"``, ``"<material> Rg"`` (separated by a space, ``:``, ``_``, ``/`` or ``-``; ``Rinf`` and
``R∞`` also work). Header keywords ``D_MM`` (or ``SAMPLE_THICKNESS_MM``), ``INSTRUMENTATION`` and
``ILLUMINATION_NAME`` are used when present. Values above 1 mean the file is in percent (divided by 100).

Both importers resample linearly onto the wavelength grid (380–780 nm in 5 nm steps by default; grid
points outside the measured range are dropped), invert with :func:`km.invert_sk`, and report in
:attr:`ImportResult.rejected` every row, sample or wavelength they left out and why. They never raise for
bad rows; a file that cannot be read at all raises :class:`MeasurementImportError`.
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from core.errors import SheerError
from core.files import read_bounded
from km.material import Material, MaterialError, Measurement

if TYPE_CHECKING:
    from collections.abc import Sequence

#: Largest measurement file read, in bytes.
MAX_IMPORT_BYTES = 16 * 1024 * 1024
#: Most data rows read from one file.
MAX_ROWS = 200_000

#: Typical layer thickness (µm), the most a brush builds up (µm), roughness and index of refraction by
#: category, used for imported materials (a material's own values can be edited afterwards).
CATEGORY_DEFAULTS: dict[str, tuple[float, float, float, float]] = {
    "foundation": (20.0, 80.0, 0.35, 1.45),
    "concealer": (25.0, 100.0, 0.40, 1.45),
    "blush": (10.0, 40.0, 0.45, 1.45),
    "bronzer": (10.0, 40.0, 0.45, 1.45),
    "highlighter": (8.0, 30.0, 0.20, 1.60),
    "lipstick": (15.0, 60.0, 0.20, 1.50),
    "eyeshadow": (10.0, 40.0, 0.40, 1.50),
    "eyeliner": (10.0, 40.0, 0.30, 1.50),
}
_FALLBACK_DEFAULTS = (20.0, 100.0, 0.35, 1.45)

Rejection = tuple[str, str]


class MeasurementImportError(SheerError, ValueError):
    """A measurement file that cannot be read at all (missing, too large, no header, wrong format)."""


@dataclass
class ImportResult:
    """What an import produced: the materials, and every rejected ``(where, reason)``.

    ``where`` is e.g. ``"line 12"``, ``"sample 'Rose R'"`` or ``"Rose: 455 nm"``.
    """

    source: str
    accepted: list[Material] = field(default_factory=list)
    rejected: list[Rejection] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def report(self, verb: str = "imported") -> str:
        """A readable multi-line summary; ``verb`` says what was done ("checked" when nothing is saved)."""
        lines = [f"{self.source}: {verb} {len(self.accepted)} material{'s' if len(self.accepted) != 1 else ''}"]
        for m in self.accepted:
            wl = m.wavelengths
            lines.append(f"  + {m.name} ({m.category}, {wl.size} wavelengths {wl[0]:g}–{wl[-1]:g} nm, "
                         f"D = {m.measurement.D_mm:g} mm)" if m.measurement else f"  + {m.name}")
        lines += [f"  note: {n}" for n in self.notes]
        if self.rejected:
            lines.append(f"rejected {len(self.rejected)}:")
            lines += [f"  - {where}: {reason}" for where, reason in self.rejected]
        return "\n".join(lines)


# --------------------------------------------------------------------------------------------------
# shared steps (the CSV reader here and the CGATS reader of km.measurement_files)


def default_grid_nm() -> np.ndarray:
    """The default wavelength grid (:data:`km.spectra.DEFAULT_GRID`) in nm, float64."""
    from km.spectra import DEFAULT_GRID

    return np.asarray(DEFAULT_GRID.wavelengths, dtype=np.float64)


def read_measurement_text(path: Path) -> str:
    """A measurement file's text (UTF-8 or Latin-1, bounded; a binary file is a :class:`MeasurementImportError`)."""
    raw = read_bounded(path, MAX_IMPORT_BYTES, "measurement file", MeasurementImportError)
    if b"\x00" in raw[:4096]:
        raise MeasurementImportError(f"{path}: not a text file")
    for encoding in ("utf-8-sig", "latin-1"):  # X-Rite software writes Latin-1 (°) as often as UTF-8
        try:
            return raw.decode(encoding)
        except UnicodeDecodeError:
            continue
    raise AssertionError("latin-1 decodes any bytes")  # pragma: no cover


def parse_number(text: str) -> float | None:
    """``text`` as a float, or None when it is not a number."""
    try:
        x = float(text.strip())
    except ValueError:
        return None
    return x


#: A number written with a decimal comma (``0,5``, ``-1,25e-3``): one comma between digits, no point.
_DECIMAL_COMMA = re.compile(r"\s*[+-]?\d+,\d+(?:[eE][+-]?\d+)?\s*")


def csv_number(text: str) -> float | None:
    """A CSV value or header number as a float, ``.`` or one ``,`` between digits as the decimal separator.

    None when it is not a number. A comma here is never a thousands separator: no measured quantity is
    written with one (a wavelength of "1,050" nm reads as 1.05 nm and is rejected as out of range).
    """
    return parse_number(text.replace(",", ".") if _DECIMAL_COMMA.fullmatch(text) else text)


def format_wavelength(x: float) -> str:
    """A wavelength for messages (``"550 nm"``)."""
    return f"{x:g} nm"


def invert_onto_grid(
    name: str, category: str, wl: np.ndarray, r_inf: np.ndarray, r: np.ndarray, rg: np.ndarray, d_mm: float,
    grid: np.ndarray, *, instrument: str, illuminant: str, saunderson: tuple[float, float] | None,
    provenance: str, rejected: list[Rejection], source: str = "measured",
) -> Material | None:
    """Resample a raw triplet onto ``grid``, invert it, and build the material (None if nothing is left)."""
    from km.optics import invert_sk

    if wl.size < 2:
        rejected.append((name, f"only {wl.size} valid wavelength{'s' if wl.size != 1 else ''}; need at least 2"))
        return None
    inside = (grid >= wl[0] - 1e-9) & (grid <= wl[-1] + 1e-9)
    outside = grid[~inside]
    if outside.size:
        parts = [_span(part) for part in (grid[grid < wl[0] - 1e-9], grid[grid > wl[-1] + 1e-9]) if part.size]
        rejected.append((name, f"{outside.size} grid wavelength{'s' if outside.size > 1 else ''} outside the "
                               f"measured range {wl[0]:g}–{wl[-1]:g} nm left out ({' and '.join(parts)})"))
    g = grid[inside]
    if g.size < 2:
        rejected.append((name, "the measured range holds fewer than 2 grid wavelengths"))
        return None
    # km.spectra resamples linearly (not colour-science's Sprague/cubic): it cannot overshoot, so
    # Rg < R < R∞ at the measured wavelengths stays true in between and 0 ≤ values ≤ 1 hold.
    from km.spectra import WavelengthGrid

    ri, rr, rgg = WavelengthGrid.from_wavelengths(g).resample(np.stack([r_inf, r, rg]), wl)
    if saunderson is None:
        kinds = _domain_reasons(ri, rr, rgg)
        suffix = ""
    else:
        from km.optics import inverse_saunderson

        ri_c, rr_c, rgg_c = (inverse_saunderson(a, *saunderson) for a in (ri, rr, rgg))
        kinds = _domain_reasons(ri_c, rr_c, rgg_c)
        suffix = " (internal reflectances, after the Saunderson correction)"
    inversion = invert_sk(ri, rr, rgg, d_mm, clip=True, saunderson=saunderson, wavelengths=g)
    s = np.asarray(inversion.S, dtype=np.float64)
    k = np.asarray(inversion.K, dtype=np.float64)
    bad = np.asarray(inversion.invalid) | ~(np.isfinite(s) & np.isfinite(k) & (s >= 0) & (k >= 0))
    # one line per run of neighbouring grid wavelengths rejected for the same reason (each wavelength
    # is still named: by the run's range and count), with the values at the first one as an example
    bad_idx = list(np.flatnonzero(bad))
    while bad_idx:
        i = bad_idx.pop(0)
        kind = kinds[i] or "the inversion gave no finite S, K"
        j = i
        while bad_idx and bad_idx[0] == j + 1 and (kinds[bad_idx[0]] or "the inversion gave no finite S, K") == kind:
            j = bad_idx.pop(0)
        where = f"{name}: {format_wavelength(g[i])}" if i == j else f"{name}: {g[i]:g}–{g[j]:g} nm ({j - i + 1} wavelengths)"
        example = f"R∞ = {ri[i]:.6g}, R = {rr[i]:.6g}, Rg = {rgg[i]:.6g}"
        rejected.append((where, f"{kind}{suffix} ({'at ' + format_wavelength(g[i]) + ': ' if i != j else ''}{example})"))
    keep = ~bad
    if keep.sum() < 2:
        rejected.append((name, "fewer than 2 wavelengths could be inverted; material not imported"))
        return None
    thickness, max_thickness, roughness, ior = CATEGORY_DEFAULTS.get(category, _FALLBACK_DEFAULTS)
    measurement = Measurement(wl, r_inf, r, rg, d_mm, instrument=instrument, illuminant=illuminant,
                              saunderson=saunderson)
    try:
        return Material(name=name, category=category, wavelengths=g[keep], S=s[keep], K=k[keep],
                        thickness_um=thickness, max_thickness_um=max_thickness, roughness=roughness, ior=ior,
                        source=source, provenance=provenance, measurement=measurement)
    except MaterialError as exc:
        rejected.append((name, str(exc)))
        return None


def _domain_reasons(r_inf: np.ndarray, r: np.ndarray, rg: np.ndarray) -> list[str]:
    """Why the Kubelka–Munk inversion is impossible at each wavelength ('' where it is possible)."""
    out = []
    for a, b, c in zip(r_inf, r, rg, strict=True):
        if not 0.0 < a < 1.0:
            out.append("R∞ is not strictly between 0 and 1")
        elif not 0.0 <= c <= 1.0:
            out.append("Rg is outside [0, 1]")
        elif not (min(a, c) < b < max(a, c)):
            out.append("R is not strictly between Rg and R∞")
        else:
            out.append("")
    return out


def _span(values: np.ndarray) -> str:
    return format_wavelength(values[0]) if values.size == 1 else f"{values[0]:g}–{values[-1]:g} nm"


def _collect_triplet(rows: list[tuple[str, float, float, float, float]], rejected: list[Rejection]
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Sort rows by wavelength, dropping duplicate wavelengths; rows are ``(where, wl, R∞, R, Rg)``."""
    rows = sorted(rows, key=lambda t: t[1])
    kept: list[tuple[str, float, float, float, float]] = []
    for row in rows:
        if kept and abs(row[1] - kept[-1][1]) < 1e-9:
            rejected.append((row[0], f"wavelength {row[1]:g} nm repeats {kept[-1][0]}"))
            continue
        kept.append(row)
    if not kept:
        empty = np.zeros(0)
        return empty, empty, empty, empty
    arr = np.array([t[1:] for t in kept], dtype=np.float64)
    return arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3]


def _check_reflectance(values: dict[str, float], where: str, rejected: list[Rejection]) -> bool:
    for col, v in values.items():
        if not math.isfinite(v):
            rejected.append((where, f"{col} is {v}"))
            return False
        if not 0.0 <= v <= 1.0:
            hint = " (reflectances are fractions, not percent)" if 1.0 < v <= 100.0 else ""
            rejected.append((where, f"{col} = {v:g} is outside [0, 1]{hint}"))
            return False
    return True


def _thickness(value: Any, where: str) -> float:
    d = value if isinstance(value, float) else parse_number(str(value))
    if d is None or not math.isfinite(d) or d <= 0 or d > 100:
        raise MeasurementImportError(f"{where}: the sample thickness D must be a number of mm in (0, 100] "
                                     f"(got {value!r})")
    return d


def sample_thickness(given: float | None, found: Any, where: str, missing: str) -> float:
    """The thickness D (mm, in (0, 100]) of the R sample.

    ``given`` (the ``--thickness-mm`` option) wins over ``found`` (the file's own value, or None); ``where``
    names the file's field in messages, ``missing`` says how to give D when neither is there.
    """
    if given is not None:
        return _thickness(given, "--thickness-mm")
    if found is not None:
        return _thickness(found, where)
    raise MeasurementImportError(f"{missing} or pass --thickness-mm")


def saunderson_coefficients(meta: dict[str, str], where: str) -> tuple[float, float] | None:
    """The header's Saunderson (k1, k2), or None when it gives neither (``where`` names the file in errors)."""
    k1, k2 = meta.get("saunderson_k1"), meta.get("saunderson_k2")
    if k1 is None and k2 is None:
        return None
    a = parse_number(k1 or "")
    b = parse_number(k2 or "")
    if a is None or b is None or not (0 <= a < 1 and 0 <= b < 1):
        raise MeasurementImportError(f"{where}: saunderson_k1 and saunderson_k2 must both be numbers in [0, 1)")
    return (a, b)


# --------------------------------------------------------------------------------------------------
# CSV

_CSV_COLUMNS: dict[str, tuple[str, ...]] = {
    "wavelength": ("wavelength", "wavelength_nm", "wavelengths", "nm", "lambda", "lambda_nm", "wl"),
    "R_inf": ("r_inf", "rinf", "r∞", "r_infinity", "r_opaque"),
    "R": ("r", "r_black", "r_d", "r_sample"),
    "Rg": ("rg", "r_g", "r_background", "background"),
}
#: Metadata keys whose values are numbers (read with :func:`csv_number`).
_NUMERIC_META = ("d_mm", "d", "saunderson_k1", "saunderson_k2")
_META_RE = re.compile(r"^#\s*([A-Za-z_][A-Za-z0-9_ ]*?)\s*[:=]\s*(.*?)\s*$")


def _column_key(text: str) -> str:
    """Normalised column name: lowercase, units in brackets dropped, spaces as underscores.

    ``"Wavelength (nm)"`` → ``wavelength``, ``"R inf"`` → ``r_inf``.
    """
    key = re.sub(r"[\(\[].*?[\)\]]", "", text.strip().strip('"')).strip().lower()
    return re.sub(r"\s+", "_", key)


def read_csv(path: str | Path, *, thickness_mm: float | None = None, name: str | None = None,
             category: str | None = None, grid: np.ndarray | Sequence[float] | None = None) -> ImportResult:
    """Import one material from a CSV triplet file (see the module docstring).

    ``thickness_mm`` (D, mm) overrides the file's ``D_mm``; ``name`` and ``category`` override the
    file's metadata (defaults: the file name and ``other``). ``grid``: target wavelengths (nm), default
    380–780 nm in 5 nm steps.
    """
    p = Path(path)
    source = str(p)
    text = read_measurement_text(p)
    result = ImportResult(source=source)
    lines = text.splitlines()
    meta, header_index = _csv_metadata(lines)
    if header_index is None:
        raise MeasurementImportError(f"{source}: no header row (expected columns wavelength, R_inf, R, Rg)")
    delimiter, header, columns = _csv_columns(lines[header_index], header_index, source, result)
    for key in _NUMERIC_META:  # "# D_mm: 0,15" (a decimal comma) is 0.15
        if key in meta and (x := csv_number(meta[key])) is not None:
            meta[key] = repr(x)
    d_mm = sample_thickness(thickness_mm, meta.get("d_mm", meta.get("d")), f"{source}: header D_mm",
                             f"{source}: the sample thickness D is not given: add a '# D_mm: 0.15' header line")
    saunderson = saunderson_coefficients(meta, source)
    rows = _csv_rows(lines[header_index + 1:], header_index, delimiter, header, columns, source, result)
    wl, r_inf, r, rg = _collect_triplet(rows, result.rejected)
    mat_name = name or meta.get("name") or p.stem
    mat_category = (category or meta.get("category") or "other").strip().lower()
    target = default_grid_nm() if grid is None else np.asarray(grid, dtype=np.float64)
    source_kind = meta.get("source", "measured").strip().lower()
    if source_kind not in ("measured", "modelled"):
        result.notes.append(f"unknown source {source_kind!r} in the header: taken as measured")
        source_kind = "measured"
    provenance = (f"{source_kind.capitalize()}: imported from {p.name} (CSV; R∞, R over a background of "
                  f"reflectance Rg at D = {d_mm:g} mm), inverted with Kubelka–Munk Eq. 6–7"
                  + (f" with Saunderson k1 = {saunderson[0]:g}, k2 = {saunderson[1]:g}" if saunderson else "")
                  + "." + (f" Original provenance: {meta['provenance']}" if meta.get("provenance") else ""))
    material = invert_onto_grid(
        mat_name, mat_category, wl, r_inf, r, rg, d_mm, target, instrument=meta.get("instrument", ""),
        illuminant=meta.get("illuminant", ""), saunderson=saunderson, provenance=provenance,
        rejected=result.rejected, source=source_kind)
    if material is not None:
        result.accepted.append(material)
    return result


def _csv_metadata(lines: list[str]) -> tuple[dict[str, str], int | None]:
    """The ``# key: value`` lines above the header (keys lower case, spaces as ``_``) and the header's index.

    The index is None when the file has no header row.
    """
    # Hand-written on purpose: colour-science's CSV reader (numpy.genfromtxt) turns a bad cell into NaN
    # and aborts or skips ragged rows without saying which line, and ignores metadata; we must report
    # every rejected row with its line number and reason, and read D from the header.
    meta: dict[str, str] = {}
    header_index: int | None = None
    for i, line in enumerate(lines):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            m = _META_RE.match(stripped)
            if m:
                meta[m.group(1).strip().lower().replace(" ", "_")] = m.group(2).strip().strip('"')
            continue
        header_index = i
        break
    return meta, header_index


def _csv_columns(header_line: str, header_index: int, source: str, result: ImportResult
                 ) -> tuple[str, list[str], dict[str, int]]:
    """The delimiter (tab, semicolon or comma), the header's column keys and each needed column's index.

    :class:`MeasurementImportError` when a column is missing or repeated; the others are noted as ignored.
    """
    delimiter = "\t" if "\t" in header_line else (";" if ";" in header_line and "," not in header_line else ",")
    header = [_column_key(h) for h in next(csv.reader([header_line], delimiter=delimiter))]
    columns: dict[str, int] = {}
    for key, aliases in _CSV_COLUMNS.items():
        found = [j for j, h in enumerate(header) if h in aliases]
        if not found:
            raise MeasurementImportError(
                f"{source}: line {header_index + 1}: no {key} column (header: {', '.join(header) or 'empty'}; "
                f"expected wavelength, R_inf, R, Rg)")
        if len(found) > 1:
            raise MeasurementImportError(f"{source}: line {header_index + 1}: more than one {key} column")
        columns[key] = found[0]
    ignored = [h for j, h in enumerate(header) if j not in columns.values()]
    if ignored:
        result.notes.append(f"ignored column{'s' if len(ignored) > 1 else ''} {', '.join(ignored)}")
    return delimiter, header, columns


def _csv_rows(body: list[str], header_index: int, delimiter: str, header: list[str], columns: dict[str, int],
              source: str, result: ImportResult) -> list[tuple[str, float, float, float, float]]:
    """The valid data rows as (where, wavelength nm, R_inf, R, Rg); the others go to ``result.rejected``."""
    rows: list[tuple[str, float, float, float, float]] = []
    if len(body) > MAX_ROWS:
        raise MeasurementImportError(f"{source}: too many rows ({len(body)}, at most {MAX_ROWS})")
    reader = csv.reader(io.StringIO("\n".join(body)), delimiter=delimiter)
    for offset, cells in enumerate(reader):
        where = f"line {header_index + 2 + offset}"
        if not cells or all(not c.strip() for c in cells) or cells[0].lstrip().startswith("#"):
            continue
        if len(cells) < len(header):
            result.rejected.append((where, f"{len(cells)} values, the header has {len(header)} columns"))
            continue
        if delimiter == "," and any(c.strip() for c in cells[len(header):]):
            raise MeasurementImportError(
                f"{source}: {where}: {len(cells)} values but the header has {len(header)} columns: decimal "
                "commas in a comma-separated file? Separate the columns with ';' or tabs, or write decimals "
                "with '.'; nothing was imported")
        values: dict[str, float] = {}
        for key, j in columns.items():
            x = csv_number(cells[j])
            if x is None:
                result.rejected.append((where, f"{key} {cells[j].strip()!r} is not a number"))
                break
            values[key] = x
        else:
            nm = values.pop("wavelength")
            if not math.isfinite(nm) or not 200.0 <= nm <= 3000.0:
                result.rejected.append((where, f"wavelength {nm:g} nm is outside 200–3000 nm"))
                continue
            if _check_reflectance(values, where, result.rejected):
                rows.append((where, nm, values["R_inf"], values["R"], values["Rg"]))
    return rows


def export_csv(material: Material, path: str | Path) -> Path:
    """Write a material as CSV (atomically); :func:`read_csv` reads the file back.

    Its measurement triplet on the material's wavelengths (linearly resampled) with ``# D_mm`` and the
    other metadata, plus ``S_per_mm`` and ``K_per_mm`` columns. A material without a measurement gets
    the triplet its S and K predict (R∞, R over black at D = 0.15 mm, Rg = 0).
    """
    from core.atomicio import atomic_write_text

    wl = material.wavelengths
    meas = material.measurement
    if meas is not None:
        d_mm = meas.D_mm
        r_inf, r, rg = (np.interp(wl, meas.wavelengths, a) for a in (meas.R_inf, meas.R, meas.Rg))
        instrument, illuminant, saunderson = meas.instrument, meas.illuminant, meas.saunderson
    else:
        from km.optics import over

        d_mm = 0.15
        r_inf = material.r_inf()
        rg = np.zeros_like(wl)
        r0, t = material.rt(d_mm * 1000.0)
        r = over(r0, t, rg)
        instrument, illuminant, saunderson = "", "", None
    out = io.StringIO()
    out.write(f"# name: {material.name}\n# category: {material.category}\n# D_mm: {d_mm!r}\n")
    if instrument:
        out.write(f"# instrument: {instrument}\n")
    if illuminant:
        out.write(f"# illuminant: {illuminant}\n")
    if saunderson:
        out.write(f"# saunderson_k1: {saunderson[0]!r}\n# saunderson_k2: {saunderson[1]!r}\n")
    out.write(f"# source: {material.source}\n")
    if material.provenance:
        out.write("# provenance: " + " ".join(material.provenance.split()) + "\n")
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["wavelength_nm", "R_inf", "R", "Rg", "S_per_mm", "K_per_mm"])
    for row in zip(wl, r_inf, r, rg, material.S, material.K, strict=True):
        writer.writerow([repr(float(x)) for x in row])
    target = Path(path)
    atomic_write_text(target, out.getvalue())
    return target
