"""Hiding power: a material's coverage class, its contrast ratio, and its colour as applied.

A cosmetic states how much of what lies beneath it hides: **sheer** (a tint; the skin or lip shows
through), **medium** (evens it out) or **full** (the product's own colour). The measure is the paint
industry's **contrast ratio** (ISO 6504-3, ASTM D2805): the luminance Y (CIE 1931 2°, D65) of a layer of
the material's default thickness over black, divided by its Y over white, both by Kubelka–Munk (Eq. 1–4 of
Huang et al. 2013). 1 hides completely; a clear layer is 0. The classes' bounds: sheer ≤ 0.5 < medium <
0.9 ≤ full (:func:`coverage_class`).

A material's :class:`Coverage` is what it *states* (a class, and usually the contrast ratio at its default
thickness) and where that came from; :func:`contrast_ratio` is what its S and K *give*. The default
library is modelled so that the two agree (``scripts/build_default_library.py`` sets each shade's
scattering so that the ratio is the one its coverage states); a material that states nothing gets the one
its S and K give (:func:`measured_coverage`).

**As applied** (:func:`applied_rgb`): the colour of a layer of the material over a diffuse background
(a skin or a lip colour, linear sRGB), composed exactly as the renderer composes it per texel
(``km_over_albedo`` in ``resources/shaders/km_compose.glsl``: the stack's R_top, T and R_bottom reduced
to linear sRGB from their spectra, then ``R_top + a·T² / (1 − R_bottom·a)`` per channel over the albedo
``a``), so a swatch and the viewport agree. The reference backgrounds (:data:`REFERENCE_SKIN_SRGB`,
:data:`REFERENCE_LIP_SRGB`) are the sample head's own skin and bare lips (the median albedo of its
``skin`` and ``lips`` regions, ``tests/km/test_coverage.py``): lip products are shown on the lip, the
rest on the skin (:func:`reference_background`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from km.errors import MaterialError
from km.srgb import srgb_decode

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

#: The coverage classes, least hiding first.
COVERAGE_CLASSES: tuple[str, ...] = ("sheer", "medium", "full")
#: A contrast ratio at most this is sheer …
SHEER_MAX = 0.5
#: … and at least this full (medium between).
FULL_MIN = 0.9
#: Luminance of linear sRGB (the Y row of the sRGB → XYZ matrix: Y of a D65-adapted colour).
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
#: The sample head's skin (sRGB, the median albedo of its ``skin`` region): the reference skin.
REFERENCE_SKIN_SRGB = "#C19B8D"
#: The sample head's bare lips (sRGB, the median albedo of its ``lips`` region): the reference lip.
REFERENCE_LIP_SRGB = "#A55A5A"
#: Categories applied to the lips (their reference background is the lip, not the skin).
LIP_CATEGORIES = ("lipstick", "lipgloss", "lipliner")
#: Decimals a computed contrast ratio is kept to (stable JSON).
CR_DECIMALS = 4


def coverage_class(contrast_ratio: float) -> str:
    """The class a contrast ratio reads as: "sheer" (≤ 0.5), "full" (≥ 0.9) or "medium" (between)."""
    return "sheer" if contrast_ratio <= SHEER_MAX else "full" if contrast_ratio >= FULL_MIN else "medium"


def hex_to_linear(hex_colour: str) -> np.ndarray:
    """Linear sRGB (3,) of ``#rrggbb``."""
    h = hex_colour.lstrip("#")
    return np.asarray(srgb_decode(np.array([int(h[i:i + 2], 16) for i in (0, 2, 4)], float) / 255.0), float)


def reference_background(category: str) -> np.ndarray:
    """The linear sRGB a material of ``category`` is shown applied on: the reference lip or skin."""
    return hex_to_linear(REFERENCE_LIP_SRGB if category in LIP_CATEGORIES else REFERENCE_SKIN_SRGB)


def _rgb_matrix(wavelengths: ArrayLike, illuminant: str = "D65") -> np.ndarray:
    from km.cache import spectral_rgb_matrix_cached

    return spectral_rgb_matrix_cached(np.asarray(wavelengths, dtype=np.float64), illuminant)


def contrast_ratio(wavelengths: ArrayLike, S: ArrayLike, K: ArrayLike, thickness_um: float) -> float:
    """Y over black / Y over white (D65) of a layer of ``thickness_um`` µm with S, K (per mm) on ``wavelengths``.

    In [0, 1]; 1 where the layer is black over white as well (nothing reaches the background and it
    reflects nothing).
    """
    from km.optics import layer_rt, over

    r0, t = layer_rt(np.asarray(S, float), np.asarray(K, float), float(thickness_um) / 1000.0)
    y = _rgb_matrix(wavelengths) @ LUMINANCE
    y_black = float(r0 @ y)
    y_white = float(over(r0, t, np.ones_like(r0)) @ y)
    if not (math.isfinite(y_black) and math.isfinite(y_white)) or y_white <= 1e-12:
        return 1.0
    return float(min(max(y_black / y_white, 0.0), 1.0))


def applied_rgb(wavelengths: ArrayLike, S: ArrayLike, K: ArrayLike, thickness_um: float,
                background_rgb: ArrayLike, illuminant: str = "D65") -> np.ndarray:
    """Linear sRGB (3,) of a layer over a diffuse background of linear sRGB ``background_rgb``.

    Composed as the renderer composes a texel (see the module docstring): R0 and T of the layer reduced
    to linear sRGB under ``illuminant`` (adapted to D65), then ``R0 + a·T² / (1 − R0·a)`` per channel.
    """
    from km.optics import layer_rt

    r0, t = layer_rt(np.asarray(S, float), np.asarray(K, float), float(thickness_um) / 1000.0)
    m = _rgb_matrix(wavelengths, illuminant)
    r_rgb = np.clip(r0 @ m, 0.0, 1.0)
    t_rgb = np.clip(t @ m, 0.0, 1.0)
    a = np.clip(np.asarray(background_rgb, float), 0.0, 1.0)
    return np.asarray(r_rgb + a * t_rgb * t_rgb / np.maximum(1.0 - r_rgb * a, 1e-4), float)


@dataclass(frozen=True)
class Coverage:
    """How much a material hides, as it states it (see the module docstring).

    Attributes:
        level: "sheer", "medium" or "full" (JSON ``class``).
        contrast_ratio: the contrast ratio at the material's default thickness (Y over black / Y over
            white, D65), or None when only the class is stated. When given, ``level`` is its class.
        provenance: where the statement comes from (a maker's claim, a measurement, how it was modelled
            or computed).
    """

    level: str
    contrast_ratio: float | None = None
    provenance: str = ""

    def __post_init__(self) -> None:
        if self.level not in COVERAGE_CLASSES:
            raise MaterialError("coverage.class", f"must be one of {', '.join(COVERAGE_CLASSES)} (got {self.level!r})")
        cr = self.contrast_ratio
        if cr is not None:
            if isinstance(cr, bool) or not isinstance(cr, int | float | np.floating) or not math.isfinite(float(cr)) \
                    or not 0.0 <= float(cr) <= 1.0:
                raise MaterialError("coverage.contrast_ratio", f"must be a number in [0, 1] or null (got {cr!r})")
            object.__setattr__(self, "contrast_ratio", float(cr))
            if coverage_class(float(cr)) != self.level:
                raise MaterialError("coverage.class", f"{self.level!r} does not match the contrast ratio {cr:g} "
                                    f"(which reads as {coverage_class(float(cr))!r}: sheer ≤ {SHEER_MAX:g} < "
                                    f"medium < {FULL_MIN:g} ≤ full)")
        if not isinstance(self.provenance, str):
            raise MaterialError("coverage.provenance", f"must be a string, got {type(self.provenance).__name__}")

    def to_json(self) -> dict[str, Any]:
        """``{"class": …, "contrast_ratio": … | null, "provenance": …}``."""
        return {"class": self.level, "contrast_ratio": self.contrast_ratio, "provenance": self.provenance}

    @classmethod
    def from_json(cls, data: Any) -> Coverage:
        """Validate and build from :meth:`to_json`'s dict; errors name ``coverage.<field>``."""
        if not isinstance(data, dict):
            raise MaterialError("coverage", f"must be an object or null, got {type(data).__name__}")
        keys = ("class", "contrast_ratio", "provenance")
        missing = [k for k in keys if k not in data]
        if missing:
            raise MaterialError("coverage", f"missing field{'s' if len(missing) > 1 else ''} {', '.join(missing)}")
        unknown = sorted(str(k) for k in data if k not in keys)
        if unknown:
            raise MaterialError("coverage", f"unknown field{'s' if len(unknown) > 1 else ''} {', '.join(unknown)}")
        if not isinstance(data["class"], str):
            raise MaterialError("coverage.class", f"must be a string, got {type(data['class']).__name__}")
        return cls(data["class"], data["contrast_ratio"], data["provenance"])


def measured_coverage(wavelengths: ArrayLike, S: ArrayLike, K: ArrayLike, thickness_um: float,
                      why: str = "") -> Coverage:
    """The coverage S and K give at ``thickness_um`` µm (the class of the contrast ratio), with provenance."""
    cr = round(contrast_ratio(wavelengths, S, K, thickness_um), CR_DECIMALS)
    text = (f"computed from S and K: contrast ratio {cr:.{CR_DECIMALS}f} at {float(thickness_um):g} µm "
            f"(Y over black / Y over white, D65)")
    return Coverage(coverage_class(cr), cr, f"{text}; {why}" if why else text)
