"""Real runs on a 2-process Dask LocalCluster: outputs, manifest, determinism, resume, changed materials,
failures, GLB jobs, and a worker SIGKILLed mid-run."""

from __future__ import annotations

import json
import os
import signal
from typing import TYPE_CHECKING

import numpy as np
import pytest
from PIL import Image

from catalogue import expand, load_spec, run_catalogue
from tests.catalogue.test_glb import check_glb

if TYPE_CHECKING:
    from pathlib import Path

#: (with tests/catalogue/test_balance.py: one worker starts the session's cluster, conftest's dask_client)
pytestmark = [pytest.mark.gl, pytest.mark.xdist_group("dask-cluster")]


def _pngs(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*.png") if "sheets" not in p.parts}


def _counters() -> dict[str, int]:
    """This worker process's cache misses (run on each Dask worker)."""
    from catalogue.worker import worker_state

    return dict(worker_state().counters)


def _settled(folder: Path) -> dict[str, bytes]:
    """The images in ``folder`` once no more appear for 0.5 s."""
    import time

    last = _pngs(folder)
    while True:
        time.sleep(0.5)
        now = _pngs(folder)
        if now.keys() == last.keys():
            return now
        last = now


def test_run_manifest_sheets_and_same_bytes_on_every_run_and_worker(dask_client, write_spec, tmp_path) -> None:
    spec = load_spec(write_spec(extra="glb = true"))
    jobs = expand(spec)
    assert len(jobs) == 2 * 2 + 2  # 2 products × 2 lights, and a GLB per product
    before = dask_client.run(_counters)
    result = run_catalogue(spec, tmp_path / "a", jobs=jobs, client=dask_client)
    assert (result.rendered, result.skipped, result.failed) == (6, 0, [])
    # each worker process loaded the head, painted the look and built its renderer at most once
    after = dask_client.run(_counters)
    for addr, c in after.items():
        delta = {k: v - before.get(addr, {}).get(k, 0) for k, v in c.items()}
        assert delta["heads"] <= 1 and delta["documents"] <= 1 and delta["renderers"] <= 1, delta
    manifest = json.loads((tmp_path / "a" / "manifest.json").read_text())
    assert sorted(e["file"] for e in manifest["images"]) == sorted(j.out for j in jobs)
    assert all(e["status"] == "rendered" and e["seconds"] > 0 and e["worker"] for e in manifest["images"])
    assert len({e["worker"] for e in manifest["images"]}) == 2  # both worker processes rendered
    csv_lines = (tmp_path / "a" / "manifest.csv").read_text().splitlines()
    assert csv_lines[0].startswith("file,kind,hash,status") and len(csv_lines) == 7
    for j in jobs:
        data = (tmp_path / "a" / j.out).read_bytes()
        if j.kind == "image":
            img = np.asarray(Image.open(tmp_path / "a" / j.out))
            assert img.shape == (48, 48, 3) and img.std() > 5  # a face, not an empty frame
        else:
            assert j.out.endswith(".glb") and check_glb(data)["images"]
    sheets = sorted(p.name for p in (tmp_path / "a" / "sheets").iterdir())
    assert sheets == ["Lipstick_Nude-front.png", "Lipstick_Pink-front.png"]
    assert Image.open(tmp_path / "a" / "sheets" / sheets[0]).size == (2 * 192, 192 + 16)  # 1 face × 2 lights
    # the products differ on the lips, the rest of the face is the same
    by_product = {j.product: np.asarray(Image.open(tmp_path / "a" / j.out), float) for j in jobs
                  if j.kind == "image" and j.light.name == "portrait"}
    assert np.abs(by_product["Lipstick Nude"] - by_product["Lipstick Pink"]).max() > 10
    # same jobs again, in the reverse order and one job per task: other workers, other cache histories
    again = run_catalogue(spec, tmp_path / "b", jobs=jobs[::-1], client=dask_client)
    assert again.rendered == 6
    assert _pngs(tmp_path / "a") == _pngs(tmp_path / "b")
    assert {j.out: (tmp_path / "a" / j.out).read_bytes() for j in jobs if j.kind == "glb"} == \
           {j.out: (tmp_path / "b" / j.out).read_bytes() for j in jobs if j.kind == "glb"}


def _warmed() -> tuple[bool, int]:
    """(this worker's GL context exists, jobs it ran): run on each Dask worker."""
    from catalogue.worker import worker_state

    return worker_state().ctx is not None, worker_state().counters["jobs"]


def test_workers_warm_up_as_they_start_and_a_warm_worker_draws_a_cold_ones_bytes(write_spec, tmp_path) -> None:
    """The preload makes each worker's context before any job; the images equal a cold process's."""
    import logging
    import time

    from distributed import Client, LocalCluster

    from catalogue.warmup import PRELOAD
    from catalogue.worker import WorkerState

    spec = load_spec(write_spec())
    jobs = expand(spec)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=":0",
                      silence_logs=logging.CRITICAL, preload=[PRELOAD]) as cluster, Client(cluster) as client:
        client.wait_for_workers(1, timeout=60)
        deadline = time.monotonic() + 60
        while not all(ready for ready, _ in client.run(_warmed).values()) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert list(client.run(_warmed).values()) == [(True, 0)]  # warm, and no job has run yet
        result = run_catalogue(spec, tmp_path / "warm", jobs=jobs, client=client)
    assert result.rendered == len(jobs) and not result.failed
    cold = WorkerState()  # this test's own process: a fresh context, nothing warmed
    try:
        for job in jobs:
            assert cold.render(job) == (tmp_path / "warm" / job.out).read_bytes(), job.out
    finally:
        cold.reset()


def test_interrupted_run_then_rerun_renders_only_the_missing(dask_client, write_spec, tmp_path) -> None:
    spec = load_spec(write_spec(lights='[[lights]]\nname = "key"\npreset = "key"'))
    jobs = expand(spec)
    out = tmp_path / "out"
    stop: list[bool] = []  # the user cancels once the first images are in
    first = run_catalogue(spec, out, jobs=jobs, client=dask_client, cancelled=lambda: bool(stop),
                          on_progress=lambda done, total, rendered, failed: rendered and stop.append(True))
    assert first.cancelled and 0 < first.rendered < len(jobs)
    manifest = json.loads((out / "manifest.json").read_text())
    assert {e["status"] for e in manifest["images"]} <= {"rendered", "cancelled"}
    written = _settled(out)  # a task already running when the run stopped may still have written its image
    assert first.rendered <= len(written) < len(jobs) and not list(out.rglob("*.tmp"))
    second = run_catalogue(spec, out, jobs=jobs, client=dask_client)
    assert (second.rendered, second.skipped) == (len(jobs) - len(written), len(written))
    assert all(_pngs(out)[k] == v for k, v in written.items())  # untouched
    third = run_catalogue(spec, out, jobs=jobs, client=dask_client)
    assert (third.rendered, third.skipped) == (0, len(jobs))
    statuses = {e["status"] for e in json.loads((out / "manifest.json").read_text())["images"]}
    assert statuses == {"skipped"}
    forced = run_catalogue(spec, out, jobs=jobs, client=dask_client, force=True)
    assert forced.rendered == len(jobs) and _pngs(out) == _pngs(out)


def test_changed_material_rerenders_only_its_images(dask_client, write_spec, library_copy, tmp_path) -> None:
    path = write_spec(extra=f"library = \"{library_copy.name}\"")
    out = tmp_path / "out"
    before = run_catalogue(load_spec(path), out, client=dask_client)
    assert before.rendered == 4
    data = json.loads(library_copy.read_text())
    pink = next(m for m in data["materials"] if m["name"] == "Lipstick Pink")
    pink["K"] = [k * 1.5 for k in pink["K"]]
    library_copy.write_text(json.dumps(data))
    spec = load_spec(path)
    after = run_catalogue(spec, out, client=dask_client)
    assert (after.rendered, after.skipped) == (2, 2)
    rendered = [e for e in json.loads((out / "manifest.json").read_text())["images"] if e["status"] == "rendered"]
    assert {e["product"] for e in rendered} == {"Lipstick Pink"}


def test_a_failing_job_is_retried_once_then_recorded(dask_client, write_spec, tmp_path, capsys) -> None:
    (tmp_path / "broken.exr").write_bytes(b"not an EXR file")
    spec_path = write_spec(lights='[[lights]]\nname = "broken"\nenvironment = "broken.exr"')
    out = tmp_path / "out"
    from app.cli import main

    address = dask_client.scheduler.address
    assert main(["catalogue", str(spec_path), "--out", str(out), "--scheduler", address]) == 1
    captured = capsys.readouterr()
    assert "2 job(s) failed" in captured.err and "failed.json" in captured.err
    failed = json.loads((out / "failed.json").read_text())["failed"]
    assert len(failed) == 2 and {f["light"] for f in failed} == {"broken"}
    assert all(f["attempts"] == 2 and f["error"] for f in failed)
    assert len(_pngs(out)) == 4  # the other jobs went on
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["failed"] == 2 and sum(e["status"] == "failed" for e in manifest["images"]) == 2


def test_a_worker_killed_mid_run_loses_and_duplicates_nothing(dask_client, write_spec, tmp_path) -> None:
    views = "\n".join(f"[[views]]\nname = \"v{k}\"\nyaw = {k * 10}" for k in range(1, 4))
    spec = load_spec(write_spec(write_spec().read_text().replace("[[views]]\nname = \"front\"", views)))
    jobs = expand(spec)
    assert len(jobs) == 12
    pids = dask_client.run(os.getpid)
    killed: list[int] = []

    def kill_one(done: int, total: int, rendered: int, failed: int) -> None:
        if rendered >= 1 and not killed:
            victim = sorted(pids.values())[0]
            os.kill(victim, signal.SIGKILL)
            killed.append(victim)

    out = tmp_path / "out"
    result = run_catalogue(spec, out, jobs=jobs, client=dask_client, on_progress=kill_one)
    assert killed and result.failed == [] and result.rendered == 12
    manifest = json.loads((out / "manifest.json").read_text())
    files = [e["file"] for e in manifest["images"]]
    assert sorted(files) == sorted(j.out for j in jobs) and len(set(files)) == 12
    assert len(_pngs(out)) == 12 and not list(out.rglob("*.tmp"))
    dask_client.wait_for_workers(2, timeout=60)  # the nanny restarts it, for the tests after this one


def test_captured_faces_projects_and_the_lightweight_mode(dask_client, write_spec, face_dir, tmp_path) -> None:
    from app.cli import main

    project = tmp_path / "campaign.sheer"
    assert main(["project", "new", "--out", str(project), "--look", "natural", "--resolution", "256"]) == 0
    text = write_spec().read_text()
    text = text.replace("[[looks]]", "[[heads]]\nname = \"sample\"\n[[heads]]\nname = \"captured\"\nface = \"face\"\n"
                                     "[[looks]]\nproject = \"campaign.sheer\"\n[[looks]]", 1)
    text = text.replace("[[lights]]\nname = \"flat\"\npreset = \"flat\"\n", "")
    spec = load_spec(write_spec(text))
    jobs = expand(spec)
    # the project on its own head, red-lip on both heads; 2 lipsticks each
    assert sorted((j.head.name, j.look.name) for j in jobs) == sorted(
        [("campaign", "campaign")] * 2 + [("sample", "red-lip")] * 2 + [("captured", "red-lip")] * 2)
    result = run_catalogue(spec, tmp_path / "out", jobs=jobs, client=dask_client)
    assert (result.rendered, result.failed) == (6, [])
    img = {(j.head.name, j.look.name, j.product): np.asarray(Image.open(tmp_path / "out" / j.out), float) for j in jobs}
    assert np.abs(img["campaign", "campaign", "Lipstick Nude"] - img["campaign", "campaign", "Lipstick Pink"]).max() > 10
    assert np.abs(img["sample", "red-lip", "Lipstick Nude"] - img["captured", "red-lip", "Lipstick Nude"]).mean() > 2

    light = write_spec(text.replace("size = [48, 48]", "size = [48, 48]\nmode = \"lightweight\"")
                       .replace("[[heads]]\nname = \"sample\"\n", "").replace("[[looks]]\nproject = \"campaign.sheer\"\n", ""),
                       name="light.toml")
    lw = run_catalogue(load_spec(light), tmp_path / "lw", client=dask_client)
    assert (lw.rendered, lw.failed) == (2, [])
    with pytest.raises(Exception, match=r"looks\[0\]\.project: mode 'lightweight'"):
        load_spec(write_spec(text.replace("size = [48, 48]", "size = [48, 48]\nmode = \"lightweight\"")
                             .replace("[[heads]]\nname = \"sample\"\n", ""), name="bad.toml"))
