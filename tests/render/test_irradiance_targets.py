"""The texture-space irradiance writes E alone when only the key light casts shadows:
the same E as with all three targets, and the visibilities written again as soon as another light casts
shadows (render.irradiance, issue #13's relight).

"The same E": the two are variants of one program, which another GPU may compile to float maths that round
differently; the half-float E then differs by at most one half-float step (measured on llvmpipe: the same
bits)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from render.lights import Light, default_lights
from render.renderer import Renderer
from tests.imaging import assert_relative_close

if TYPE_CHECKING:
    from pathlib import Path

pytestmark = pytest.mark.gl
SIZE = (160, 120)


@pytest.fixture(scope="module")
def doc() -> Any:
    from painting import Document

    return Document.from_head(resolution=256)


def _e(r: Renderer) -> np.ndarray:
    n = r.irradiance.size
    return np.frombuffer(r.irradiance.textures[0].read(), np.float16).reshape(n, n, 4).copy()


def test_e_alone_is_the_same_e_and_shadowed_fills_write_their_visibility(
        doc: Any, gl_ctx: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SHEER_CACHE_DIR", str(tmp_path))  # no padding index on disk: the first update makes it
    r = Renderer(gl_ctx, doc.head, layout=doc.layout)
    try:
        r.settings.irradiance_size = 256
        key, fill, rim = default_lights()
        # the key alone shadowed (the default rig's fill casts shadows since the raking-light fix)
        r.lights = [key, Light(fill.kind, fill.vector, fill.colour, fill.intensity, False), rim]
        assert [lt.shadows for lt in r.lights] == [True, False, False]
        r.render_image(SIZE)
        irr = r.irradiance
        assert irr.size == 256 and irr.index is not None
        assert [k[-1] for k in irr.programs] == [0], "the first update writes all three targets"
        three = _e(r)
        irr.invalidate()
        r.render_image(SIZE)
        assert sorted(k[-1] for k in irr.programs) == [0, 1], "the key light alone shadowed: E alone"
        # one half-float step is 2^-11 to 2^-10 of the value; under E = 1e-3 the bound stays at 1e-6, still
        # at least one step
        assert_relative_close(_e(r), three, rtol=2.0 ** -10, floor=1e-3, name="E-alone-vs-three-targets")
        n = irr.size
        vis = np.frombuffer(irr.textures[1].read(), np.uint8).reshape(n, n, 4)
        assert vis[..., 0].min() == 255, "the fill casts no shadow yet"
        fill = Light.directional(-45.0, 5.0, 0.35, (0.9, 0.95, 1.0), shadows=True)
        r.lights = [r.lights[0], fill, r.lights[2]]
        r.render_image(SIZE)
        vis = np.frombuffer(irr.textures[1].read(), np.uint8).reshape(n, n, 4)
        assert (vis[..., 0] < 128).sum() > 50, "the shadowed fill's visibility was not written"
    finally:
        r.release()
