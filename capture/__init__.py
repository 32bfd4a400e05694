"""Sheer's face capture (Paris et al. 2003, "Lightweight face relighting"), numpy/scipy only — no Qt, no GL.

- :mod:`capture.camera`: the photograph's camera (projection matrix, or DLT + refinement from ≥ 6 points).
- :mod:`capture.raster`: G-buffers in the photo's view and in UV space, on :mod:`painting.raster`'s rasteriser.
- :mod:`capture.mask`: the skin mask (painted, or landmark polygon refined by a skin-hue model).
- :mod:`capture.probe`: mirror-ball light-probe analysis (direction, flash hue, ambient).
- :mod:`capture.reflectance`: the reflectance map on the Gaussian sphere; the exponent (Eq. 3).
- :mod:`capture.phong`: the Phong skin model and its fit in CIE Luv.
- :mod:`capture.pipeline`: the whole capture, the detail texture, face folders.
- :mod:`capture.lod`: coarse heads by quadric decimation, detail re-baked.
- :mod:`capture.synthetic`: synthetic ground truth for validation.
"""
