"""``sheer bench capture``'s automatic-capture figures (issue #15): landmarks and photo → face folder.

- ``landmarks_ms`` (target ≤ 300): :func:`capture.landmarks.detect_faces` on the two shared portraits and
  a render of the sample head, the detector already loaded (a kiosk's steady state), median / p90 / max
  over the runs; ``landmarks_first_ms``: the first call in the process (MediaPipe's import and model load).
- ``capture_auto_s`` (target ≤ 10): :func:`capture.auto.capture_auto` from Grace Hopper's portrait file to
  a written face folder (the person's own head, the default 512² detail texture), median / p90 / max;
  ``capture_auto_first_s``: the first one in the process (the imports of trimesh, OpenEXR… included);
  ``capture_auto_cpu_s``: the process's CPU seconds per capture (median; on a loaded machine the wall
  time grows with the load average, this does not).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np


def _render_sample() -> np.ndarray:
    """The sample head from the front (the capture's CPU rasteriser, albedo × Lambert), uint8 512²."""
    from capture.camera import look_at
    from capture.pipeline import linear_to_srgb8, pixel_data, sample_texture
    from km.srgb import srgb_decode
    from painting.head import load_head

    head = load_head()
    cam = look_at(np.array([-0.1, 1.1, 22.0]), np.array([-0.1, 1.1, 2.0]), np.array([0.0, 1.0, 0.0]), 15.0, 512, 512)
    pix = pixel_data(head, cam)
    albedo = srgb_decode(np.asarray(head.albedo, dtype=np.float64) / 255.0)
    lam = np.clip(np.einsum("pc,pc->p", pix.normals, pix.view), 0.0, 1.0)
    img = np.full((512, 512, 3), 0.18)
    img[pix.rows, pix.cols] = sample_texture(albedo, pix.uv) * (0.25 + 0.9 * lam[:, None])
    return linear_to_srgb8(img)


def measure(quick: bool = False) -> dict[str, Any]:
    """The automatic capture's timings (see the module docstring); ``quick``: fewer runs."""
    from PIL import Image

    from bench.stats import spread
    from capture.auto import capture_auto
    from capture.landmarks import detect_faces
    from core.assets import find_asset

    photos = [np.asarray(Image.open(find_asset(p)).convert("RGB"))
              for p in ("photos/grace_hopper.jpg", "photos/astronaut.png")] + [_render_sample()]
    t = time.perf_counter()
    detect_faces(photos[0])
    first_ms = 1000.0 * (time.perf_counter() - t)
    runs = 3 if quick else 10
    times = []
    for _ in range(runs):
        for img in photos:
            t = time.perf_counter()
            faces = detect_faces(img)
            times.append(1000.0 * (time.perf_counter() - t))
            assert faces, "a benchmark photo lost its face"
    captures, cpu = [], []
    with tempfile.TemporaryDirectory(prefix="sheer-bench-auto-") as tmp:
        for i in range(2 if quick else 5):
            t, c = time.perf_counter(), time.process_time()
            capture_auto(find_asset("photos/grace_hopper.jpg"), Path(tmp) / f"face{i}")
            captures.append(time.perf_counter() - t)
            cpu.append(time.process_time() - c)
    return {"landmarks_first_ms": round(first_ms, 1), **spread("landmarks_ms", times, 1),
            "landmarks_runs": len(times), "capture_auto_first_s": round(captures[0], 2),
            **spread("capture_auto_s", captures[1:] or captures, 2), "capture_auto_runs": len(captures),
            "capture_auto_cpu_s": round(float(np.median(cpu[1:] or cpu)), 2)}
