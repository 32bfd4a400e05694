"""The reference mode's full-resolution Gaussians run three to a pass pair (sss_gauss3.frag) with the same
frame as one Gaussian per pass pair: the same taps (whole-texel ones: the pair's widest radius adds zero weights
but on the nearest skin), and the sum cut to half precision as the blending did."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from render.lights import Light
from render.renderer import Renderer

pytestmark = pytest.mark.gl


@pytest.mark.parametrize("full_resolution", [False, True])
def test_three_gaussians_a_pass_give_the_per_gaussian_frame(_gl_session_ctx: Any, full_resolution: bool) -> None:
    from painting import Document
    from painting.looks import apply_look

    doc = Document.from_head(resolution=512)
    apply_look(doc, "red-lip")
    r = Renderer(_gl_session_ctx, doc.head, layout=doc.layout)
    try:
        r.lights = [Light.directional(35.0, 25.0, 1.5)]
        r.settings.mode = "reference"
        r.settings.reference_full_resolution = full_resolution  # five full-resolution Gaussians: 3 + 2
        frames = []
        for n in (1, 3):
            r.sss.full_per_pass = n
            frames.append(r.render_image((640, 360)).astype(int))
        mask = r.skin_pixel_mask()
        diff = np.abs(frames[0] - frames[1]).max(axis=-1)
        assert mask.sum() > 10_000
        assert diff.max() <= 1  # at most one 8-bit level (the 3 + 2 split sums in another order)
        assert (diff[mask] > 0).mean() < (0.01 if full_resolution else 0.001)
        assert len([k for k in r.sss._gauss3 if k[1] == 1 and k[2] == 3]) >= 1  # the three-Gaussian passes ran
    finally:
        r.release()
