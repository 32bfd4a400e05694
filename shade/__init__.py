"""The Shade Finder's physics: a foundation matched to a skin, its coverage, and skin read from a photograph.

- :mod:`shade.match` — the shade bank (each foundation's reflectance over a skin at its thickness), the match
  of a measured or photographed skin, ΔE2000 under several illuminants (metamerism), and the match's
  confidence (how close the skin model came to the colour).
- :mod:`shade.coverage` — how well a range of shades covers the skins the skin model can produce.
- :mod:`shade.photo` — a skin colour read from a region of a photograph, colour-corrected by a checker (the
  face's region is found by :mod:`capture.skin`, a layer up, with MediaPipe's landmarks).

Stands on :mod:`km` (optics, the skin model, colour) and :mod:`core`; used by the studio's Shade Finder,
the kiosk's *Find my foundation*, ``sheer shade`` and ``sheer bench shade``. Never imports Qt or GL.
"""
