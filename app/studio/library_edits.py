"""What the material library editor may edit, and Duncan shade mixing.

The edits themselves are the document's (:mod:`painting.document_materials`): one undo history with the
strokes, and every layer of an edited material follows it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from km.material import Material


#: The properties the editor's fields set, with the type each value is converted to.
EDITABLE = {"category": str, "thickness_um": float, "max_thickness_um": float, "roughness": float,
            "ior": float}


def duncan_mix(a: Material, b: Material, fraction_b: float, name: str) -> Material:
    """A new material ``name`` mixing ``a`` and ``b`` by Duncan's rule (``km.optics.mix``).

    S and K (per mm) are the concentration-weighted sums, ``fraction_b`` in [0, 1] of ``b`` (clipped), on
    ``a``'s wavelength grid (``b``'s spectra interpolated onto it).
    """
    from km.optics import mix

    wl = np.asarray(a.wavelengths, float)
    sb = np.interp(wl, np.asarray(b.wavelengths, float), np.asarray(b.S, float))
    kb = np.interp(wl, np.asarray(b.wavelengths, float), np.asarray(b.K, float))
    c = float(np.clip(fraction_b, 0.0, 1.0))
    S, K = mix([(1.0 - c, np.asarray(a.S, float), np.asarray(a.K, float)), (c, sb, kb)])
    return a.replace(name=name, S=S, K=K, measurement=None, source="modelled",
                     provenance=f"Duncan mix: {1 - c:.0%} {a.name} + {c:.0%} {b.name}")
