"""Real photographs (public domain) with the sample head fitted from stored correspondences
(tests/data/capture/*_points.json), captured and relit in the lightweight engine. The capture is the
session's (``portrait_capture``, tests/capture/portraits.py), which tests/render/test_mirror.py shares.

``SHEER_WRITE_DOCS=1`` also writes docs/images/capture_<name>.png: photo | fitted Phong | relit ×2.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from tests.capture import portraits

if TYPE_CHECKING:
    from collections.abc import Callable

pytestmark = [pytest.mark.slow, pytest.mark.gl, pytest.mark.xdist_group(portraits.GROUP)]
DOCS = Path(__file__).resolve().parents[2] / "docs" / "images"


def _crop_box(points: np.ndarray, shape: tuple[int, ...], margin: float = 1.1) -> tuple[int, int, int, int]:
    c = points.mean(axis=0)
    half = margin * float(np.ptp(points, axis=0).max())
    x0, y0 = int(max(c[0] - half, 0)), int(max(c[1] - half * 1.1, 0))
    x1, y1 = int(min(c[0] + half, shape[1])), int(min(c[1] + half * 0.9, shape[0]))
    return x0, y0, x1, y1


@pytest.mark.parametrize("name", ["astronaut", "grace_hopper"])
def test_photo_capture_and_relight(name: str, gl_ctx: Any, tmp_path: Path,
                                   portrait_capture: Callable[[str], portraits.PointsCapture]) -> None:
    from PIL import Image

    from capture.face import Face
    from capture.pipeline import linear_to_srgb8
    from render.lights import Light
    from render.lightweight import LightweightRenderer

    captured = portrait_capture(name)
    spec, head, photo, camera = captured.spec, captured.head, captured.photo, captured.camera
    h, w = photo.shape[:2]
    # A generic head on another person: measured 2.8 px (astronaut, face 95 px) and 5.7 px (Hopper, 185 px).
    assert camera.reprojection_error_px is not None and camera.reprojection_error_px < 0.04 * float(np.ptp([p["image"][0] for p in spec["points"]])) * 2
    result = captured.result  # capture(head, photo, camera, texture_size=512)
    assert np.isfinite(result.fit.rms_luv) and result.skin_mask.sum() > 1000
    assert result.reproduction_de2000_skin < 8.0  # a generic head on someone else's face

    # Relight in the photo's own view: the lightweight engine with a camera matching the photo's.
    face = Face(params=result.params, detail=result.detail, data={})
    lw = LightweightRenderer(gl_ctx, head, face, shadow_size=1024)
    try:
        from render.camera import OrbitCamera

        cam = OrbitCamera(fov_y=float(np.degrees(2 * np.arctan(h / 2 / camera.K[1, 1]))))
        eye = camera.centre
        target = eye + camera.R[2] * float(np.linalg.norm(eye - head.vertices.mean(axis=0)))
        d = eye - target
        cam.target = target
        cam.distance = float(np.linalg.norm(d))
        cam.yaw = float(np.degrees(np.arctan2(d[0], d[2])))
        cam.pitch = float(np.degrees(np.arcsin(d[1] / cam.distance)))
        cam.near, cam.far = cam.distance * 0.5, cam.distance * 2.0
        lw.camera = cam
        lw.lights = [Light.directional(55, 25, 1.1, colour=(1.0, 0.92, 0.8))]
        left = lw.render_image((w, h))
        lw.lights = [Light.directional(-60, 10, 0.9, colour=(0.8, 0.9, 1.0)),
                     Light.directional(40, 50, 0.5)]
        right = lw.render_image((w, h))
    finally:
        lw.release()
    assert left.shape == (h, w, 3) and not np.array_equal(left, right)
    px = np.array([p["image"] for p in spec["points"]])
    x0, y0, x1, y1 = _crop_box(px, photo.shape)
    panels = [linear_to_srgb8(photo), linear_to_srgb8(result.fitted_render), left, right]
    tiles = [np.asarray(Image.fromarray(p[y0:y1, x0:x1]).resize((256, 256 * (y1 - y0) // (x1 - x0)),
                                                                   Image.LANCZOS)) for p in panels]
    strip = np.concatenate(tiles, axis=1)
    # The face region of the relit image is lit (not black).
    assert tiles[2].mean() > 30
    out = DOCS if os.environ.get("SHEER_WRITE_DOCS") else tmp_path
    out.mkdir(parents=True, exist_ok=True)
    Image.fromarray(strip).save(out / f"capture_{name}.png")
