"""Sheer's face capture (Paris et al. 2003, "Lightweight face relighting").

A flash photograph of a face, a head mesh, the photograph's camera and a mirror-ball probe go in; a
relightable face comes out: the Phong skin parameters and a detail texture in the head's UV space (a
face folder, :mod:`capture.face`), which the lightweight engine (:mod:`render.lightweight`) draws.

What it may import: :mod:`core`, :mod:`km`, :mod:`painting` and :mod:`project` (the layers below it) and
numerical and file libraries (numpy, scipy, colour-science, Pillow, OpenEXR, trimesh, pyvista). Never
:mod:`render` (its sibling), Qt or GL: the capture runs headless, without a GL context — its G-buffers
come from :mod:`painting.raster`'s CPU rasteriser. pyproject.toml's import-linter contracts check this.

- :mod:`capture.camera`: the photograph's camera (projection matrix, or DLT + refinement from ≥ 6 points).
- :mod:`capture.raster`: G-buffers in the photo's view and in UV space, on :mod:`painting.raster`'s rasteriser.
- :mod:`capture.mask`: the skin mask (painted, or landmark polygon refined by a skin-hue model).
- :mod:`capture.probe`: mirror-ball light-probe analysis (direction, flash hue, ambient).
- :mod:`capture.reflectance`: the reflectance map on the Gaussian sphere; the exponent (Eq. 3).
- :mod:`capture.phong`: the Phong skin model and its fit in CIE Luv.
- :mod:`capture.lobe`: the specular lobe (s, i_s) read from the high-passed photograph, registered on it.
- :mod:`capture.pipeline`: the whole capture and the detail texture.
- :mod:`capture.face`: the face folder (face.json, detail.exr, report.png) written and read back.
- :mod:`capture.lod`: coarse heads by quadric decimation, detail re-baked.
- the synthetic ground truth the capture is validated on lives in :mod:`bench.capture_synthetic`.
"""
