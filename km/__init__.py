"""Kubelka–Munk optics, spectra, colour and the cosmetic material library (pure numpy + colour-science).

Units: wavelengths in nm; S and K per mm; thicknesses X and D in mm; reflectances and transmittances
are fractions in [0, 1]. Arrays broadcast, wavelengths on the last axis.

Modules: :mod:`km.optics` (Kubelka–Munk Eq. 1–4 and 6–7, Saunderson, mixing), :mod:`km.spectra`
(wavelength grids), :mod:`km.srgb` (the sRGB transfer functions), :mod:`km.colour` (spectra to XYZ,
linear sRGB, Lab, ΔE2000), :mod:`km.cache` (the spectral → RGB matrix on disk), :mod:`km.coverage` (coverage
classes, the contrast ratio, a layer's colour as applied), :mod:`km.material` (Material, Measurement; its
error in :mod:`km.errors`), :mod:`km.measurements` (CSV and CGATS import, CSV export), :mod:`km.library`
(Library, the default library).

What km may import: :mod:`core`, numpy and colour-science; never :mod:`painting`, :mod:`project`,
:mod:`render`, :mod:`capture`, :mod:`app`, Qt or GL (the import-linter contracts in ``pyproject.toml``
check it).

The public names are exported lazily (PEP 562), so ``import km`` stays cheap and each module is
loaded on first use (:func:`core.lazy.install_lazy`): add a public name by adding one line to ``_EXPORTS``.
"""

from __future__ import annotations

from core.lazy import install_lazy

#: public name -> module that defines it
_EXPORTS: dict[str, str] = {
    # optics (Eq. 1-4, 6-7 of Huang et al. 2013)
    "KMDomainError": "km.optics",
    "layer_rt": "km.optics",
    "over": "km.optics",
    "stack": "km.optics",
    "invert_sk": "km.optics",
    "mix": "km.optics",
    "r_inf_from_ks": "km.optics",
    "ks_from_r_inf": "km.optics",
    "saunderson": "km.optics",
    "inverse_saunderson": "km.optics",
    # spectra and colour
    "WavelengthGrid": "km.spectra",
    "DEFAULT_GRID": "km.spectra",
    "spectrum_to_xyz": "km.colour",
    "spectrum_to_rgb": "km.colour",
    "xyz_to_lab": "km.colour",
    "linear_rgb_to_lab": "km.colour",
    "delta_e2000": "km.colour",
    "spectral_rgb_matrix": "km.colour",
    # materials and the library
    "Material": "km.material",
    "Measurement": "km.material",
    "MaterialError": "km.material",
    "Library": "km.library",
    "LibraryError": "km.library",
    "default_library": "km.library",
}

__getattr__, __dir__, __all__ = install_lazy(__name__, _EXPORTS)
