"""Renderer pieces that need no GPU: the shader loader, kernels, SH, tangents, camera."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pytest

from render.camera import OrbitCamera
from render.errors import RenderError
from render.gpu_head import vertex_tangents
from render.lights import Environment, Light, equirect_directions
from render.shaders import ShaderLibrary
from render.sss import SKIN_GAUSSIANS, fast_kernel

if TYPE_CHECKING:
    from pathlib import Path


def test_include_resolved_once_with_defines(tmp_path: Path) -> None:
    (tmp_path / "a.glsl").write_text('#include "b.glsl"\nfloat a() { return b(); }\n')
    (tmp_path / "b.glsl").write_text("float b() { return 1.0; }\n")
    (tmp_path / "main.frag.glsl").write_text('#version 450 core\n#include "a.glsl"\n#include "b.glsl"\nvoid main() {}\n')
    src = ShaderLibrary([tmp_path]).source("main.frag", {"NL": 3})
    lines = src.splitlines()
    assert lines[0] == "#version 450 core" and lines[1] == "#define NL 3"
    assert src.count("float b()") == 1 and "float a()" in src and "#include" not in src
    assert src.index("float b()") < src.index("float a()")


def test_include_errors_name_the_file(tmp_path: Path) -> None:
    (tmp_path / "x.glsl").write_text('#include "y.glsl"\n')
    (tmp_path / "y.glsl").write_text('#include "x.glsl"\n')
    (tmp_path / "m.glsl").write_text('#include "missing.glsl"\n')
    lib = ShaderLibrary([tmp_path])
    with pytest.raises(RenderError, match="cycle"):
        lib.source("x")
    with pytest.raises(RenderError, match=r"m.glsl:1: .*missing.glsl"):
        lib.source("m")
    with pytest.raises(RenderError, match="bad shader define"):
        lib.source("y", {"1x": 1})


def test_every_shipped_shader_expands() -> None:
    lib = ShaderLibrary()
    names = sorted(p.name for p in lib.folders[0].glob("*.glsl") if p.name.count(".") == 2)
    assert "frame.frag.glsl" in names and "km.frag.glsl" in names
    for name in names:
        src = lib.source(name, {"NL": 2, "NLIGHTS": 3, "NW": 81, "MAX_LAYERS": 8, "NTAPS": 17})
        assert src.startswith("#version 450") and "#include" not in src


@pytest.mark.parametrize("taps", [11, 17, 25])
def test_fast_kernel_is_normalised_and_symmetric(taps: int) -> None:
    k = fast_kernel(taps)
    assert k.shape == (taps, 4)
    np.testing.assert_allclose(k[:, :3].sum(axis=0), 1.0, atol=1e-6)
    assert k[0, 3] == 0.0
    offs = np.sort(k[1:, 3])
    np.testing.assert_allclose(offs, -offs[::-1], atol=1e-6)
    # red scatters farthest: less weight at the centre than blue
    assert k[0, 0] < k[0, 2]
    merged = fast_kernel(taps, core_mm=1.0)
    np.testing.assert_allclose(merged[:, :3].sum(axis=0), 1.0, atol=1e-6)
    assert np.all(merged[0, :3] >= k[0, :3])


def test_skin_profile_weights_sum_to_one() -> None:
    w = np.array([g[1:] for g in SKIN_GAUSSIANS])
    np.testing.assert_allclose(w.sum(axis=0), 1.0, atol=1e-3)


def test_environment_sh_of_a_uniform_sky() -> None:
    env = Environment.from_image(np.ones((32, 64, 3), np.float32), "grey", intensity=2.0)
    n = np.array([[0, 1, 0], [1, 0, 0], [0, 0, -1.0]])
    np.testing.assert_allclose(env.irradiance(n), 2.0, rtol=1e-2)
    d, dw = equirect_directions(32, 64)
    np.testing.assert_allclose(dw.sum(), 4 * np.pi, rtol=1e-3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-9)


def test_environment_brighter_side() -> None:
    img = np.zeros((32, 64, 3), np.float32)
    img[:8] = 10.0  # a bright sky
    env = Environment.from_image(img, "sky")
    up, down = env.irradiance(np.array([[0, 1.0, 0], [0, -1.0, 0]]))
    assert up[0] > 5 * max(down[0], 1e-6)


def test_tangents_are_orthonormal_and_follow_u() -> None:
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
    f = np.array([[0, 1, 2], [1, 3, 2]])
    uv = v[:, :2].copy()
    n = np.tile([0, 0, 1.0], (4, 1))
    t = vertex_tangents(v, f, uv, n)
    np.testing.assert_allclose(t[:, :3], np.tile([1.0, 0, 0], (4, 1)), atol=1e-9)
    np.testing.assert_allclose(t[:, 3], 1.0)
    t2 = vertex_tangents(v, f, uv * [-1, 1], n)  # mirrored u
    np.testing.assert_allclose(t2[:, :3], np.tile([-1.0, 0, 0], (4, 1)), atol=1e-9)


def test_camera_looks_at_target() -> None:
    cam = OrbitCamera(yaw=30, pitch=10, distance=5.0, target=np.array([1.0, 2.0, 3.0]))
    vp = cam.view_projection(16 / 9)
    c = vp @ np.array([1.0, 2.0, 3.0, 1.0])
    np.testing.assert_allclose(c[:2] / c[3], 0.0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(cam.eye() - cam.target), 5.0)


def test_light_validation() -> None:
    Light.directional(10, 20, 1.0).validate()
    with pytest.raises(RenderError, match="light 3"):
        Light("spot").validate("light 3")
    with pytest.raises(RenderError, match="finite"):
        Light.directional(0, 0, float("nan")).validate()


def test_reference_taps_space_at_most_a_texel() -> None:
    from render.sss import REFERENCE_TAPS, reference_taps

    for sigma in (0.0, 0.3, 0.7, 1.0, 1.4, 1.9, 2.5, 4.0, 40.0):
        n = reference_taps(sigma)
        assert n % 2 == 1 and 5 <= n <= REFERENCE_TAPS
        if n < REFERENCE_TAPS:  # not capped: taps over ±3σ are at most 0.8 texel apart
            assert 6.0 * sigma / (n - 1) <= 0.8 + 1e-9


@pytest.mark.gl
@pytest.mark.parametrize("shadows", [0, 1, 2])
@pytest.mark.parametrize("lights", [0, 1, 8])
def test_every_lightweight_face_specialisation_compiles(gl_ctx: object, lights: int, shadows: int) -> None:
    """Every light count × shadow mode the engine may ask for (render.lightweight.program_for) compiles:
    no lights with per-pixel shadows once failed (the shadow helper referred to per-light varyings)."""
    lib = ShaderLibrary()
    for env in (0, 1):
        for makeup in (0, 1):
            prog = lib.program(gl_ctx, "lightweight_face.vert", "lightweight_face.frag",  # type: ignore[arg-type]
                               {"LW_NLIGHTS": lights, "LW_SHADOWS": shadows, "LW_ENV": env, "LW_MAKEUP": makeup})
            prog.release()
