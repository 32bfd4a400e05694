"""``sheer bench studio --json`` (bench.studio) on a real window: a small run of the real command prints one
JSON object with every key, and each timed series reports its 90th percentile and its maximum beside its
median."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.cli_support import sheer

pytestmark = [pytest.mark.qt, pytest.mark.gl]

#: Every key of the JSON object (the keys of earlier versions keep their names).
KEYS = {
    "startup_to_first_frame_s", "orbit_fps", "orbit_frame_ms", "orbit_frame_ms_p90", "orbit_frame_ms_max",
    "orbit_paintgl_ms", "orbit_paintgl_ms_p90", "orbit_paintgl_ms_max", "viewport_px", "dab_to_frame_ms",
    "dab_to_frame_ms_p90", "dab_to_frame_ms_max", "dab_update_ms", "dab_update_ms_p90", "dab_update_ms_max",
    "paint_resolution", "render_mode", "load_average_1min", "cpus", "renderer_frames", "note", "backends",
    "targets", "orbit_frames_presented", "orbit_input_events", "orbit_event_deliveries",
    "orbit_interactive_scale", "settle_ms", "light_settle_ms", "light_drag_fps", "interactive_vs_settled_de2000", "interactive_vs_settled_de2000_p95",
    "interactive_scale_compared", "first_dab_ms", "dabs_presented", "interactive_budget_ms",
    "interactive_scale_cap", "dab_frame_paintgl_ms", "dab_frame_paintgl_ms_p90", "dab_frame_paintgl_ms_max",
    "dab_frame_flush_ms", "dab_frame_flush_ms_p90", "dab_frame_flush_ms_max",
    "settle_ms_p90", "settle_ms_max", "light_settle_ms_p90", "light_settle_ms_max", "settles_timed",
    "settle_frame_ms", "light_settle_frame_ms", "light_drag_paintgl_ms",
}
SERIES = ("orbit_frame_ms", "orbit_paintgl_ms", "dab_to_frame_ms", "dab_update_ms", "settle_ms", "light_settle_ms")


def test_bench_studio_prints_every_key_with_p90_and_max() -> None:
    proc = subprocess.run([sys.executable, "-m", "app", "bench", "studio", "--json", "--orbit-seconds", "0.6",
                           "--dab-seconds", "0.4", "--resolution", "512", "--settles", "2"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    result = json.loads(proc.stdout)  # one JSON object and nothing else on stdout
    assert set(result) == KEYS
    for name in SERIES:
        median, p90, slowest = result[name], result[f"{name}_p90"], result[f"{name}_max"]
        assert 0 < median <= p90 <= slowest, (name, median, p90, slowest)
    assert result["viewport_px"] == [1280, 720] and result["paint_resolution"] == 512
    assert result["render_mode"] == "fast" and result["startup_to_first_frame_s"] > 0
    # the orbit's frames reached the screen (counted at the swap), interactive, within the scale cap
    assert result["orbit_frames_presented"] >= 3 and result["orbit_fps"] > 0
    assert result["orbit_input_events"] == 60 and 1 <= result["orbit_event_deliveries"] <= 60
    assert 0 < result["orbit_interactive_scale"] <= result["interactive_scale_cap"] < 1.0
    # the view settled after the last input, and the interactive frame of a pose is close to the settled
    assert result["settle_ms"] > 0 and result["settles_timed"] == 2
    assert 0 < result["settle_frame_ms"] < result["settle_ms_max"]
    assert 0 < result["light_settle_frame_ms"] < result["light_settle_ms_max"]
    assert result["light_drag_paintgl_ms"] > 0
    assert result["light_settle_ms"] > 0 and result["light_drag_fps"] > 0
    assert 0 <= result["interactive_vs_settled_de2000"] <= result["interactive_vs_settled_de2000_p95"]
    assert 0 < result["interactive_scale_compared"] < 1.0
    # every dab reached the screen; the first dab of the session is timed
    assert result["dabs_presented"] == 40 and result["first_dab_ms"] > 0
    assert result["backends"] == {"renderer": "render.Renderer", "library": "km", "document": "painting.Document"}


def test_bench_studio_refuses_no_timed_settle() -> None:
    # in this process: the options are refused before any window (what a process adds is tested above)
    proc = sheer("bench", "studio", "--json", "--settles", "0")
    assert proc.returncode == 2 and "--settles must be at least 1" in proc.stderr
    assert "Traceback" not in proc.stderr and proc.stdout == ""
