"""Spectrophotometer files: the X-Rite/CGATS reader, and the importer that detects a file's format.

:func:`read_cgats` reads CGATS; :func:`import_file` picks CGATS or CSV from the file's content.

The formats, the resampling onto the wavelength grid, the inversion to S and K (per mm) and the rejection
report are described in :mod:`km.measurements`, which holds the CSV reader and the checks shared by both.
"""

from __future__ import annotations

import math
import re
import shlex
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from km.measurements import (
    MAX_ROWS,
    ImportResult,
    MeasurementImportError,
    default_grid_nm,
    format_wavelength,
    invert_onto_grid,
    parse_number,
    read_csv,
    read_measurement_text,
    sample_thickness,
    saunderson_coefficients,
)

if TYPE_CHECKING:
    from collections.abc import Sequence

_SPECTRAL_FIELD_RE = re.compile(r"^(?:SPECTRAL_?)?NM_?(\d+(?:\.\d+)?)$|^SPECTRAL_(\d+(?:\.\d+)?)$", re.IGNORECASE)
_ROLE_RE = re.compile(r"^(?:(?P<base>.*?)[\s:_/-]+)?(?P<role>r_?inf|r∞|r_?infinity|r_?g|r)$", re.IGNORECASE)


def _role(label: str) -> tuple[str, str] | None:
    m = _ROLE_RE.match(label.strip())
    if not m:
        return None
    role = m.group("role").lower().replace("_", "")
    role = {"rinf": "R_inf", "r∞": "R_inf", "rinfinity": "R_inf", "rg": "Rg", "r": "R"}[role]
    return (m.group("base") or "").strip(), role


def read_cgats(path: str | Path, *, thickness_mm: float | None = None, name: str | None = None,
               category: str | None = None, grid: np.ndarray | Sequence[float] | None = None) -> ImportResult:
    """Import materials from an X-Rite / CGATS spectral file (see the module docstring).

    ``name`` may be given only when the file holds one material.
    """
    p = Path(path)
    source = str(p)
    text = read_measurement_text(p)
    result = ImportResult(source=source)
    keywords, fields_, data = _cgats_blocks(text)
    if fields_ is None:
        raise MeasurementImportError(f"{source}: not a CGATS/X-Rite file: no BEGIN_DATA_FORMAT block")
    if len(data) > MAX_ROWS:
        raise MeasurementImportError(f"{source}: too many samples ({len(data)}, at most {MAX_ROWS})")
    spectral, wl_all, label_col = _spectral_columns(fields_, source)
    d_mm = sample_thickness(thickness_mm, keywords.get("D_MM", keywords.get("SAMPLE_THICKNESS_MM")),
                             f"{source}: keyword D_MM",
                             f"{source}: the sample thickness D is not given: add a 'D_MM 0.15' keyword")
    saunderson = saunderson_coefficients({k.lower(): v for k, v in keywords.items()}, source)
    groups, display = _materials(_cgats_samples(data, fields_, spectral, label_col, wl_all, result), result)
    if name is not None and len(groups) > 1:
        raise MeasurementImportError(f"{source}: --name can only be used for a file with one material "
                                     f"(this one has {len(groups)}: {', '.join(display[k] or '?' for k in groups)})")
    target = default_grid_nm() if grid is None else np.asarray(grid, dtype=np.float64)
    instrument = keywords.get("INSTRUMENTATION", "")
    illuminant = keywords.get("ILLUMINATION_NAME", "")
    for key, group in groups.items():
        base = display[key]
        missing = [role for role in ("R_inf", "R", "Rg") if role not in group]
        mat_name = name or base or p.stem
        if missing:
            result.rejected.append((f"material {mat_name!r}", f"missing the {' and '.join(missing)} sample"
                                                              f"{'s' if len(missing) > 1 else ''}"))
            continue
        provenance = (f"Measured: imported from {p.name} (CGATS samples {', '.join(repr(group[r][0]) for r in ('R_inf', 'R', 'Rg'))}"
                      f"; D = {d_mm:g} mm{', instrument ' + instrument if instrument else ''}), inverted with "
                      "Kubelka–Munk Eq. 6–7"
                      + (f" with Saunderson k1 = {saunderson[0]:g}, k2 = {saunderson[1]:g}" if saunderson else "")
                      + ".")
        material = invert_onto_grid(
            mat_name, (category or "other").strip().lower(), wl_all, group["R_inf"][1], group["R"][1],
            group["Rg"][1], d_mm, target, instrument=instrument, illuminant=illuminant, saunderson=saunderson,
            provenance=provenance, rejected=result.rejected)
        if material is not None:
            result.accepted.append(material)
    if not groups and not result.rejected:
        result.rejected.append((source, "no samples in the BEGIN_DATA block"))
    return result


def _cgats_blocks(text: str) -> tuple[dict[str, str], list[str] | None, list[tuple[int, str]]]:
    """A CGATS file's header keywords (upper case), its data format's fields and its data rows.

    The fields are None when the file has no data format block; a row is (line number, line).
    """
    # Hand-written on purpose: colour.read_sds_from_xrite_file (documented as "minimalistic and absolutely
    # not bullet-proof") only knows lowercase 'nmNNN' fields, not CGATS's SPECTRAL_NMNNN, splits quoted
    # sample names at spaces, takes the name from the second column, aborts the whole file on one bad value
    # and drops the header keywords; we need per-row reasons, D and the instrument from the header.
    keywords: dict[str, str] = {}
    fields_: list[str] | None = None
    data: list[tuple[int, str]] = []
    state = "header"
    for lineno, raw_line in enumerate(text.splitlines(), start=1):
        line = raw_line.strip()
        if not line or line.startswith("#"):
            continue
        upper = line.split(None, 1)[0].upper()
        if state == "header":
            if upper == "BEGIN_DATA_FORMAT":
                state, fields_ = "format", []
            elif upper == "BEGIN_DATA":
                state = "data"
            else:
                parts = line.split(None, 1)
                if len(parts) == 2:
                    keywords[parts[0].upper()] = parts[1].strip().strip('"')
        elif state == "format":
            if upper == "END_DATA_FORMAT":
                state = "header"
            else:
                fields_ = (fields_ or []) + line.split()
        elif state == "data":
            if upper == "END_DATA":
                state = "header"
            else:
                data.append((lineno, line))
    return keywords, fields_, data


def _spectral_columns(fields_: list[str], source: str) -> tuple[list[tuple[int, float]], np.ndarray, int]:
    """The spectral fields (column, wavelength nm) in wavelength order, their wavelengths and the label's column.

    :class:`MeasurementImportError` naming ``source`` when there are fewer than two, one repeats, or no field
    names the samples.
    """
    spectral: list[tuple[int, float]] = []
    for j, f in enumerate(fields_):
        m = _SPECTRAL_FIELD_RE.match(f)
        if m:
            spectral.append((j, float(m.group(1) or m.group(2))))
    if len(spectral) < 2:
        raise MeasurementImportError(f"{source}: no spectral fields (SPECTRAL_NM380 … or nm380 …) in the data format")
    upper_fields = [f.upper() for f in fields_]
    label_col = next((upper_fields.index(k) for k in ("SAMPLE_NAME", "SAMPLE_ID") if k in upper_fields), None)
    if label_col is None:
        raise MeasurementImportError(f"{source}: the data format has neither SAMPLE_NAME nor SAMPLE_ID")
    order = np.argsort([wl for _, wl in spectral], kind="stable")
    spectral = [spectral[i] for i in order]
    wl_all = np.array([wl for _, wl in spectral])
    if np.any(np.diff(wl_all) <= 0):
        raise MeasurementImportError(f"{source}: the data format repeats a spectral field")
    return spectral, wl_all, label_col


def _cgats_samples(data: list[tuple[int, str]], fields_: list[str], spectral: list[tuple[int, float]],
                   label_col: int, wl_all: np.ndarray, result: ImportResult) -> list[tuple[str, np.ndarray]]:
    """The valid rows as (label, reflectance in [0, 1] per wavelength); the others go to ``result.rejected``.

    Values above 1 anywhere mean the file is in percent (a note says so).
    """
    samples: list[tuple[str, np.ndarray]] = []  # (label, values) of valid rows
    parsed_rows: list[tuple[str, str, list[float]]] = []
    for lineno, line in data:
        where = f"line {lineno}"
        try:
            tokens = shlex.split(line, posix=True)
        except ValueError as exc:
            result.rejected.append((where, f"cannot split the row: {exc}"))
            continue
        if len(tokens) != len(fields_):
            result.rejected.append((where, f"{len(tokens)} values, the data format has {len(fields_)} fields"))
            continue
        values: list[float] = []
        for j, _wl in spectral:
            x = parse_number(tokens[j])
            if x is None or not math.isfinite(x):
                result.rejected.append((where, f"{fields_[j]} {tokens[j]!r} is not a finite number"))
                break
            values.append(x)
        else:
            parsed_rows.append((where, tokens[label_col], values))
    scale_percent = bool(parsed_rows) and max(max(v) for _, _, v in parsed_rows) > 1.0
    if scale_percent:
        result.notes.append("values above 1 found: the file is read as percent (divided by 100)")
    for where, label, values in parsed_rows:
        arr = np.array(values) / (100.0 if scale_percent else 1.0)
        bad = np.flatnonzero((arr < 0) | (arr > 1))
        if bad.size:
            result.rejected.append((f"{where} ({label})", f"reflectance {arr[bad[0]]:g} at "
                                                          f"{format_wavelength(wl_all[bad[0]])} is outside [0, 1]"))
            continue
        samples.append((label, arr))
    return samples


def _materials(samples: list[tuple[str, np.ndarray]], result: ImportResult
               ) -> tuple[dict[str, dict[str, tuple[str, np.ndarray]]], dict[str, str]]:
    """The samples grouped by material (case-folded name) and role (R_inf, R, Rg), and each material's name.

    A sample without a role, or a role's second sample, goes to ``result.rejected``.
    """
    groups: dict[str, dict[str, tuple[str, np.ndarray]]] = {}
    display: dict[str, str] = {}
    for label, arr in samples:
        r = _role(label)
        if r is None:
            result.rejected.append((f"sample {label!r}", "its name does not end in R_inf, R or Rg, so its role "
                                                         "in the measurement is unknown"))
            continue
        base, role = r
        key = base.casefold()
        display.setdefault(key, base)
        group = groups.setdefault(key, {})
        if role in group:
            result.rejected.append((f"sample {label!r}", f"a second {role} sample for {base or 'the material'!r}"))
            continue
        group[role] = (label, arr)
    return groups, display


# --------------------------------------------------------------------------------------------------


def is_cgats(path: str | Path) -> bool:
    """True if the file looks like X-Rite/CGATS (it has a BEGIN_DATA_FORMAT line)."""
    if not Path(path).is_file():
        return False
    try:
        with open(path, "rb") as fh:
            head = fh.read(64 * 1024)
    except OSError:
        return False
    return b"BEGIN_DATA_FORMAT" in head.upper()


def import_file(path: str | Path, *, thickness_mm: float | None = None, name: str | None = None,
                category: str | None = None, grid: np.ndarray | Sequence[float] | None = None) -> ImportResult:
    """Import a CSV or X-Rite/CGATS measurement file (detected from its content)."""
    reader = read_cgats if is_cgats(path) else read_csv
    return reader(path, thickness_mm=thickness_mm, name=name, category=category, grid=grid)
