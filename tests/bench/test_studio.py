"""``sheer bench studio --json`` (bench.studio) on a real window: a small run of the real command prints one
JSON object with every key, and each timed series reports its 90th percentile and its maximum beside its
median."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

pytestmark = [pytest.mark.qt, pytest.mark.gl]

#: Every key of the JSON object (the keys of earlier versions keep their names).
KEYS = {
    "startup_to_first_frame_s", "orbit_fps", "orbit_frame_ms", "orbit_frame_ms_p90", "orbit_frame_ms_max",
    "orbit_paintgl_ms", "orbit_paintgl_ms_p90", "orbit_paintgl_ms_max", "viewport_px", "dab_to_frame_ms",
    "dab_to_frame_ms_p90", "dab_to_frame_ms_max", "dab_update_ms", "dab_update_ms_p90", "dab_update_ms_max",
    "paint_resolution", "render_mode", "load_average_1min", "cpus", "renderer_frames", "note", "backends",
    "targets",
}
SERIES = ("orbit_frame_ms", "orbit_paintgl_ms", "dab_to_frame_ms", "dab_update_ms")


def test_bench_studio_prints_every_key_with_p90_and_max() -> None:
    frames, dabs = 4, 3
    proc = subprocess.run([sys.executable, "-m", "app", "bench", "studio", "--json", "--frames", str(frames),
                           "--dabs", str(dabs), "--resolution", "512"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    result = json.loads(proc.stdout)  # one JSON object and nothing else on stdout
    assert set(result) == KEYS
    for name in SERIES:
        median, p90, slowest = result[name], result[f"{name}_p90"], result[f"{name}_max"]
        assert 0 < median <= p90 <= slowest, (name, median, p90, slowest)
    assert result["orbit_fps"] == pytest.approx(1000.0 / result["orbit_frame_ms"], rel=0.01)
    assert result["viewport_px"] == [1280, 720] and result["paint_resolution"] == 512
    assert result["render_mode"] == "fast" and result["startup_to_first_frame_s"] > 0
    # every orbit step and every dab drew a new frame (3 untimed orbit steps first)
    assert result["renderer_frames"] >= frames + 3 + dabs
    assert result["backends"] == {"renderer": "render.Renderer", "library": "km", "document": "painting.Document"}
