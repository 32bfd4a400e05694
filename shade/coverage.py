"""Shade-range coverage: which skins a range of foundations serves badly, and the shade that would fill the gap.

A population of skins is sampled over the skin model's parameters (light to very dark; a scrambled
Halton sequence, seeded, so a run is reproducible); for each skin the best foundation of the library
and its ΔE2000 against the skin itself ("disappears") are found with :func:`shade.match.best_thickness`.
Skins whose best ΔE2000 exceeds a threshold are *poorly served*. The largest **gap** is the poorly
served skin with the most poorly served neighbours (CIELAB distance below :data:`GAP_RADIUS_LAB`) and
those neighbours; the suggested shade is the Duncan mixture (:func:`km.optics.mix`) of the library's
foundations that minimises the mean ΔE2000 of the gap's skins (each at its own best thickness):
concentrations on the simplex (softmax), searched by Nelder–Mead from the best mixture of two, on the thickness grid
only (the final score uses the full thickness search).

Units: thickness µm, wavelengths nm, reflectances [0, 1], ΔE2000 unit 1, angles in degrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from km.optics import mix, r_inf_from_ks
from km.skin import hue_degrees, ita_degrees, lab_of, skin_reflectance
from shade.match import ShadeBank, ShadeError, best_thickness

__all__ = ["PopulationRanges", "Coverage", "GapShade", "sample_skins", "coverage", "suggest_gap_shade",
           "POORLY_SERVED_DE2000"]

FloatArray = NDArray[np.float64]

#: A skin whose best foundation is further than this (ΔE2000) is poorly served (2: clearly visible
#: side by side; the usual acceptance threshold for skin-tone matching).
POORLY_SERVED_DE2000 = 2.0
#: Two poorly served skins closer than this in CIELAB (ΔE*ab) are in the same gap.
GAP_RADIUS_LAB = 6.0
#: Concentrations below this are left out of a suggested recipe (which is then scored as named).
RECIPE_MIN = 0.005
#: Most gap skins the mixture is optimised on (a seeded subsample beyond that; the result is scored on all).
GAP_SAMPLE = 48


@dataclass(frozen=True)
class PopulationRanges:
    """Ranges the population is sampled over (melanin and blood log-uniform, the others uniform).

    Defaults: light (ITA° > 70) to very dark (ITA° < −70) skins of the model, blood 0.3–4 %,
    oxygenation 60–90 %, scattering 0.7–1.5, pheomelanin 10–60 % of the melanin.
    """

    melanin: tuple[float, float] = (0.005, 0.40)
    blood: tuple[float, float] = (0.003, 0.04)
    oxygenation: tuple[float, float] = (0.6, 0.9)
    scattering: tuple[float, float] = (0.7, 1.5)
    pheomelanin: tuple[float, float] = (0.1, 0.6)


def sample_skins(n: int, seed: int = 0, ranges: PopulationRanges | None = None) -> dict[str, FloatArray]:
    """``n`` skins' parameters (arrays of n), a scrambled Halton sample of :class:`PopulationRanges`."""
    from scipy.stats import qmc

    if not 1 <= n <= 1_000_000:
        raise ShadeError(f"the population must hold 1 to 1,000,000 skins, got {n}")
    r = ranges or PopulationRanges()
    u = qmc.Halton(d=5, scramble=True, seed=seed).random(n)
    log_range = [(math.log(lo), math.log(hi)) for lo, hi in (r.melanin, r.blood)]
    return {
        "melanin": np.exp(log_range[0][0] + u[:, 0] * (log_range[0][1] - log_range[0][0])),
        "blood": np.exp(log_range[1][0] + u[:, 1] * (log_range[1][1] - log_range[1][0])),
        "oxygenation": r.oxygenation[0] + u[:, 2] * (r.oxygenation[1] - r.oxygenation[0]),
        "scattering": r.scattering[0] + u[:, 3] * (r.scattering[1] - r.scattering[0]),
        "pheomelanin": r.pheomelanin[0] + u[:, 4] * (r.pheomelanin[1] - r.pheomelanin[0]),
    }


@dataclass(frozen=True)
class GapShade:
    """A suggested new shade: a Duncan mixture of existing foundations.

    Attributes:
        recipe: concentration (fraction, sums to 1) per foundation name, largest first, zeros left out.
        S, K: the mixture's coefficients (per mm) on the grid.
        r_inf: its opaque reflectance (fractions), for a swatch.
        gap_skins: indices (into the population) of the gap's skins.
        mean_de_before: their mean best ΔE2000 with the library as it is.
        mean_de_after: their mean best ΔE2000 with the new shade added.
        served_after: how many of them the library then serves (best ΔE2000 ≤ the threshold).
    """

    recipe: dict[str, float]
    S: FloatArray
    K: FloatArray
    r_inf: FloatArray
    gap_skins: NDArray[np.int64]
    mean_de_before: float
    mean_de_after: float
    served_after: int

    def to_json(self) -> dict[str, Any]:
        """JSON-ready summary (the spectrum as R∞)."""
        return {"recipe": {k: round(v, 4) for k, v in self.recipe.items()}, "gap_skins": int(self.gap_skins.size),
                "mean_de2000_before": round(self.mean_de_before, 3), "mean_de2000_after": round(self.mean_de_after, 3),
                "served_after": self.served_after, "r_inf": [round(float(v), 5) for v in self.r_inf]}


@dataclass(frozen=True)
class Coverage:
    """The coverage of a range over a population.

    Attributes:
        params: the skins' parameters (arrays of N, see :func:`sample_skins`).
        lab: (N, 3) the skins' CIELAB under the illuminant.
        ita_deg, hue_deg: (N,) ITA° and hue angle h_ab of each skin.
        best: (N,) index of each skin's best foundation (into ``names``).
        best_de2000: (N,) its ΔE2000; best_thickness_um: (N,) its thickness.
        names: the foundations' names.
        threshold: the poorly-served ΔE2000 threshold.
        gap: the suggested shade (None when every skin is served).
    """

    params: dict[str, FloatArray]
    lab: FloatArray
    ita_deg: FloatArray
    hue_deg: FloatArray
    best: NDArray[np.int64]
    best_de2000: FloatArray
    best_thickness_um: FloatArray
    names: tuple[str, ...]
    threshold: float
    illuminant: str
    gap: GapShade | None

    @property
    def served_fraction(self) -> float:
        """Fraction of the population whose best ΔE2000 is within the threshold."""
        return float(np.mean(self.best_de2000 <= self.threshold))

    def to_json(self) -> dict[str, Any]:
        """JSON-ready summary: counts per shade, percentiles, the served fraction and the gap."""
        de = self.best_de2000
        return {
            "skins": int(de.size), "illuminant": self.illuminant, "threshold_de2000": self.threshold,
            "served_fraction": round(self.served_fraction, 4),
            "de2000_percentiles": {str(p): round(float(np.percentile(de, p)), 3) for p in (10, 50, 90, 100)},
            "best_counts": {n: int(np.sum(self.best == i)) for i, n in enumerate(self.names)},
            "ita_range_deg": [round(float(self.ita_deg.min()), 1), round(float(self.ita_deg.max()), 1)],
            "gap": None if self.gap is None else self.gap.to_json(),
        }


def _mixture_bank(bank: ShadeBank, c: FloatArray) -> ShadeBank:
    S, K = mix([(c[i], bank.S[i], bank.K[i]) for i in range(len(bank.names))])
    return ShadeBank(names=("mix",), S=S[None, :], K=K[None, :], t_lo_um=np.array([bank.t_lo_um.min()]),
                     t_hi_um=np.array([bank.t_hi_um.max()]), grid=bank.grid)


def _softmax(z: FloatArray) -> FloatArray:
    e = np.exp(np.append(0.0, z) - max(0.0, float(np.max(z))))
    return e / e.sum()


def suggest_gap_shade(bank: ShadeBank, skins: FloatArray, lab: FloatArray, best_de: FloatArray,
                      illuminant: str = "D65", threshold: float = POORLY_SERVED_DE2000, seed: int = 0
                      ) -> GapShade | None:
    """The mixture of ``bank``'s foundations that best serves the largest gap (module docstring).

    ``skins`` (N, n) reflectances, ``lab`` (N, 3) their colours, ``best_de`` (N,) their best ΔE2000
    with the library. Returns None when no skin is poorly served.
    """
    from scipy.optimize import minimize

    bad = np.flatnonzero(best_de > threshold)
    if bad.size == 0:
        return None
    d = np.linalg.norm(lab[bad, None, :] - lab[None, bad, :], axis=-1)
    centre = int(np.argmax(np.sum(d < GAP_RADIUS_LAB, axis=1)))
    gap = bad[d[centre] < GAP_RADIUS_LAB]
    rng = np.random.default_rng(seed)
    sample = gap if gap.size <= GAP_SAMPLE else np.sort(rng.choice(gap, GAP_SAMPLE, replace=False))
    M = len(bank.names)

    def cost(c: FloatArray, idx: NDArray[np.int64] = sample) -> float:
        _, de = best_thickness(_mixture_bank(bank, c), skins[idx], skins[idx], illuminant, golden_steps=0)
        return float(de.mean())

    # start: the best mixture of two (or the single foundation), 3 ratios per pair
    candidates = [np.eye(M)[i] for i in range(M)]
    for i in range(M):
        for j in range(i + 1, M):
            candidates += [w * np.eye(M)[i] + (1 - w) * np.eye(M)[j] for w in (0.25, 0.5, 0.75)]
    start = min(candidates, key=cost)
    z0 = np.log(np.maximum(start, 1e-4) / max(start[0], 1e-4))[1:]
    sol = minimize(lambda z: cost(_softmax(z)), z0, method="Nelder-Mead",
                   options={"maxfev": 80 * M, "xatol": 1e-3, "fatol": 1e-3})
    c = _softmax(sol.x) if cost(_softmax(sol.x)) <= cost(start) else start
    c = np.where(c >= RECIPE_MIN, c, 0.0)  # a recipe names no trace components; it is scored as named
    c /= c.sum()
    new = _mixture_bank(bank, c)
    _, de_new = best_thickness(new, skins[gap], skins[gap], illuminant)
    after = np.minimum(best_de[gap], de_new[:, 0])
    recipe = {bank.names[i]: float(c[i]) for i in np.argsort(-c) if c[i] > 0.0}
    return GapShade(recipe=recipe, S=new.S[0], K=new.K[0],
                    r_inf=r_inf_from_ks(new.K[0] / new.S[0]), gap_skins=gap,
                    mean_de_before=float(best_de[gap].mean()), mean_de_after=float(after.mean()),
                    served_after=int(np.sum(after <= threshold)))


def coverage(bank: ShadeBank, n: int = 1000, *, seed: int = 0, illuminant: str = "D65",
             threshold: float = POORLY_SERVED_DE2000, ranges: PopulationRanges | None = None,
             suggest: bool = True) -> Coverage:
    """How well ``bank``'s foundations serve ``n`` sampled skins (see the module docstring)."""
    if not (math.isfinite(threshold) and threshold > 0):
        raise ShadeError(f"the poorly-served threshold must be a positive ΔE2000, got {threshold}")
    params = sample_skins(n, seed, ranges)
    skins = skin_reflectance(params["melanin"], params["blood"], params["oxygenation"], params["scattering"],
                             bank.grid, params["pheomelanin"])
    t, de = best_thickness(bank, skins, skins, illuminant)
    best = np.argmin(de, axis=1)
    rows = np.arange(n)
    lab = lab_of(skins, illuminant, bank.grid)
    gap = suggest_gap_shade(bank, skins, lab, de[rows, best], illuminant, threshold, seed) if suggest else None
    return Coverage(params=params, lab=lab, ita_deg=ita_degrees(lab), hue_deg=hue_degrees(lab), best=best,
                    best_de2000=de[rows, best], best_thickness_um=t[rows, best], names=bank.names,
                    threshold=threshold, illuminant=illuminant, gap=gap)
