"""``sheer bench catalogue``: its options, its catalogue sized by ``--views``, and one small run's keys.

No assertion on timing: only that the figures are there and consistent (speed is measured by the bench).
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import pytest

from bench import catalogue as bench

if TYPE_CHECKING:
    from pathlib import Path


def test_views_size_the_catalogue_and_two_are_todays_24_images(tmp_path: Path) -> None:
    from catalogue import expand, load_spec

    assert bench.view_yaws(2) == [("front", 0.0), ("three-quarter", 30.0)]
    yaws = bench.view_yaws(bench.MAX_VIEWS)
    assert len({name for name, _ in yaws}) == len({yaw for _, yaw in yaws}) == bench.MAX_VIEWS
    assert all(-180 <= yaw <= 180 for _, yaw in yaws)
    for views, images in ((1, 12), (2, 24), (8, 96)):
        path = tmp_path / f"v{views}.toml"
        path.write_text(bench.bench_spec(views, 32), encoding="utf-8")
        spec = load_spec(path)
        assert len(expand(spec)) == images and spec.size == (32, 32)


@pytest.mark.parametrize("argv", [["--workers", "0,2"], ["--workers", "one"], ["--workers", ","], ["--views", "0"],
                                  ["--views", str(bench.MAX_VIEWS + 1)], ["--separate", "-1"], ["--size", "8"]])
def test_bad_options_are_refused(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert bench.main(argv) == 2
    assert "error" in capsys.readouterr().err


@pytest.mark.gl
@pytest.mark.slow
def test_a_small_run_prints_every_key_per_worker_count(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench.main(["--json", "--views", "1", "--workers", "2,1", "--repeats", "1", "--separate", "0",
                       "--size", "32"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["images"] == 12 and out["views"] == 1 and out["workers"] == [1, 2] and out["size"] == "32x32"
    for key in ("images_per_s_1_worker", "images_per_s_2_workers", "scaling_2_vs_1",
                "scaling_2_vs_1_with_cluster_start", "run_s_1_worker", "run_s_2_workers_p90", "cluster_start_s_max",
                "catalogue_s_per_image_1_worker", "worker_busy_s_1_worker", "worker_busy_s_2_workers",
                "first_jobs_s_1_worker", "first_jobs_s_2_workers", "first_run_s_with_cluster_start",
                "resume_noop_s", "resume_noop_ratio", "load_avg_start", "load_avg_end", "egl_devices"):
        assert isinstance(out[key], (int, float)) and out[key] >= 0, key
    assert out["separate_process_s_per_image"] is None and out["speedup_vs_separate_processes"] is None
    per_count = ("images_per_s", "scaling_vs_1", "jobs_per_worker", "max_over_min_jobs", "first_jobs_s",
                 "first_job_s_max", "worker_busy_s")
    for key in per_count:
        assert set(out[key]) == {"1", "2"}, key  # JSON's keys are strings
    assert out["scaling_vs_1"]["1"] == 1.0 and out["scaling_vs_1"]["2"] == out["scaling_2_vs_1"]
    assert out["jobs_per_worker"]["1"] == [12]
    two = out["jobs_per_worker"]["2"]
    assert len(two) == 2 and sum(two) == 12 and two == sorted(two, reverse=True)
    assert out["max_over_min_jobs"]["1"] == 1.0
    assert out["first_job_s_max"]["2"] <= out["first_jobs_s"]["2"]
