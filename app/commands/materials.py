"""``sheer materials``: list, show, plot and import cosmetic materials.

- ``sheer materials list [--category C] [--library PATH]``
- ``sheer materials show NAME [--library PATH]``: properties, provenance and a spectral table
- ``sheer materials plot NAME --out FILE.png [--library PATH]``: R∞, R, Rg, S, K, R0 and T against wavelength
- ``sheer materials import FILE [--library PATH] [--thickness-mm D] [--name NAME] [--category C]``
- ``sheer materials export NAME --out FILE.csv [--library PATH]``

Without ``--library`` the default library is used, read-only: ``import`` then only checks the file and
reports what it would import ("checked N materials … nothing saved"); with ``--library`` it adds them to that
library, creating the file if it does not exist yet.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import argparse
    from collections.abc import Callable

    from app.commands import Subcommands
    from km.library import Library
    from km.material import Material


def register(sub: Subcommands) -> None:
    """Add ``sheer materials`` and its sub-commands to the sub-command parsers ``sub``."""
    from app.commands import LIBRARY_HELP, command_group

    msub = command_group(sub, "materials", "list, show, plot and import cosmetic materials", __doc__)
    q = msub.add_parser("list", help="list materials")
    q.add_argument("--category", help="only this category (e.g. foundation, lipstick)")
    q.add_argument("--library", type=Path, help=LIBRARY_HELP)
    q.set_defaults(func=run_list)

    q = msub.add_parser("show", help="show a material's properties, provenance and spectra")
    q.add_argument("name", help="material name (case-insensitive)")
    q.add_argument("--library", type=Path, help=LIBRARY_HELP)
    q.add_argument("--step-nm", type=float, default=20.0, help="wavelength step of the table (nm, default 20)")
    q.set_defaults(func=run_show)

    for command, what, out, func in (("plot", "plot a material's spectra to a PNG file", "PNG", run_plot),
                                     ("export", "write a material's measurement, S and K as CSV (re-importable)",
                                      "CSV", run_export)):
        q = msub.add_parser(command, help=what)
        q.add_argument("name", help="material name (case-insensitive)")
        q.add_argument("--out", type=Path, required=True, help=f"output {out} file")
        q.add_argument("--library", type=Path, help=LIBRARY_HELP)
        q.set_defaults(func=func)

    q = msub.add_parser("import", help="import a measurement (CSV or X-Rite/CGATS) into a library")
    q.add_argument("file", type=Path, help="CSV (wavelength, R_inf, R, Rg) or X-Rite/CGATS spectral file")
    q.add_argument("--library", type=Path, help="library to add to (created if missing); without it the "
                                                "import is only checked and reported")
    q.add_argument("--thickness-mm", type=float, help="thickness D of the R sample in mm (overrides the file)")
    q.add_argument("--name", help="material name (default: from the file)")
    q.add_argument("--category", help="material category (default: from the file, else 'other')")
    q.add_argument("--replace", action="store_true", help="replace materials of the same name")
    q.set_defaults(func=run_import)


def _library(path: Path | None) -> Library:
    from km.library import Library, default_library

    return default_library() if path is None else Library.load(path)


def run_list(args: argparse.Namespace) -> int:
    """Print one line per material (name, category, opaque colour, default thickness in µm, source); returns 0."""
    lib = _library(args.library)
    mats = lib.materials if args.category is None else lib.by_category(args.category)
    if args.category is not None and not mats:
        from core.errors import SheerError

        raise SheerError(f"no materials in category {args.category!r}; categories: {', '.join(lib.categories())}")
    width = max([len(m.name) for m in mats] + [4])
    print(f"{'name':<{width}}  {'category':<12} {'colour':<8} {'µm':>5}  source")
    for m in mats:
        print(f"{m.name:<{width}}  {m.category:<12} {_hex(m):<8} {m.thickness_um:>5g}  {m.source}")
    print(f"{len(mats)} material{'s' if len(mats) != 1 else ''}")
    return 0


def _hex(m: Material) -> str:
    try:
        return m.swatch_hex()
    except Exception:  # the colour is decoration here: never fail a listing for it
        return "?"


def run_show(args: argparse.Namespace) -> int:
    """Print a material's properties, provenance and a spectral table (every ``--step-nm`` nm); returns 0."""
    import textwrap

    import numpy as np

    from core.errors import SheerError

    if not (args.step_nm > 0):
        raise SheerError("--step-nm must be positive")
    m = _library(args.library).get(args.name)
    r0, t = m.rt()
    r_inf = m.r_inf()
    rows = [
        ("name", m.name), ("category", m.category), ("source", m.source),
        ("wavelengths", f"{m.wavelengths.size} samples, {m.wavelengths[0]:g}–{m.wavelengths[-1]:g} nm"),
        ("thickness", f"{m.thickness_um:g} µm (maximum {m.max_thickness_um:g} µm)"),
        ("roughness", f"{m.roughness:g}"), ("index of refraction", f"{m.ior:g}"),
        ("colour (opaque)", m.swatch_hex("opaque")),
        ("colour over black", f"{m.swatch_hex('black')} at {m.thickness_um:g} µm"),
        ("colour over white", f"{m.swatch_hex('white')} at {m.thickness_um:g} µm"),
    ]
    meas = m.measurement
    if meas is not None:
        rows.append(("measurement", f"R∞, R over Rg at D = {meas.D_mm:g} mm, {meas.wavelengths.size} samples "
                                    f"{meas.wavelengths[0]:g}–{meas.wavelengths[-1]:g} nm"))
        if meas.instrument:
            rows.append(("instrument", meas.instrument))
        if meas.illuminant:
            rows.append(("illuminant", meas.illuminant))
        if meas.saunderson:
            rows.append(("Saunderson", f"k1 = {meas.saunderson[0]:g}, k2 = {meas.saunderson[1]:g}"))
    w = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{w}}  {v}")
    print("provenance")
    print(textwrap.fill(m.provenance or "(none)", width=100, initial_indent="  ", subsequent_indent="  "))
    print()
    wl = m.wavelengths
    picks = [i for i, x in enumerate(wl) if abs((x - wl[0]) / args.step_nm - round((x - wl[0]) / args.step_nm)) < 1e-6]
    head = f"{'nm':>6} {'S /mm':>10} {'K /mm':>10} {'R∞':>7} {'R0':>7} {'T':>7}"
    if meas is not None:
        head += f" {'meas R∞':>8} {'meas R':>7} {'Rg':>7}"
        mi = [np.interp(wl, meas.wavelengths, a) for a in (meas.R_inf, meas.R, meas.Rg)]
    print(head + f"   (R0, T at {m.thickness_um:g} µm)")
    for i in picks:
        line = f"{wl[i]:>6g} {m.S[i]:>10.4g} {m.K[i]:>10.4g} {r_inf[i]:>7.4f} {r0[i]:>7.4f} {t[i]:>7.4f}"
        if meas is not None:
            line += f" {mi[0][i]:>8.4f} {mi[1][i]:>7.4f} {mi[2][i]:>7.4f}"
        print(line)
    return 0


def run_plot(args: argparse.Namespace) -> int:
    """Plot a material's spectra to --out (:func:`plot_material`); returns 0."""
    from core.errors import SheerError

    if args.out.suffix.lower() != ".png":
        raise SheerError(f"--out must name a .png file (got {args.out})")
    return _write_material(args, plot_material)


def plot_material(m: Material, out: Path) -> None:
    """Plot a material's spectra against wavelength, with its swatches, into ``out`` (PNG, written atomically).

    The curves: R∞, R, Rg (the measurement, when there is one), S and K (per mm), and R0, T at the
    material's default thickness (µm).
    """
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    from core.atomicio import atomic_write_with

    wl = m.wavelengths
    r0, t = m.rt()
    fig = Figure(figsize=(10, 4.4), dpi=100)
    ax1, ax2 = fig.subplots(1, 2)
    meas = m.measurement
    if meas is not None:
        kind = "measured" if m.source == "measured" else "synthetic measurement"
        ax1.plot(meas.wavelengths, meas.R_inf, color="tab:green", lw=2, label=f"R∞ ({kind})")
        ax1.plot(meas.wavelengths, meas.R, color="tab:red", lw=2, label=f"R over Rg, D = {meas.D_mm:g} mm")
        ax1.plot(meas.wavelengths, meas.Rg, color="tab:blue", lw=2, label="Rg (background)")
    else:
        ax1.plot(wl, m.r_inf(), color="tab:green", lw=2, label="R∞ (from S, K)")
    ax1.plot(wl, r0, color="black", ls="--", label=f"R0 at {m.thickness_um:g} µm")
    ax1.plot(wl, t, color="tab:purple", ls="--", label=f"T at {m.thickness_um:g} µm")
    ax1.set_xlabel("wavelength (nm)")
    ax1.set_ylabel("reflectance / transmittance (fraction)")
    ax1.set_ylim(0, 1.05)
    ax1.set_title("reflectance and transmittance")
    ax1.legend(fontsize=7, loc="best")
    ax1.grid(alpha=0.3)
    ax2.plot(wl, m.S, color="tab:blue", label="S (scattering)")
    ax2.plot(wl, m.K, color="tab:red", label="K (absorption)")
    ax2.set_xlabel("wavelength (nm)")
    ax2.set_ylabel("coefficient (per mm)")
    ax2.set_title("Kubelka–Munk coefficients")
    if max(float(m.S.max()), float(m.K.max())) > 0 and min(float(m.S.min()), float(m.K.min())) > 0:
        ax2.set_yscale("log")
    ax2.legend(fontsize=7, loc="best")
    ax2.grid(alpha=0.3)
    # swatches: opaque, over black and over white at the default thickness
    for i, (label, bg) in enumerate((("opaque", "opaque"), ("on black", "black"), ("on white", "white"))):
        rgb = tuple(float(c) for c in m.swatch_rgb(bg))
        x0 = 0.80 + i * 0.065
        fig.patches.append(Rectangle((x0, 0.905), 0.055, 0.07, transform=fig.transFigure, facecolor=rgb,
                                     edgecolor="0.5", lw=0.8))
        fig.text(x0 + 0.0275, 0.885, label, ha="center", va="top", fontsize=7)
    fig.suptitle(f"{m.name} ({m.category}, {m.source})", x=0.02, ha="left", fontsize=11)
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.12, top=0.80, wspace=0.28)
    atomic_write_with(out, lambda fh: fig.savefig(fh, format="png"))


def run_import(args: argparse.Namespace) -> int:
    """Check a measurement file and report it; with ``--library`` add its materials to that library.

    Returns:
        0, or 1 when nothing in the file could be imported.
    """
    from km.library import Library
    from km.measurement_files import import_file

    lib = None
    if args.library is not None and args.library.exists():
        lib = Library.load(args.library)  # read first: a broken library stops before any work
    result = import_file(args.file, thickness_mm=args.thickness_mm, name=args.name, category=args.category)
    checked_only = args.library is None  # one word for one thing: "checked" here, "imported" once saved
    print(result.report(verb="checked" if checked_only else "imported"))
    if not result.accepted:
        print("sheer: error: nothing could be imported", file=sys.stderr)
        return 1
    if checked_only:
        print("nothing saved: pass --library PATH to add the material" + ("s" if len(result.accepted) != 1 else "")
              + " to a library")
        return 0
    if lib is None:
        lib = Library(name=args.library.stem)
    from km.library import LibraryError

    for m in result.accepted:
        if m.name in lib and not args.replace:
            raise LibraryError(f"{args.library}: a material named {lib.get(m.name).name!r} already exists "
                               "(use --name or --replace); nothing was saved")
        lib.add(m, replace=args.replace)
    lib.save(args.library)
    print(f"saved {len(result.accepted)} material{'s' if len(result.accepted) != 1 else ''} to {args.library}")
    return 0


def run_export(args: argparse.Namespace) -> int:
    """Write a material's measurement, S and K as a re-importable CSV to --out; returns 0."""
    from km.measurements import export_csv

    return _write_material(args, export_csv)


def _write_material(args: argparse.Namespace, write: Callable[[Material, Path], object]) -> int:
    """Write material ``args.name`` of ``args.library`` to ``args.out`` with ``write``; returns 0.

    Raises:
        SheerError: the folder of ``args.out`` does not exist, or the library has no such material.
    """
    from core.errors import SheerError

    if not args.out.parent.exists() and str(args.out.parent):
        raise SheerError(f"{args.out.parent}: no such folder")
    write(_library(args.library).get(args.name), args.out)
    print(f"wrote {args.out}")
    return 0
