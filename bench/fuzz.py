"""Fuzzing and crash-during-save harness for projects and material libraries (``sheer bench fuzz``).

- :func:`mutate` damages a valid file the ways files get damaged or forged: bit flips, truncation,
  byte runs overwritten/inserted/deleted, zip entries swapped, dropped, duplicated or added, and
  ``project.json`` values replaced (the zip rebuilt with correct CRCs, so the damage reaches the
  validators). It takes a ``random.Random``: hypothesis drives it in the test suite
  (``st.randoms()``), a seeded ``Random`` in the benchmark, so both run the same mutations.
- :func:`classify` opens the result: ``"ok"``, ``"ProjectError"`` (or ``"SheerError"`` for
  libraries) or ``"other: <type>: <message>"`` — the last must never happen.
- :func:`crash_runs` saves projects in a child process over and over, kills it (SIGKILL) at a random
  moment, and opens the file and its ``.bak`` each time: the file must always be the old or the new
  project, and the ``.bak`` (there from the start) must never go missing. A killed process leaves the
  kernel's page cache intact: power cuts are modelled in ``tests/project/test_power_cut.py``.

``sheer bench fuzz --importers N`` fuzzes the importers instead (meshes, photographs, EXR files, projects
with an embedded head): :mod:`bench.fuzz_importers`, which the command runs first.

``sheer bench fuzz [--cases N] [--crash-runs N] [--seed S] --json`` prints cases run, outcomes by kind
and by mutation, the time to open one damaged file (``case_ms``: median, ``case_ms_p90``,
``case_ms_max``), the crash-kill results and timings. It exits 1 unless no case raised anything but a
``ProjectError``/``SheerError``, no crash lost the file or its ``.bak`` (``file_absent`` and
``bak_absent`` 0) and every file opened as a version that was saved.
"""

from __future__ import annotations

import argparse
import copy
import io
import json
import multiprocessing
import os
import random
import sys
import tempfile
import time
import warnings
import zipfile
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from bench.stats import spread
from core.errors import SheerError
from project.errors import ProjectError
from project.io import open_project, project_bytes, read_project
from project.model import HeadRef, Project, ProjectLayer

#: wavelengths (nm) of the fuzzing material: a coarse grid keeps the cases small
_WL = [400.0, 500.0, 600.0, 700.0]


def tiny_material(name: str = "Foundation F", s: float = 8.0) -> dict[str, Any]:
    """A small valid material JSON (``km.Material.to_json`` format)."""
    return {"name": name, "category": "foundation", "source": "modelled", "provenance": "fuzzing sample",
            "wavelengths": list(_WL), "S": [s, s, s, s], "K": [0.5, 0.8, 1.0, 1.2], "thickness_um": 20.0,
            "max_thickness_um": 100.0, "roughness": 0.3, "ior": 1.45, "measurement": None,
            "coverage": None}


def tiny_head(embedded: bool = True) -> HeadRef:
    """A head reference whose files are a few bytes (checksums only: the fuzzer never loads the mesh)."""
    import hashlib

    data = {"head.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n",
            "head.obj.sheer-head.json": b'{"schema_version": 1, "name": "tiny", "mm_per_unit": 100.0}'}
    files = {k: hashlib.sha256(v).hexdigest() for k, v in data.items()}
    return HeadRef(name="tiny", mesh_path=None if embedded else Path("/nonexistent/head.obj"), asset=None,
                   mesh="head.obj", files=files, data=data if embedded else None)


def write_tiny_head(folder: str | Path, name: str = "head.obj") -> Path:
    """Write :func:`tiny_head`'s files into ``folder``; returns the mesh path.

    The files are a one-triangle OBJ with UVs (named ``name``) and its metadata sidecar.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    data = tiny_head(True).data
    assert data is not None
    (folder / name).write_bytes(data["head.obj"])
    (folder / (name + ".sheer-head.json")).write_bytes(data["head.obj.sheer-head.json"])
    return folder / name


def sample_project(side: int = 64, layers: int = 2, seed: int = 0, embedded: bool = True,
                   name: str = "fuzz sample") -> Project:
    """A small valid project: ``layers`` layers of ``side``² texels of random thickness (0-30 µm).

    The layers alternate EXR and PNG maps and two materials; a light, a camera and a look come with
    them; ``seed`` seeds the maps.
    """
    rng = np.random.default_rng(seed)
    out = []
    for i in range(layers):
        thickness = (rng.random((side, side)) * 30).astype(np.float32)
        thickness[: side // 4] = 0.0
        out.append(ProjectLayer(name=f"Layer {i}", material="Foundation F" if i % 2 == 0 else "Blush B",
                                thickness=thickness, opacity=0.8, max_thickness_um=60.0,
                                encoding="exr-float32" if i % 2 == 0 else "png16"))
    blush = tiny_material("Blush B", 2.0)
    blush["category"] = "blush"
    return Project(
        name=name, head=tiny_head(embedded), resolution=side, layers=out,
        materials={"Foundation F": tiny_material(), "Blush B": blush},
        lights=[{"type": "directional", "color": [1.0, 0.95, 0.9], "intensity": 3.0, "direction": [0.0, -0.5, -1.0]}],
        camera={"position": [0.0, 0.0, 5.0], "target": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0],
                "fov_deg": 30.0, "near": 0.1, "far": 100.0},
        look={"name": "Day", "description": "fuzz", "tags": ["test"]},
    )


# ------------------------------------------------------------------------------------------- mutations


def _entries(blob: bytes) -> list[tuple[str, bytes]]:
    with zipfile.ZipFile(io.BytesIO(blob)) as zf:
        return [(i.filename, zf.read(i)) for i in zf.infolist()]


def _rezip(entries: list[tuple[str, bytes]]) -> bytes:
    buf = io.BytesIO()
    with warnings.catch_warnings(), zipfile.ZipFile(buf, "w") as zf:
        warnings.simplefilter("ignore")  # duplicate names are what some mutations want
        for name, data in entries:
            zf.writestr(zipfile.ZipInfo(name, date_time=(2020, 1, 1, 0, 0, 0)), data)
    return buf.getvalue()


def _json_paths(value: Any, prefix: tuple = ()) -> list[tuple]:
    paths = [prefix]
    if isinstance(value, dict):
        for k, v in value.items():
            paths += _json_paths(v, (*prefix, k))
    elif isinstance(value, list):
        for i, v in enumerate(value[:8]):
            paths += _json_paths(v, (*prefix, i))
    return paths


_ODD_VALUES: list[Any] = [None, True, False, 0, -1, 1, 2, 3, 1.5, -0.0, 1e308, -1e308, 2**70, "", "x",
                          "../../etc/passwd", "/abs/path", "layers/000.exr", "C:\\x", "\u0000", [], [1, 2, 3],
                          [0, 0, 0], {}, {"a": 1}, "exr-float32", "png16", 8192, 8193, 65536, 100000.0]


def _random_value(rng: random.Random, old: Any) -> Any:
    r = rng.random()
    if r < 0.45:
        return rng.choice(_ODD_VALUES)
    if isinstance(old, bool):
        return not old
    if isinstance(old, (int, float)):
        return rng.choice([old * -1, old + 1, old * 1000, old / 3, int(old) if isinstance(old, float) else float(old)])
    if isinstance(old, str):
        return old[: rng.randrange(len(old) + 1)] + rng.choice(["", "/..", "é", "\\", " "])
    if isinstance(old, list) and old:
        return old[:-1] if rng.random() < 0.5 else [*old, old[-1]]
    return rng.choice(_ODD_VALUES)


def _mutate_json(doc: Any, rng: random.Random) -> Any:
    doc = copy.deepcopy(doc)
    paths = [p for p in _json_paths(doc) if p]
    if not paths:
        return rng.choice(_ODD_VALUES)
    path = rng.choice(paths)
    parent = doc
    for key in path[:-1]:
        parent = parent[key]
    key = path[-1]
    action = rng.random()
    if action < 0.15 and isinstance(parent, dict):
        del parent[key]  # a missing key
    elif action < 0.25 and isinstance(parent, dict):
        parent[f"extra_{rng.randrange(100)}"] = rng.choice(_ODD_VALUES)  # an unknown key
    else:
        parent[key] = _random_value(rng, parent[key])
    return doc


MUTATIONS = ("bitflip", "truncate", "overwrite", "insert", "delete", "swap_entries", "drop_entry",
             "duplicate_entry", "extra_entry", "json_value", "json_text", "entry_bitflip", "map_swap_names")


def mutate(blob: bytes, rng: random.Random, kind: str | None = None) -> tuple[str, bytes]:
    """One damaged variant of the project (or any zip) ``blob``; returns (mutation, bytes)."""
    kind = kind or rng.choice(MUTATIONS)
    data = bytearray(blob)
    n = len(data)
    if kind == "bitflip":
        for _ in range(rng.choice([1, 1, 2, 8])):
            pos = rng.randrange(n)
            data[pos] ^= 1 << rng.randrange(8)
        return kind, bytes(data)
    if kind == "truncate":
        return kind, bytes(data[: rng.randrange(n)])
    if kind == "overwrite":
        pos = rng.randrange(n)
        run = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 32)))
        return kind, bytes(data[:pos] + run + data[pos + len(run):])[:n]
    if kind == "insert":
        pos = rng.randrange(n)
        return kind, bytes(data[:pos] + bytes(rng.randrange(256) for _ in range(rng.randrange(1, 16))) + data[pos:])
    if kind == "delete":
        pos = rng.randrange(n)
        return kind, bytes(data[:pos] + data[pos + rng.randrange(1, 64):])
    entries = _entries(blob)
    names = [e[0] for e in entries]
    if kind == "swap_entries" and len(entries) >= 2:
        i, j = rng.sample(range(len(entries)), 2)
        entries[i], entries[j] = (entries[i][0], entries[j][1]), (entries[j][0], entries[i][1])
    elif kind == "map_swap_names" and len(entries) >= 2:
        i, j = rng.sample(range(len(entries)), 2)
        entries[i], entries[j] = entries[j], entries[i]
    elif kind == "drop_entry":
        entries.pop(rng.randrange(len(entries)))
    elif kind == "duplicate_entry":
        entries.append(entries[rng.randrange(len(entries))])
    elif kind == "extra_entry":
        name = rng.choice(["extra.txt", "../evil.txt", "/abs.txt", "layers/999.exr", "head/x", "a//b",
                           "PROJECT.JSON", "dir/", "C:/x", "a\\b"])
        entries.append((name, b"surprise"))
    elif kind in ("json_value", "json_text") and "project.json" in names:
        i = names.index("project.json")
        text = entries[i][1]
        if kind == "json_value":
            try:
                doc = json.loads(text)
                new = json.dumps(_mutate_json(doc, rng)).encode()
            except ValueError:
                new = text
        else:
            pos = rng.randrange(len(text))
            new = text[:pos] + rng.choice([b"NaN", b"Infinity", b"1e999", b'"', b"}", b"[", b"\xff", b"-"]) + \
                text[pos + rng.randrange(3):]
        entries[i] = ("project.json", new)
    elif kind == "entry_bitflip":
        i = rng.randrange(len(entries))
        body = bytearray(entries[i][1])
        if body:
            for _ in range(rng.choice([1, 4, 16])):
                pos = rng.randrange(len(body))
                body[pos] ^= 1 << rng.randrange(8)
        entries[i] = (entries[i][0], bytes(body))
    else:
        return "bitflip", mutate(blob, rng, "bitflip")[1]
    try:
        return kind, _rezip(entries)
    except ValueError:  # zipfile refuses some names itself
        return kind, blob


def classify(blob: bytes) -> str:
    """Open ``blob`` as a project: "ok", "ProjectError" or "other: …" (a bug)."""
    try:
        read_project(io.BytesIO(blob), name="fuzzed.sheer", project_dir=None, verify_head=False)
    except ProjectError:
        return "ProjectError"
    except Exception as exc:  # anything else is a bug in the loader
        return f"other: {type(exc).__name__}: {exc}"
    return "ok"


def sample_library_text() -> bytes:
    """A small valid material library (``km.Library`` JSON)."""
    blush = tiny_material("Blush B", 2.0)
    blush["category"] = "blush"
    return json.dumps({"format": "sheer.materials", "schema_version": 1, "name": "fuzz",
                       "materials": [tiny_material(), blush]}).encode()


def mutate_library(text: bytes, rng: random.Random) -> tuple[str, bytes]:
    """A damaged variant of a library file: byte damage or a JSON value change."""
    kind = rng.choice(["bitflip", "truncate", "overwrite", "json_value", "json_value", "json_text"])
    if kind == "json_value":
        return kind, json.dumps(_mutate_json(json.loads(text), rng)).encode()
    if kind == "json_text":
        pos = rng.randrange(len(text))
        return kind, text[:pos] + rng.choice([b"NaN", b"Infinity", b"1e999", b'"', b"}", b"\xff"]) + text[pos + 1:]
    return mutate(text, rng, kind)


def classify_library(text: bytes) -> str:
    """Load ``text`` as a material library: "ok", "SheerError" or "other: …" (a bug)."""
    import km

    try:
        km.Library.loads(text, source="fuzzed.json")
    except SheerError:
        return "SheerError"
    except Exception as exc:
        return f"other: {type(exc).__name__}: {exc}"
    return "ok"


def run_fuzz(cases: int, seed: int = 0, library_share: float = 0.2) -> dict[str, Any]:
    """Run ``cases`` mutated projects and libraries; counts by outcome and mutation.

    Also the time to open one mutated file (``case_ms``: median, ``case_ms_p90``, ``case_ms_max``, ms).
    """
    rng = random.Random(seed)
    bases = [project_bytes(sample_project(64, 2, seed=0, embedded=True), self_contained=True),
             project_bytes(sample_project(64, 3, seed=1, embedded=False), self_contained=False)]
    library = sample_library_text()
    outcomes: Counter[str] = Counter()
    by_kind: Counter[str] = Counter()
    others: list[str] = []
    case_ms: list[float] = []
    t0 = time.perf_counter()
    for _ in range(cases):
        if rng.random() < library_share:
            kind, blob = mutate_library(library, rng)
            start = time.perf_counter()
            result = classify_library(blob)
            kind = "library:" + kind
        else:
            kind, blob = mutate(rng.choice(bases), rng)
            start = time.perf_counter()
            result = classify(blob)
        case_ms.append((time.perf_counter() - start) * 1000.0)
        key = result if not result.startswith("other") else "other"
        outcomes[key] += 1
        by_kind[f"{kind}:{key}"] += 1
        if key == "other" and len(others) < 20:
            others.append(f"{kind}: {result}")
    return {"cases": cases, "outcomes": dict(outcomes), "by_mutation": dict(sorted(by_kind.items())),
            "other_examples": others, "seconds": round(time.perf_counter() - t0, 2),
            **(spread("case_ms", case_ms, 3) if case_ms else {})}


# ------------------------------------------------------------------------------------- crash during save


def _crash_child(path: str, seed: int, ready: Any) -> None:
    """Save two alternating projects to ``path`` forever (until killed)."""
    from project.io import save_project

    versions = [sample_project(64, 2, seed=seed, embedded=True, name=f"generation {g}") for g in range(2)]
    project_bytes(versions[0], self_contained=True)  # warm up (lazy imports, schema) before the clock starts
    ready.set()
    g = 0
    while True:
        save_project(versions[g % 2], path, self_contained=True, clear_recovery=False)
        g += 1


def crash_runs(runs: int, seed: int = 0, folder: str | Path | None = None,
               max_delay_s: float = 0.1) -> dict[str, Any]:
    """Kill a saving process ``runs`` times at random moments; open the file (and its .bak) each time.

    Before the first run on a file an initial version is saved twice, so there is always an old
    project to lose and a ``.bak`` that must survive. Returns counts: runs, file_loaded (the file
    opened and was the old or a new version) / file_absent, bak_loaded / bak_absent, temporary files
    left behind by the kills, failures (with messages).
    """
    rng = random.Random(seed)
    methods = multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
    if hasattr(ctx, "set_forkserver_preload"):
        ctx.set_forkserver_preload(["project.io", "bench.fuzz", "km.material", "jsonschema",
                                    "OpenEXR", "PIL.PngImagePlugin"])
    from project.io import save_project

    expected = {f"generation {g}" for g in range(2)} | {"initial"}
    initial = sample_project(64, 2, seed=seed, embedded=True, name="initial")
    stats: Counter[str] = Counter(dict.fromkeys(
        ("runs", "file_loaded", "file_absent", "bak_loaded", "bak_absent", "temp_files_left"), 0))
    failures: list[str] = []
    with tempfile.TemporaryDirectory(dir=folder) as tmp:
        for run in range(runs):
            path = Path(tmp) / f"run{run % 4}.sheer"  # reuse a few files: later runs replace existing ones
            if not path.exists():  # there is always an old version to lose, and a .bak
                save_project(initial, path, self_contained=True, clear_recovery=False)
                save_project(initial, path, self_contained=True, clear_recovery=False)
            ready = ctx.Event()
            proc = ctx.Process(target=_crash_child, args=(str(path), seed + run, ready), daemon=True)
            proc.start()
            ready.wait(30)
            time.sleep(rng.uniform(0.0, max_delay_s))
            proc.kill()
            proc.join(10)
            stats["runs"] += 1
            for candidate, label in ((path, "file"), (path.with_name(path.name + ".bak"), "bak")):
                if not candidate.exists():
                    stats[f"{label}_absent"] += 1
                    continue
                try:
                    project = open_project(candidate)
                except ProjectError as exc:
                    failures.append(f"run {run}: {label}: {exc}")
                    continue
                if project.name not in expected:
                    failures.append(f"run {run}: {label}: unexpected content {project.name!r}")
                    continue
                stats[f"{label}_loaded"] += 1
            stats["temp_files_left"] += len([p for p in Path(tmp).iterdir() if p.name.endswith(".tmp")])
            for p in Path(tmp).iterdir():  # as the studio's recovery does: remove stale temporaries
                if p.name.endswith(".tmp"):
                    p.unlink()
    return {**dict(stats), "failures": len(failures), "failure_examples": failures[:10]}


_STEP_CALLS = (("os", "fsync"), ("os", "replace"), ("os", "chmod"), ("os", "unlink"), ("os", "link"),
               ("shutil", "copy2"))


def _step_crash_child(path: str, step: int) -> None:
    """Save once, exiting abruptly just before or just after the ``step``-th file-system call."""
    import shutil

    from project.io import save_project

    modules = {"os": os, "shutil": shutil}
    counter = [0]

    def tick() -> None:
        counter[0] += 1
        if counter[0] == step:
            os._exit(3)  # no clean-up, no flush: the process dies here (its page cache survives)

    for module_name, name in _STEP_CALLS:
        real = getattr(modules[module_name], name)

        def wrapped(*args: Any, _real: Any = real, **kwargs: Any) -> Any:
            tick()
            result = _real(*args, **kwargs)
            tick()
            return result

        setattr(modules[module_name], name, wrapped)
    save_project(sample_project(64, 2, seed=1, embedded=True, name="generation 1"), path,
                 self_contained=True, clear_recovery=False)
    os._exit(0)


def crash_at_every_step(folder: str | Path | None = None, max_steps: int = 200) -> dict[str, Any]:
    """Crash a save just before and just after each of its file-system calls, one run per point.

    The calls are fsync, replace, chmod, unlink, link and copy2; the save is over an existing project
    with a ``.bak``; the file and its ``.bak`` are opened after each crash.

    Returns steps (crash points covered), failures (with messages).
    """
    from project.io import save_project

    ctx = multiprocessing.get_context("forkserver" if "forkserver" in multiprocessing.get_all_start_methods()
                                      else "spawn")
    initial = sample_project(64, 2, seed=0, embedded=True, name="initial")
    failures: list[str] = []
    steps = 0
    with tempfile.TemporaryDirectory(dir=folder) as tmp:
        path = Path(tmp) / "p.sheer"
        for step in range(1, max_steps + 1):
            for p in Path(tmp).iterdir():
                p.unlink()
            save_project(initial, path, self_contained=True, clear_recovery=False)
            save_project(initial, path, self_contained=True, clear_recovery=False)  # so a .bak exists too
            proc = ctx.Process(target=_step_crash_child, args=(str(path), step))
            proc.start()
            proc.join(60)
            for candidate in (path, path.with_name(path.name + ".bak")):
                try:
                    name = open_project(candidate).name
                    if name not in ("initial", "generation 1"):
                        failures.append(f"step {step}: {candidate.name}: unexpected {name!r}")
                except (ProjectError, OSError) as exc:
                    failures.append(f"step {step}: {candidate.name}: {exc}")
            if proc.exitcode == 0:  # the save completed: every point before it has been covered
                if open_project(path).name != "generation 1":
                    failures.append("a completed save did not leave the new version")
                break
            steps += 1
    return {"steps": steps, "failures": len(failures), "failure_examples": failures[:10]}


def bench_main(argv: list[str]) -> int:
    """``sheer bench fuzz``: ≥ 10,000 fuzz cases and ≥ 200 crash-kill runs by default; prints JSON."""
    parser = argparse.ArgumentParser(prog="sheer bench fuzz", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int, default=10_000)
    parser.add_argument("--crash-runs", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", action="store_true", help="print JSON (the only format)")
    args = parser.parse_args(argv)
    fuzz = run_fuzz(args.cases, args.seed)
    t0 = time.perf_counter()
    crash = crash_runs(args.crash_runs, args.seed) if args.crash_runs > 0 else {}
    crash["seconds"] = round(time.perf_counter() - t0, 2)
    steps = crash_at_every_step() if args.crash_runs > 0 else {"steps": 0, "failures": 0}
    result = {
        "cases_run": fuzz["cases"],
        "project_errors": fuzz["outcomes"].get("ProjectError", 0),
        "library_errors": fuzz["outcomes"].get("SheerError", 0),
        "accepted": fuzz["outcomes"].get("ok", 0),
        "other_exceptions": fuzz["outcomes"].get("other", 0),
        **{key: fuzz[key] for key in ("case_ms", "case_ms_p90", "case_ms_max") if key in fuzz},
        "fuzz": fuzz,
        "crash_kill": crash,
        "crash_at_every_step": steps,
        "pid": os.getpid(),
    }
    json.dump(result, sys.stdout, indent=2)
    print()
    ok = (result["other_exceptions"] == 0 and crash.get("failures", 0) == 0 and steps["failures"] == 0
          and crash.get("file_absent", 0) == 0 and crash.get("bak_absent", 0) == 0)
    return 0 if ok else 1
