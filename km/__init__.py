"""Kubelka–Munk optics, spectra, colour and the cosmetic material library (pure numpy + colour-science).

Units: wavelengths in nm; S and K per mm; thicknesses X and D in mm. Arrays broadcast, wavelengths on
the last axis.
"""

from __future__ import annotations

from km.errors import AssetNotFoundError, SheerError

__all__ = ["AssetNotFoundError", "SheerError"]
