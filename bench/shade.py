"""``sheer bench shade --json``: how long the shade finder takes.

- ``match_ms``: :func:`shade.match.match_shades` on one skin for every foundation of the library (best
  thickness of each, ΔE2000 under D65, the metamerism check under D65 / F11 / A), over ``--skins``
  skins fitted from colours across the model's range (the fits are not timed here).
- ``fit_ms``: :func:`km.skin.fit_skin` of one colour (the skin model's least squares).
- ``match_ms_large``: the same match for a library of ``--large`` foundations (Duncan mixtures of the
  default ones), to show how it scales.
- ``coverage_s``: :func:`shade.coverage.coverage` of ``--population`` skins (1,000 by default),
  including the gap shade's optimisation, over ``--repeats`` runs.

Every median comes with its ``_p90`` and ``_max``; the machine's load average is reported. One warm-up
(colour-science's matrices, the fit's table) is not counted.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

from bench.stats import spread
from km.library import default_library
from km.optics import mix
from km.skin import fit_skin, lab_of, skin_reflectance
from shade.coverage import coverage
from shade.match import ShadeBank, foundations, match_shades

__all__ = ["main"]

#: colours the timed skins are fitted from: (melanin, blood) across light to dark
_SKINS = [(m, b) for m in (0.008, 0.02, 0.05, 0.1, 0.2) for b in (0.005, 0.02)]


def _large_bank(bank: ShadeBank, n: int, seed: int = 0) -> ShadeBank:
    """``n`` foundations: random Duncan mixtures of the bank's, with its thickness range."""
    rng = np.random.default_rng(seed)
    S, K = [], []
    for _ in range(n):
        c = rng.dirichlet(np.ones(len(bank.names)))
        s, k = mix([(c[i], bank.S[i], bank.K[i]) for i in range(len(bank.names))])
        S.append(s)
        K.append(k)
    return ShadeBank(names=tuple(f"mix {i}" for i in range(n)), S=np.stack(S), K=np.stack(K),
                     t_lo_um=np.full(n, bank.t_lo_um.min()), t_hi_um=np.full(n, bank.t_hi_um.max()), grid=bank.grid)


def main(argv: list[str]) -> int:
    """Run the benchmark and print one JSON object on stdout; returns 0."""
    parser = argparse.ArgumentParser(prog="sheer bench shade", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--json", action="store_true", help="JSON output (the only format; accepted)")
    parser.add_argument("--skins", type=int, default=len(_SKINS), help="skins the match is timed on (≤ 10)")
    parser.add_argument("--large", type=int, default=100, help="foundations of the large library (default 100)")
    parser.add_argument("--population", type=int, default=1000, help="skins of the coverage run (default 1000)")
    parser.add_argument("--repeats", type=int, default=3, help="coverage runs (default 3)")
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:
        return int(exc.code or 0)
    if not (1 <= args.skins <= len(_SKINS)) or args.repeats < 1 or args.large < 1 or args.population < 1:
        print(f"sheer bench shade: error: --skins must be 1..{len(_SKINS)}; --repeats, --large and --population "
              "at least 1", file=sys.stderr)
        return 2

    bank = ShadeBank.from_materials(foundations(default_library()))
    large = _large_bank(bank, args.large)
    colours = [lab_of(skin_reflectance(m, b)) for m, b in _SKINS[: args.skins]]
    fit_skin(colours[0])  # warm-up: the fit's table, colour-science's matrices
    match_shades(skin_reflectance(0.05, 0.01), skin_reflectance(0.05, 0.01), bank)

    fit_ms, match_ms, large_ms = [], [], []
    clock = time.perf_counter
    for lab in colours:
        t0 = clock()
        fit = fit_skin(lab)
        t1 = clock()
        match_shades(fit.reflectance, fit.reflectance, bank)
        t2 = clock()
        match_shades(fit.reflectance, fit.reflectance, large)
        t3 = clock()
        fit_ms.append((t1 - t0) * 1e3)
        match_ms.append((t2 - t1) * 1e3)
        large_ms.append((t3 - t2) * 1e3)
    coverage_s = []
    served = 0.0
    for _ in range(args.repeats):
        t0 = clock()
        cov = coverage(bank, args.population, seed=0)
        coverage_s.append(clock() - t0)
        served = cov.served_fraction
    result = {
        "benchmark": "shade", "foundations": len(bank.names), "skins_timed": len(colours),
        **spread("match_ms", match_ms, 1), **spread("fit_ms", fit_ms, 1),
        "large_foundations": args.large, **spread("match_ms_large", large_ms, 1),
        "population": args.population, **spread("coverage_s", coverage_s, 2), "served_fraction": round(served, 3),
        "targets": {"match_ms": 200.0, "coverage_s": 10.0},
        "loadavg_1min": round(os.getloadavg()[0], 2), "cpu_count": os.cpu_count(),
    }
    json.dump(result, sys.stdout, indent=2)
    print()
    return 0
