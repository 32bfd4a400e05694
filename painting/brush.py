"""The brush: a sphere in 3D around a surface point (radius in mm), its falloff and its modes.

How a stroke changes a thickness map (µm), per texel, with ``base`` the value when the stroke first
touched the texel and ``m`` the stroke's coverage in [0, 1] (each dab composites its alpha
``a = flow · falloff(d / r) · pressure`` over it: ``m ← m + (1 − m)·a``, so overlapping dabs of one
stroke build up smoothly and never exceed full coverage):

========  ===========================================================================================
mode      result
========  ===========================================================================================
add       ``min(base + strength · amount · m, layer maximum)`` (never lowers a texel above the maximum)
erase     ``base · (1 − strength · m)``
set       ``base + (amount − base) · strength · m`` (flatten towards ``amount``)
smooth    per dab, a 3D diffusion step with a symmetric kernel ``smooth_radius · r`` wide (trilinear
          hats on a grid of that spacing), weighted by ``√a_i·√a_j`` and scaled by ``strength``: the sum
          of thickness is conserved and no value leaves the old [min, max]; no neighbour cap
fill      the chart under the dab is set to ``strength · amount`` (clamped to the maximum)
========  ===========================================================================================

``amount`` (µm) defaults to the layer material's default thickness.

Region options (:mod:`painting.regions`): with ``region`` set, ``region_mode="inside"`` multiplies every
dab's weight by the region's soft mask (the stroke stays inside, fading over its feather), ``"avoid"``
by one minus it (e.g. never paint the eyes); ``mode="fill"`` with a region fills the whole region (not
the chart) towards ``strength · amount`` with the region's soft edge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from core.errors import SheerError

MODES = ("add", "erase", "smooth", "set", "fill")
REGION_MODES = ("inside", "avoid")


class BrushError(SheerError, ValueError):
    """A brush setting out of range; the message names the setting and the allowed range."""


@dataclass(frozen=True)
class Brush:
    """Brush settings (immutable; make a new one with :func:`dataclasses.replace`).

    Attributes:
        radius_mm: sphere radius in millimetres, (0, 500].
        hardness: [0, 1]; fraction of the radius painted at full weight, then a smoothstep to 0 at the
            radius (1 = hard edge).
        strength: [0, 1]; how far a stroke goes towards its target (the stroke's opacity).
        mode: one of :data:`MODES`.
        flow: (0, 1]; alpha of one dab (build-up speed within a stroke).
        amount_um: target/added thickness in µm (add, set, fill); None = the material's default.
        spacing: dab spacing as a fraction of the radius, (0, 4]; points closer than this to the last
            dab are skipped, longer gaps are covered by capsules (no holes in fast strokes).
        pressure_radius, pressure_strength: whether pen pressure scales the radius / the alpha.
        max_angle_deg: texels whose normal is more than this from the dab's normal are not painted
            (back faces, the other lip, the far side of the nose), [0, 180].
        mirror: also paint the mirror image about the head's midplane (same stroke, one undo step).
        smooth_radius: smoothing kernel width (the grid spacing h; texels up to 2h apart per axis
            exchange thickness), fraction of the radius, (0, 1]; at least one texel.
        falloff_curve: optional custom falloff, weights sampled at evenly spaced d/r in [0, 1]
            (at least 2 samples in [0, 1]); overrides ``hardness``.
        region: a facial region's name (:data:`painting.regions.REGION_NAMES`) or None.
        region_mode: "inside" (stay inside ``region``) or "avoid" (never paint it).
    """

    radius_mm: float = 8.0
    hardness: float = 0.5
    strength: float = 1.0
    mode: str = "add"
    flow: float = 1.0
    amount_um: float | None = None
    spacing: float = 0.15
    pressure_radius: bool = False
    pressure_strength: bool = True
    max_angle_deg: float = 80.0
    mirror: bool = False
    smooth_radius: float = 0.25
    falloff_curve: tuple[float, ...] | None = field(default=None)
    region: str | None = None
    region_mode: str = "inside"

    def validate(self) -> Brush:
        """Raise :class:`BrushError` for a bad setting; return self."""

        def number(name: str, lo: float, hi: float, lo_open: bool = False) -> float:
            value = getattr(self, name)
            try:
                v = float(value)
            except (TypeError, ValueError):
                raise BrushError(f"brush {name} must be a number, got {value!r}") from None
            if not math.isfinite(v) or v > hi or v < lo or (lo_open and v == lo):
                bracket = "(" if lo_open else "["
                raise BrushError(f"brush {name} must be in {bracket}{lo}, {hi}], got {value!r}")
            return v

        number("radius_mm", 0.0, 500.0, lo_open=True)
        number("hardness", 0.0, 1.0)
        number("strength", 0.0, 1.0)
        number("flow", 0.0, 1.0, lo_open=True)
        number("spacing", 0.0, 4.0, lo_open=True)
        number("max_angle_deg", 0.0, 180.0)
        number("smooth_radius", 0.0, 1.0, lo_open=True)
        if self.amount_um is not None:
            number("amount_um", 0.0, 10_000.0)
        if self.mode not in MODES:
            raise BrushError(f"brush mode must be one of {', '.join(MODES)}, got {self.mode!r}")
        if self.region_mode not in REGION_MODES:
            raise BrushError(f"brush region_mode must be one of {', '.join(REGION_MODES)}, got {self.region_mode!r}")
        if self.region is not None:
            from painting.regions import REGION_NAMES

            if self.region not in REGION_NAMES:
                raise BrushError(f"brush region {self.region!r} is not a region (known: {', '.join(REGION_NAMES)})")
        if self.falloff_curve is not None:
            curve = np.asarray(self.falloff_curve, dtype=float)
            if curve.ndim != 1 or len(curve) < 2 or not np.all(np.isfinite(curve)) \
                    or curve.min() < 0 or curve.max() > 1:
                raise BrushError("brush falloff_curve must be at least 2 weights in [0, 1]")
        return self

    def falloff(self, t: np.ndarray) -> np.ndarray:
        """Weight in [0, 1] at normalised distance ``t = d / r`` (float32 in, float32 out); 0 at t ≥ 1."""
        t = np.asarray(t, dtype=np.float32)
        if self.falloff_curve is not None:
            curve = np.asarray(self.falloff_curve, dtype=np.float32)
            xs = np.linspace(0.0, 1.0, len(curve), dtype=np.float32)
            w = np.interp(t, xs, curve).astype(np.float32)
            return np.where(t < 1.0, w, np.float32(0.0))
        h = np.float32(min(max(self.hardness, 0.0), 1.0))
        if h >= 1.0:
            return np.where(t < 1.0, np.float32(1.0), np.float32(0.0)).astype(np.float32)
        x = np.clip((t - h) / (np.float32(1.0) - h), 0.0, 1.0)
        return (np.float32(1.0) - x * x * (np.float32(3.0) - np.float32(2.0) * x)).astype(np.float32)
