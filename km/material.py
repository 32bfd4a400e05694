"""Cosmetic materials: Kubelka–Munk coefficients, specular parameters, provenance and raw measurement.

A :class:`Material` is an immutable value: its arrays are read-only float64 copies, and a changed
material is made with :meth:`Material.replace` (which validates again). Every constructor validates, so
a ``Material`` that exists is always sound: finite values, S and K ≥ 0, matching lengths, strictly
increasing wavelengths.

Units
-----
============================  ==========  =========================================
field                         unit        range
============================  ==========  =========================================
wavelengths                   nm          strictly increasing, within [200, 3000]
S, K                          per mm      finite, ≥ 0, same length as wavelengths
thickness_um                  µm          (0, max_thickness_um]
max_thickness_um              µm          (0, 10000]
roughness                     1           (0, 1] (Beckmann slope, Kelemen specular)
ior                           1           [1, 3] (index of refraction)
Measurement.R_inf, R, Rg      1           finite, in [0, 1]
Measurement.D_mm              mm          (0, 100]
Measurement.saunderson k1,k2  1           [0, 1)
============================  ==========  =========================================

JSON (stable: project files embed materials with :meth:`Material.to_json`)
--------------------------------------------------------------------------
A material is a JSON object with exactly these keys (``measurement`` may be ``null``)::

    {"name": str, "category": str, "source": "measured" | "modelled", "provenance": str,
     "wavelengths": [nm...], "S": [per mm...], "K": [per mm...],
     "thickness_um": float, "max_thickness_um": float, "roughness": float, "ior": float,
     "measurement": null | {"wavelengths": [nm...], "R_inf": [...], "R": [...], "Rg": [...],
                            "D_mm": float, "instrument": str, "illuminant": str,
                            "saunderson": null | {"k1": float, "k2": float}},
     "coverage": null | {"class": "sheer" | "medium" | "full", "contrast_ratio": null | float,
                         "provenance": str}}

``coverage`` is what the material states about its hiding (:mod:`km.coverage`: the class, and the
contrast ratio at ``thickness_um``); null in a file means it states none, and the one its S and K give
is used (and written back).

:data:`MATERIAL_JSON_SCHEMA` is the JSON Schema of this shape. Numbers are written with Python's
shortest round-trip ``repr``, so a save/load round trip is
bit-identical. :meth:`Material.from_json` rejects missing and unknown keys, wrong types (``true`` is
not a number), NaN/±inf, negative S or K, length mismatches and out-of-range values with a
:class:`MaterialError` whose message names the field, e.g. ``materials[3].S[12]: negative (-0.5)``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from km.coverage import Coverage, applied_rgb, contrast_ratio, measured_coverage, reference_background
from km.errors import MaterialError as MaterialError  # re-exported: its home was this module
from km.srgb import srgb_encode

#: Categories the studio knows (others are allowed if they are short lowercase words).
CATEGORIES: tuple[str, ...] = (
    "foundation", "concealer", "primer", "powder", "blush", "bronzer", "contour", "highlighter",
    "lipstick", "lipgloss", "lipliner", "eyeshadow", "eyeliner", "mascara", "other",
)
SOURCES: tuple[str, ...] = ("measured", "modelled")

MAX_NAME_CHARS = 120
MAX_TEXT_CHARS = 20_000
MAX_SAMPLES = 4096
_CATEGORY_RE = re.compile(r"^[a-z][a-z0-9_-]{0,39}$")

_MATERIAL_KEYS = ("name", "category", "source", "provenance", "wavelengths", "S", "K", "thickness_um",
                  "max_thickness_um", "roughness", "ior", "measurement", "coverage")
#: Fields whose change changes what a material hides (:meth:`Material.replace` then recomputes its coverage).
_OPTICAL_FIELDS = ("wavelengths", "S", "K", "thickness_um")
_MEASUREMENT_KEYS = ("wavelengths", "R_inf", "R", "Rg", "D_mm", "instrument", "illuminant", "saunderson")


def _number_array(minimum: float | None = None, maximum: float | None = None) -> dict[str, Any]:
    item: dict[str, Any] = {"type": "number"}
    if minimum is not None:
        item["minimum"] = minimum
    if maximum is not None:
        item["maximum"] = maximum
    return {"type": "array", "minItems": 1, "maxItems": MAX_SAMPLES, "items": item}


#: JSON Schema (draft 2020-12) of :meth:`Material.to_json`, for documents that embed materials (e.g. a
#: project file's ``$defs``). It checks the shape, types and ranges; what a schema cannot express
#: (finite values, equal lengths, increasing wavelengths, thickness ≤ maximum) is checked by
#: :meth:`Material.from_json`, which is the authority.
MATERIAL_JSON_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "Sheer material (km.Material JSON)",
    "type": "object",
    "additionalProperties": False,
    "required": list(_MATERIAL_KEYS),
    "properties": {
        "name": {"type": "string", "minLength": 1, "maxLength": MAX_NAME_CHARS},
        "category": {"type": "string", "pattern": _CATEGORY_RE.pattern},
        "source": {"enum": list(SOURCES)},
        "provenance": {"type": "string", "maxLength": MAX_TEXT_CHARS},
        "wavelengths": {**_number_array(200.0, 3000.0), "minItems": 2, "description": "nm, strictly increasing"},
        "S": {**_number_array(0.0), "description": "scattering coefficient, per mm"},
        "K": {**_number_array(0.0), "description": "absorption coefficient, per mm"},
        "thickness_um": {"type": "number", "exclusiveMinimum": 0, "maximum": 10_000},
        "max_thickness_um": {"type": "number", "exclusiveMinimum": 0, "maximum": 10_000},
        "roughness": {"type": "number", "exclusiveMinimum": 0, "maximum": 1},
        "ior": {"type": "number", "minimum": 1, "maximum": 3},
        "measurement": {
            "oneOf": [
                {"type": "null"},
                {
                    "type": "object",
                    "additionalProperties": False,
                    "required": list(_MEASUREMENT_KEYS),
                    "properties": {
                        "wavelengths": {**_number_array(200.0, 3000.0), "minItems": 2},
                        "R_inf": _number_array(0.0, 1.0),
                        "R": _number_array(0.0, 1.0),
                        "Rg": _number_array(0.0, 1.0),
                        "D_mm": {"type": "number", "exclusiveMinimum": 0, "maximum": 100},
                        "instrument": {"type": "string", "maxLength": MAX_NAME_CHARS * 4},
                        "illuminant": {"type": "string", "maxLength": MAX_NAME_CHARS},
                        "saunderson": {
                            "oneOf": [
                                {"type": "null"},
                                {"type": "object", "additionalProperties": False, "required": ["k1", "k2"],
                                 "properties": {"k1": {"type": "number", "minimum": 0, "exclusiveMaximum": 1},
                                                "k2": {"type": "number", "minimum": 0, "exclusiveMaximum": 1}}},
                            ]
                        },
                    },
                },
            ]
        },
        "coverage": {
            "oneOf": [
                {"type": "null"},
                {"type": "object", "additionalProperties": False,
                 "required": ["class", "contrast_ratio", "provenance"],
                 "properties": {"class": {"enum": ["sheer", "medium", "full"]},
                                "contrast_ratio": {"oneOf": [{"type": "null"},
                                                             {"type": "number", "minimum": 0, "maximum": 1}]},
                                "provenance": {"type": "string", "maxLength": MAX_TEXT_CHARS}}},
            ]
        },
    },
}


# --------------------------------------------------------------------------------------------------
# validation helpers (shared by the constructors and from_json)


def _check_number(value: Any, where: str, lo: float | None = None, hi: float | None = None,
                  lo_open: bool = False, hi_open: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        raise MaterialError(where, f"must be a number, got {type(value).__name__}")
    try:
        x = float(value)
    except OverflowError:  # a JSON integer beyond the float range
        raise MaterialError(where, "must be finite (got an integer too large for a float)") from None
    if not math.isfinite(x):
        raise MaterialError(where, f"must be finite (got {x})")
    if lo is not None and (x < lo or (lo_open and x == lo)):
        raise MaterialError(where, f"must be {'>' if lo_open else '≥'} {lo:g} (got {x:g})")
    if hi is not None and (x > hi or (hi_open and x == hi)):
        raise MaterialError(where, f"must be {'<' if hi_open else '≤'} {hi:g} (got {x:g})")
    return x


def _check_text(value: Any, where: str, max_chars: int = MAX_TEXT_CHARS, nonempty: bool = False) -> str:
    if not isinstance(value, str):
        raise MaterialError(where, f"must be a string, got {type(value).__name__}")
    if len(value) > max_chars:
        raise MaterialError(where, f"too long ({len(value)} characters, at most {max_chars})")
    if nonempty and not value.strip():
        raise MaterialError(where, "must not be empty")
    return value


def _check_name(value: Any, where: str = "name") -> str:
    name = _check_text(value, where, MAX_NAME_CHARS, nonempty=True)
    if name != name.strip():
        raise MaterialError(where, f"must not start or end with spaces ({name!r})")
    if any(ord(c) < 32 for c in name):
        raise MaterialError(where, "must not contain control characters")
    return name


def _check_array(value: Any, where: str, lo: float | None = None, hi: float | None = None,
                 length: int | None = None, length_of: str = "wavelengths") -> np.ndarray:
    """A 1-D finite float64 read-only copy of ``value``.

    A list from JSON is checked element by element so that the error names the index.
    """
    if isinstance(value, np.ndarray):
        if value.ndim != 1:
            raise MaterialError(where, f"must be one-dimensional (got shape {value.shape})")
        if value.dtype.kind not in "fiu":
            raise MaterialError(where, f"must hold numbers (got dtype {value.dtype})")
        arr = np.array(value, dtype=np.float64)
    elif isinstance(value, Sequence) and not isinstance(value, str | bytes):
        for i, v in enumerate(value):
            if isinstance(v, bool) or not isinstance(v, int | float | np.floating | np.integer):
                raise MaterialError(f"{where}[{i}]", f"must be a number, got {type(v).__name__}")
            if isinstance(v, int):
                try:
                    float(v)
                except OverflowError:  # a JSON integer beyond the float range
                    raise MaterialError(f"{where}[{i}]", "must be finite (got an integer too large for a float)"
                                        ) from None
        arr = np.array(value, dtype=np.float64)
    else:
        raise MaterialError(where, f"must be a list of numbers, got {type(value).__name__}")
    if arr.size == 0:
        raise MaterialError(where, "must not be empty")
    if arr.size > MAX_SAMPLES:
        raise MaterialError(where, f"too many samples ({arr.size}, at most {MAX_SAMPLES})")
    if length is not None and arr.size != length:
        raise MaterialError(where, f"has {arr.size} values but {length_of} has {length}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise MaterialError(f"{where}[{bad[0]}]", f"must be finite (got {arr[bad[0]]})")
    if lo is not None:
        bad = np.flatnonzero(arr < lo)
        if bad.size:
            what = "negative" if lo == 0 else f"below {lo:g}"
            raise MaterialError(f"{where}[{bad[0]}]", f"{what} ({arr[bad[0]]:g})")
    if hi is not None:
        bad = np.flatnonzero(arr > hi)
        if bad.size:
            raise MaterialError(f"{where}[{bad[0]}]", f"above {hi:g} ({arr[bad[0]]:g})")
    arr.setflags(write=False)
    return arr


def _check_wavelengths(value: Any, where: str = "wavelengths") -> np.ndarray:
    arr = _check_array(value, where, lo=200.0, hi=3000.0)
    if arr.size < 2:
        raise MaterialError(where, "needs at least two wavelengths")
    steps = np.diff(arr)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise MaterialError(f"{where}[{i}]", f"wavelengths must increase strictly ({arr[i - 1]:g} then {arr[i]:g} nm)")
    return arr


def _check_keys(data: Any, keys: Sequence[str], where: str) -> Mapping[str, Any]:
    if not isinstance(data, Mapping):
        raise MaterialError(where, f"must be an object, got {type(data).__name__}")
    missing = [k for k in keys if k not in data]
    if missing:
        raise MaterialError(where, f"missing field{'s' if len(missing) > 1 else ''} {', '.join(missing)}")
    unknown = sorted(str(k) for k in data if k not in keys)
    if unknown:
        raise MaterialError(where, f"unknown field{'s' if len(unknown) > 1 else ''} {', '.join(unknown)}")
    return data


def _floats(arr: np.ndarray) -> list[float]:
    return [float(x) for x in arr]


def _arrays_equal(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and bool(np.array_equal(a, b))


# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Measurement:
    """The raw Kubelka–Munk measurement of a material (Huang et al. 2013, Eq. 6–8).

    ``R_inf``: reflectance of an opaque (infinitely thick) layer; ``R``: reflectance of a layer of
    thickness ``D_mm`` over the background; ``Rg``: reflectance of the background alone (a black card in
    the paper; a white one for contrast charts). All are fractions in [0, 1] on ``wavelengths`` (nm).
    ``saunderson`` is the optional ``(k1, k2)`` surface-reflection correction that was (or should be)
    applied to turn measured into internal reflectances.
    """

    wavelengths: np.ndarray
    R_inf: np.ndarray
    R: np.ndarray
    Rg: np.ndarray
    D_mm: float
    instrument: str = ""
    illuminant: str = ""
    saunderson: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        wl = _check_wavelengths(self.wavelengths)
        n = wl.size
        object.__setattr__(self, "wavelengths", wl)
        for name in ("R_inf", "R", "Rg"):
            object.__setattr__(self, name, _check_array(getattr(self, name), name, 0.0, 1.0, length=n))
        object.__setattr__(self, "D_mm", _check_number(self.D_mm, "D_mm", 0.0, 100.0, lo_open=True))
        object.__setattr__(self, "instrument", _check_text(self.instrument, "instrument", MAX_NAME_CHARS * 4))
        object.__setattr__(self, "illuminant", _check_text(self.illuminant, "illuminant", MAX_NAME_CHARS))
        if self.saunderson is not None:
            if not isinstance(self.saunderson, Sequence) or isinstance(self.saunderson, str) \
                    or len(self.saunderson) != 2:
                raise MaterialError("saunderson", "must be a pair (k1, k2) or None")
            k1 = _check_number(self.saunderson[0], "saunderson.k1", 0.0, 1.0, hi_open=True)
            k2 = _check_number(self.saunderson[1], "saunderson.k2", 0.0, 1.0, hi_open=True)
            object.__setattr__(self, "saunderson", (k1, k2))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Measurement):
            return NotImplemented
        return (all(_arrays_equal(getattr(self, n), getattr(other, n)) for n in ("wavelengths", "R_inf", "R", "Rg"))
                and (self.D_mm, self.instrument, self.illuminant, self.saunderson)
                == (other.D_mm, other.instrument, other.illuminant, other.saunderson))

    __hash__ = None  # type: ignore[assignment]

    def invert(self, *, clip: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """(S, K) per mm from this triplet with :func:`km.invert_sk` (Eq. 6–7).

        Saunderson-corrected when ``saunderson`` is set. Raises :class:`km.KMDomainError` on invalid data
        unless ``clip``.
        """
        from km.optics import invert_sk

        return invert_sk(self.R_inf, self.R, self.Rg, self.D_mm, clip=clip,
                         saunderson=self.saunderson, wavelengths=self.wavelengths)

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict (see the module docstring for the shape)."""
        return {
            "wavelengths": _floats(self.wavelengths), "R_inf": _floats(self.R_inf), "R": _floats(self.R),
            "Rg": _floats(self.Rg), "D_mm": float(self.D_mm), "instrument": self.instrument,
            "illuminant": self.illuminant,
            "saunderson": None if self.saunderson is None
            else {"k1": self.saunderson[0], "k2": self.saunderson[1]},
        }

    @classmethod
    def from_json(cls, data: Any, *, where: str = "measurement") -> Measurement:
        """Validate and build a measurement from its JSON dict; errors name ``where.<field>``."""
        try:
            d = _check_keys(data, _MEASUREMENT_KEYS, "")
            wl = _check_wavelengths(d["wavelengths"])
            arrays = {k: _check_array(d[k], k, 0.0, 1.0, length=wl.size) for k in ("R_inf", "R", "Rg")}
            sd = d["saunderson"]
            saunderson: tuple[float, float] | None = None
            if sd is not None:
                sd = _check_keys(sd, ("k1", "k2"), "saunderson")
                saunderson = (_check_number(sd["k1"], "saunderson.k1", 0.0, 1.0, hi_open=True),
                              _check_number(sd["k2"], "saunderson.k2", 0.0, 1.0, hi_open=True))
            return cls(wl, arrays["R_inf"], arrays["R"], arrays["Rg"],
                       _check_number(d["D_mm"], "D_mm"), d["instrument"], d["illuminant"], saunderson)
        except MaterialError as exc:
            raise exc.within(where) from None


@dataclass(frozen=True, eq=False)
class Material:
    """A cosmetic material (see the module docstring for units and ranges).

    ``S`` and ``K`` (per mm) are on ``wavelengths`` (nm); ``thickness_um`` is the default layer
    thickness and ``max_thickness_um`` the most a brush may build up; ``roughness`` and ``ior`` drive
    the layer's specular term; ``source`` is ``"measured"`` or ``"modelled"`` and ``provenance`` says
    where the numbers come from; ``measurement`` is the raw R∞/R/Rg triplet when there is one.
    """

    name: str
    category: str
    wavelengths: np.ndarray
    S: np.ndarray
    K: np.ndarray
    thickness_um: float = 20.0
    max_thickness_um: float = 100.0
    roughness: float = 0.35
    ior: float = 1.45
    source: str = "modelled"
    provenance: str = ""
    measurement: Measurement | None = field(default=None)
    coverage: Coverage | None = field(default=None)

    def __post_init__(self) -> None:
        object.__setattr__(self, "name", _check_name(self.name))
        cat = _check_text(self.category, "category", 40, nonempty=True)
        if not _CATEGORY_RE.match(cat):
            raise MaterialError("category", f"must be a lowercase word such as {', '.join(CATEGORIES[:4])} "
                                            f"(got {cat!r})")
        wl = _check_wavelengths(self.wavelengths)
        object.__setattr__(self, "wavelengths", wl)
        object.__setattr__(self, "S", _check_array(self.S, "S", lo=0.0, length=wl.size))
        object.__setattr__(self, "K", _check_array(self.K, "K", lo=0.0, length=wl.size))
        mx = _check_number(self.max_thickness_um, "max_thickness_um", 0.0, 10_000.0, lo_open=True)
        object.__setattr__(self, "max_thickness_um", mx)
        object.__setattr__(self, "thickness_um",
                           _check_number(self.thickness_um, "thickness_um", 0.0, mx, lo_open=True))
        object.__setattr__(self, "roughness", _check_number(self.roughness, "roughness", 0.0, 1.0, lo_open=True))
        object.__setattr__(self, "ior", _check_number(self.ior, "ior", 1.0, 3.0))
        if self.source not in SOURCES:
            raise MaterialError("source", f"must be one of {', '.join(SOURCES)} (got {self.source!r})")
        object.__setattr__(self, "provenance", _check_text(self.provenance, "provenance"))
        if self.measurement is not None and not isinstance(self.measurement, Measurement):
            raise MaterialError("measurement", f"must be a Measurement or None, got {type(self.measurement).__name__}")
        if self.coverage is None:
            object.__setattr__(self, "coverage", measured_coverage(wl, self.S, self.K, self.thickness_um,
                                                                   "the material states none"))
        elif not isinstance(self.coverage, Coverage):
            raise MaterialError("coverage", f"must be a Coverage or None, got {type(self.coverage).__name__}")

    # ---- value semantics

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Material):
            return NotImplemented
        return all(
            _arrays_equal(a, b) if isinstance(a, np.ndarray) else a == b
            for a, b in ((getattr(self, f.name), getattr(other, f.name)) for f in fields(self))
        )

    __hash__ = None  # type: ignore[assignment]

    def replace(self, **changes: Any) -> Material:
        """A copy with some fields changed, validated again (e.g. ``m.replace(name="Rose 2")``).

        A change of S, K, the wavelengths or the default thickness changes what the material hides: unless
        ``coverage`` is given too, the copy's coverage is the one its new S and K give.
        """
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        unknown = set(changes) - set(values)
        if unknown:
            raise TypeError(f"Material has no field {', '.join(sorted(unknown))}")
        if "coverage" not in changes and any(k in changes for k in _OPTICAL_FIELDS):
            changes = {**changes, "coverage": None}
        values.update(changes)
        return Material(**values)

    # ---- optics

    def rt(self, thickness_um: float | np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(R0, T)`` of a layer of ``thickness_um`` µm (default: ``self.thickness_um``) over nothing.

        Eq. 1–2; fractions in [0, 1] on ``self.wavelengths``. An array of thicknesses broadcasts: shape
        ``(*thickness.shape, n_wavelengths)``.
        """
        from km.optics import layer_rt

        x_um = self.thickness_um if thickness_um is None else thickness_um
        x_mm = np.asarray(x_um, dtype=np.float64)[..., None] / 1000.0
        if np.any(~np.isfinite(x_mm)) or np.any(x_mm < 0):
            raise MaterialError("thickness_um", f"must be finite and ≥ 0 (got {x_um})")
        return layer_rt(self.S, self.K, x_mm)

    def r0(self, thickness_um: float | None = None) -> np.ndarray:
        """Reflectance R0 of a layer of ``thickness_um`` µm with no background (fraction, per wavelength)."""
        return self.rt(thickness_um)[0]

    def transmittance(self, thickness_um: float | None = None) -> np.ndarray:
        """Diffuse transmittance T of a layer of ``thickness_um`` µm (fraction, per wavelength)."""
        return self.rt(thickness_um)[1]

    def r_inf(self) -> np.ndarray:
        """Reflectance of an opaque layer, R∞ = 1 + K/S − √((K/S)² + 2K/S).

        A fraction in [0, 1] per wavelength; 0 where S = 0.
        """
        from km.optics import r_inf_from_ks

        with np.errstate(divide="ignore", invalid="ignore"):
            ks = np.where(self.S > 0, self.K / np.where(self.S > 0, self.S, 1.0), np.inf)
        return r_inf_from_ks(ks)

    def reflectance_over(self, background: float | np.ndarray | str = "black",
                         thickness_um: float | None = None) -> np.ndarray:
        """Total reflectance (fraction, per wavelength) of the layer over a background.

        ``background``: ``"black"`` (0), ``"white"`` (1), a number in [0, 1] or a reflectance spectrum on
        ``self.wavelengths``; ``thickness_um`` as :meth:`rt`.
        """
        from km.optics import over

        rg = _background(background, self.wavelengths.size)
        r0, t = self.rt(thickness_um)
        return over(r0, t, rg)

    def swatch_rgb(self, background: float | np.ndarray | str = "black", thickness_um: float | None = None,
                   illuminant: str = "D65", *, encoded: bool = True) -> np.ndarray:
        """Display colour of the layer over ``background`` (see :meth:`reflectance_over`) under a light.

        ``illuminant``: a CIE illuminant name (default D65).

        Gamma-encoded sRGB in [0, 1] (clipped), or linear sRGB (unclipped) with ``encoded=False``.
        ``background="opaque"`` gives the colour of R∞.
        """
        # km.colour.spectrum_to_rgb's matrix through km's disk cache: swatches are drawn while the studio
        # starts, and importing colour-science for them cost about a second there (the same product)
        from km.cache import spectral_rgb_matrix_cached

        if isinstance(background, str) and background == "opaque":
            refl = self.r_inf()
        else:
            refl = self.reflectance_over(background, thickness_um)
        m = spectral_rgb_matrix_cached(np.asarray(self.wavelengths, dtype=np.float64), illuminant)
        with np.errstate(all="ignore"):
            rgb = np.asarray(np.asarray(refl, dtype=np.float64) @ m, dtype=np.float64)
        return srgb_encode(np.clip(rgb, 0.0, 1.0)) if encoded else rgb

    def swatch_hex(self, background: float | np.ndarray | str = "opaque", thickness_um: float | None = None,
                   illuminant: str = "D65") -> str:
        """``#rrggbb`` of :meth:`swatch_rgb` (default: the opaque colour)."""
        rgb = self.swatch_rgb(background, thickness_um, illuminant)
        r, g, b = (int(round(float(c) * 255)) for c in rgb)
        return f"#{r:02x}{g:02x}{b:02x}"

    def on_wavelengths(self, wavelengths: np.ndarray | Sequence[float]) -> Material:
        """This material with S and K linearly interpolated onto ``wavelengths`` (nm).

        Held constant beyond the ends. The measurement, if any, stays on its own grid.
        """
        from km.spectra import WavelengthGrid

        wl = _check_wavelengths(np.asarray(wavelengths, dtype=np.float64))
        s, k = WavelengthGrid.from_wavelengths(wl).resample(np.stack([self.S, self.K]), self.wavelengths,
                                                            extrapolate=True)
        # the same product on another grid: what it states about its hiding stays
        return self.replace(wavelengths=wl, S=s, K=k, coverage=self.coverage)

    # ---- hiding (km.coverage)

    def contrast_ratio(self, thickness_um: float | None = None) -> float:
        """The contrast ratio S and K give: Y over black / Y over white (D65) at ``thickness_um``.

        Default: the material's own thickness. In [0, 1] (1 hides completely); see :mod:`km.coverage`.
        """
        return contrast_ratio(self.wavelengths, self.S, self.K,
                              self.thickness_um if thickness_um is None else float(thickness_um))

    def applied_rgb(self, background: np.ndarray | tuple[float, float, float] | str = "reference",
                    thickness_um: float | None = None, illuminant: str = "D65") -> np.ndarray:
        """Linear sRGB (3,) of a layer of ``thickness_um`` µm (default: its own) as applied on a background.

        ``background``: linear sRGB, or ``"reference"`` for the reference skin or lip of its category
        (:func:`km.coverage.reference_background`). Composed as the renderer composes a texel
        (:func:`km.coverage.applied_rgb`).
        """
        bg = reference_background(self.category) if isinstance(background, str) and background == "reference" \
            else np.asarray(background, float)
        return applied_rgb(self.wavelengths, self.S, self.K,
                           self.thickness_um if thickness_um is None else float(thickness_um), bg, illuminant)

    # ---- JSON

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict with exactly the keys of the module docstring (stable format)."""
        return {
            "name": self.name, "category": self.category, "source": self.source,
            "provenance": self.provenance, "wavelengths": _floats(self.wavelengths),
            "S": _floats(self.S), "K": _floats(self.K), "thickness_um": float(self.thickness_um),
            "max_thickness_um": float(self.max_thickness_um), "roughness": float(self.roughness),
            "ior": float(self.ior),
            "measurement": None if self.measurement is None else self.measurement.to_json(),
            "coverage": None if self.coverage is None else self.coverage.to_json(),
        }

    @classmethod
    def from_json(cls, data: Any, *, where: str = "material") -> Material:
        """Validate and build a material from its JSON dict; nothing is silently fixed.

        Raises:
            MaterialError: any problem, naming ``where.<field>`` (e.g. ``materials[3].S[12]``).
        """
        try:
            d = _check_keys(data, _MATERIAL_KEYS, "")
            name = _check_name(d["name"])
            _check_text(d["category"], "category", 40, nonempty=True)
            _check_text(d["source"], "source", 40)
            wl = _check_wavelengths(d["wavelengths"])
            s = _check_array(d["S"], "S", lo=0.0, length=wl.size)
            k = _check_array(d["K"], "K", lo=0.0, length=wl.size)
            numbers = {key: _check_number(d[key], key)
                       for key in ("thickness_um", "max_thickness_um", "roughness", "ior")}
            measurement = None
            if d["measurement"] is not None:
                measurement = Measurement.from_json(d["measurement"], where="measurement")
            coverage = None if d["coverage"] is None else Coverage.from_json(d["coverage"])
            if coverage is None:  # states none: the one S and K give, saying so
                coverage = measured_coverage(wl, s, k, numbers["thickness_um"], "not stated in the file")
            return cls(name=name, category=d["category"], wavelengths=wl, S=s, K=k,
                       source=d["source"], provenance=d["provenance"], measurement=measurement,
                       coverage=coverage, **numbers)
        except MaterialError as exc:
            raise exc.within(where) from None


# --------------------------------------------------------------------------------------------------


def _background(background: float | np.ndarray | str, n: int) -> np.ndarray:
    if isinstance(background, str):
        named = {"black": 0.0, "white": 1.0}
        if background not in named:
            raise MaterialError("background", f"must be black, white, a number or a spectrum (got {background!r})")
        return np.full(n, named[background])
    rg = np.asarray(background, dtype=np.float64)
    if rg.ndim == 0:
        rg = np.full(n, float(rg))
    if rg.shape[-1] != n:
        raise MaterialError("background", f"spectrum has {rg.shape[-1]} values, the material {n}")
    if np.any(~np.isfinite(rg)) or np.any(rg < 0) or np.any(rg > 1):
        raise MaterialError("background", "reflectance must be finite and within [0, 1]")
    return rg
