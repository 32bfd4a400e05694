"""The composite's cover (render.cover): the head's convex hull gives the same frames as the head, and is
left out where it cannot cover the head (the eye inside it, the near plane cutting it)."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from render.cover import CoverMesh, compute_cover, load_cover
from render.lights import Light
from render.renderer import Renderer
from tests.imaging import max_level_difference

if TYPE_CHECKING:
    from collections.abc import Iterator

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def renderer(_gl_session_ctx: Any) -> Iterator[Renderer]:
    from painting import Document
    from painting.looks import apply_look

    doc = Document.from_head(resolution=512)
    apply_look(doc, "red-lip")
    r = Renderer(_gl_session_ctx, doc.head, layout=doc.layout)
    r.lights = [Light.directional(35.0, 25.0, 1.5)]
    from render.km_pass import LayerInput

    r.set_layers([LayerInput(lay.material_object, np.array(lay.thickness), lay.opacity, lay.visible, lay.name)
                  for lay in doc.layers])
    deadline = time.monotonic() + 60.0
    while r._composite_cover() is None and time.monotonic() < deadline:  # the hull's first computation
        time.sleep(0.05)
    yield r
    r.release()


def test_hull_is_cached_closed_outward_and_contains_the_head(renderer: Renderer, gl_ctx: Any) -> None:
    v = renderer.gpu_head.vertices
    points, faces = compute_cover(v)
    cached = load_cover(v)
    assert cached is not None and np.array_equal(cached[1], faces)
    assert len(faces) < renderer.gpu_head.triangle_count / 8
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2), "the hull is a closed surface"
    cover = CoverMesh(gl_ctx, points, faces)
    try:
        # every vertex of the head is on the inner side of every face (outward normals)
        d = v @ cover._normals.T - cover._offsets  # noqa: SLF001
        assert d.max() < 1e-4
    finally:
        cover.release()


@pytest.mark.parametrize("mode", ["fast", "reference"])
@pytest.mark.parametrize("linear", [False, True])
def test_the_hull_composites_the_same_frame_as_the_head(renderer: Renderer, gl_ctx: Any, mode: str,
                                                        linear: bool) -> None:
    r = renderer
    assert r._cover is not None  # noqa: SLF001
    r.settings.mode = mode
    with_hull = r.render_image((400, 300), linear=linear)
    cover, r._cover = r._cover, None  # noqa: SLF001
    try:
        with_head = r.render_image((400, 300), linear=linear)
        w, h = r._targets["diffuse"].size  # noqa: SLF001
        drawn = np.frombuffer(r._targets["diffuse"].read(), np.float16).reshape(h, w, 4)[::-1, :, 3] != 0  # noqa: SLF001
    finally:
        r._cover = cover  # noqa: SLF001
        r.settings.mode = "fast"
    # the head's pixels (the lit pass drew them): one program on the same inputs (texelFetch at its own
    # pixel), exactly determined (GL 4.5 appendix A, rule 4)
    np.testing.assert_array_equal(with_hull[drawn], with_head[drawn])
    if linear:  # a float target: the clear and the composite's u_clear_colour are the same floats
        np.testing.assert_array_equal(with_hull, with_head)
    else:  # the hull's other pixels: the clear colour converted to 8 bits by the composite instead of by the
        # clear, which GL lets take either neighbouring level (measured on llvmpipe: the same bytes)
        assert max_level_difference(with_hull, with_head) <= 1


def test_hull_is_left_out_where_it_cannot_cover(renderer: Renderer, gl_ctx: Any) -> None:
    r = renderer
    cover = r._cover  # noqa: SLF001
    assert cover is not None
    cam = r.camera
    proj = cam.projection(4 / 3)
    near = float(proj[2, 3] / (proj[2, 2] - 1.0))
    assert cover.usable(cam.eye(), cam.view(), near)
    saved = cam.distance
    try:
        cam.distance = 0.05 * saved  # the eye inside the head's hull
        proj = cam.projection(4 / 3)
        assert not cover.usable(cam.eye(), cam.view(), float(proj[2, 3] / (proj[2, 2] - 1.0)))
        # an eye just outside a face, looking at it, with a near plane beyond that face: not usable
        from core.camera import look_at

        centre = cover.points[cover.faces[0]].mean(axis=0)
        eye = centre + cover._normals[0] * 0.01  # noqa: SLF001
        up = np.array([0.0, 1.0, 0.0]) if abs(cover._normals[0][1]) < 0.9 else np.array([1.0, 0.0, 0.0])  # noqa: SLF001
        view = look_at(eye, centre, up)
        assert cover.usable(eye, view, 0.001)
        assert not cover.usable(eye, view, 0.05)
    finally:
        cam.distance = saved
