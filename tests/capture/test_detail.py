"""The detail texture is the photograph ÷ the fitted model (issue 14's follow-up, done in issue 15).

The paper divides the photograph by its reflectance map (indexed by the camera-space normal). On a face
turned from the camera the map also absorbs the regional albedo that correlates with the normal, and the
detail texture no longer gives the photograph back: the capture's reproduction of GPU-drawn faces turned
15–30° was ΔE2000 2.0–2.9. Divided by the fitted Phong model — what the lightweight engine multiplies the
detail by — it is 0.16–0.51 on every case of tests/capture/test_out_of_sample.py.

Away from the photograph's view: a face photographed turned +30° (bench/capture_truth.py draws it on the
GPU with its own renderer), captured, then relit by the lightweight engine *from the front* under the same
flash, against the GPU's own frontal photograph of the same face, over the 34,266 frontal face pixels
the turned photograph saw (mean ΔE2000):

==================================== ===========
detail texture                       frontal view
==================================== ===========
photograph ÷ fitted model (now)      1.23
photograph ÷ reflectance map (paper) 3.05
==================================== ===========
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

if TYPE_CHECKING:
    import moderngl

pytestmark = [pytest.mark.slow, pytest.mark.gl]


def test_detail_times_the_fitted_model_is_the_photograph() -> None:
    """At the photograph's own view, detail × model gives each seen texel's photograph value back."""
    from bench.capture_synthetic import FLASH_RGB, light_from_camera, validation_camera
    from capture.phong import Geometry, PhongParams, delta_e2000, shade
    from capture.pipeline import bake_detail, fitted_shading, pixel_data, sample_texture
    from painting.head import load_head

    head = load_head()
    cam = validation_camera(256)
    light = light_from_camera(cam, 4.0, 3.0)
    p = PhongParams(diffuse=np.array([0.46, 0.31, 0.245]), specular=0.18, exponent=24.0, ambient_scale=1.0,
                    flash_rgb=FLASH_RGB, ambient_rgb=np.full(3, 0.03))
    pix = pixel_data(head, cam)
    photo = np.zeros((256, 256, 3))
    model = shade(p, Geometry.from_vectors(pix.normals, pix.view, light), clip=False)
    # a smooth albedo pattern in UV (the texture then resamples it without loss)
    u, v = pix.uv[:, :1], pix.uv[:, 1:]
    pattern = 1.0 + 0.25 * np.sin(40 * u + np.array([0.0, 1.0, 2.0])) * np.cos(30 * v)
    photo[pix.rows, pix.cols] = np.clip(model * pattern, 0, 1)
    detail, valid = bake_detail(head, cam, photo, pix.depth, fitted_shading(p, light), 512)
    assert valid.mean() > 0.1
    facing = np.einsum("pc,pc->p", pix.normals, pix.view) > 0.5
    back = np.clip(sample_texture(detail, pix.uv) * model, 0, 1)
    de = delta_e2000(back[facing], photo[pix.rows, pix.cols][facing])
    assert float(np.median(de)) < 0.2, float(np.median(de))


def _frontal_relit(ctx: moderngl.Context, head: Any, detail: np.ndarray, result: Any, camera: Any) -> np.ndarray:
    from capture.face import Face
    from render.lights import Light
    from render.lightweight import LightweightRenderer
    from render.pinhole import pinhole_camera

    lw = LightweightRenderer(ctx, head, Face(params=result.params, detail=detail, data={}))
    try:
        lw.camera = pinhole_camera(camera, head.vertices)
        lw.lights = [Light("directional", tuple(result.light_dir_world), tuple(result.params.flash_rgb), 1.0, True)]
        lw.eye_highlights = False
        return lw.render_image((camera.width, camera.height))
    finally:
        lw.release()


def test_a_turned_capture_relit_from_the_front(gl_ctx: moderngl.Context) -> None:
    from bench.capture_synthetic import FLASH_RGB
    from bench.capture_truth import Case, case_camera, case_head, draw_case, render_photo
    from capture.mask import landmark_region
    from capture.phong import delta_e2000
    from capture.pipeline import bake_detail, capture, pixel_data, sample_texture
    from capture.probe import analyse_probe
    from km.srgb import srgb_decode

    case = Case("sample", 24.0, light_deg=(8.0, 0.0), yaw_deg=30.0)
    scene = draw_case(gl_ctx, case)
    result = capture(scene.head, scene.photo.linear, scene.fit_camera, probe=analyse_probe(scene.probe_linear),
                     texture_size=512)
    front_cam = case_camera(scene.head, Case("sample", 24.0))
    _, texture = case_head("sample")
    front = render_photo(gl_ctx, scene.head, texture, front_cam, scene.diffuse, 0.18, 24.0, scene.light, FLASH_RGB,
                         result.params.ambient_scale * result.params.ambient_rgb)
    # the frontal skin pixels the turned photograph saw (facing both cameras, inside the capture's mask
    # region re-projected: texels seen)
    pix = pixel_data(scene.head, front_cam)
    seen = sample_texture(result.detail_valid.astype(float)[..., None], pix.uv)[:, 0] > 0.999
    facing = np.einsum("pc,pc->p", pix.normals, pix.view) > 0.5
    region = landmark_region(front_cam, scene.head.metadata.landmarks, (front_cam.height, front_cam.width))
    sel = seen & facing & region[pix.rows, pix.cols]
    assert sel.sum() > 2000
    truth = front.linear[pix.rows[sel], pix.cols[sel]]

    def mean_de(detail: np.ndarray) -> float:
        img = _frontal_relit(gl_ctx, scene.head, detail, result, front_cam)
        got = srgb_decode(img[pix.rows[sel], pix.cols[sel]] / 255.0)
        return float(delta_e2000(got, truth).mean())

    now = mean_de(result.detail)
    # the paper's detail, baked from the same capture: the photograph ÷ its reflectance map
    pix_turned = pixel_data(scene.head, scene.fit_camera)
    paper, _ = bake_detail(scene.head, scene.fit_camera, scene.photo.linear, pix_turned.depth,
                           lambda n, v: result.rmap.sample(n @ scene.fit_camera.R.T), 512)
    before = mean_de(paper)
    assert now < 1.35, now  # measured 1.23 (module docstring)
    assert now < before - 1.0, (now, before)  # measured 3.05
