"""km.Library: load/save, validation of every kind of malformed file, atomic save, migrations, editing,
and the default library (counts, provenance, consistency of S and K with the synthetic measurement, and
that ``scripts/build_default_library.py --check`` reproduces the file byte for byte)."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

import core.atomicio
import km
import km.library as library_mod
from core.assets import resource_path
from core.errors import SheerError
from core.migrations import Migrations
from km.library import Library, LibraryError
from km.material import Material, Measurement

if TYPE_CHECKING:
    from collections.abc import Callable
    from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]
WL = np.arange(380.0, 781.0, 5.0)


def make_material(name: str, category: str = "lipstick", seed: int = 0) -> Material:
    rng = np.random.default_rng(seed)
    s = rng.uniform(0.5, 60.0, WL.size)  # full-precision random doubles: a real test of bit identity
    k = rng.uniform(0.0, 30.0, WL.size)
    r0, t = km.layer_rt(s, k, 0.15)
    rg = np.full(WL.size, 0.045)
    meas = Measurement(WL, km.r_inf_from_ks(k / s), km.over(r0, t, rg), rg, 0.15, "test rig", "D55")
    return Material(name=name, category=category, wavelengths=WL, S=s, K=k, thickness_um=15.0,
                    max_thickness_um=60.0, roughness=0.2, ior=1.5, source="measured",
                    provenance=f"synthetic test material {seed}", measurement=meas)


@pytest.fixture
def lib() -> Library:
    return Library([make_material("Red", seed=1), make_material("Nude", seed=2),
                    make_material("Rose", "blush", seed=3), make_material("Berry", seed=4)], name="test")


def test_round_trip_is_bit_identical(lib: Library, tmp_path: Path) -> None:
    path = tmp_path / "lib.json"
    lib.save(path)
    back = Library.load(path)
    assert back.names() == lib.names() and back.name == "test" and back.path == path
    for a, b in zip(lib, back, strict=True):
        assert a == b
        for arr in ("wavelengths", "S", "K"):
            assert getattr(a, arr).tobytes() == getattr(b, arr).tobytes()
        assert a.measurement.R.tobytes() == b.measurement.R.tobytes()
    # saving what was loaded writes the same bytes
    path2 = tmp_path / "again.json"
    back.save(path2)
    assert path2.read_bytes() == path.read_bytes()
    data = json.loads(path.read_text())
    assert data["format"] == "sheer.materials" and data["schema_version"] == library_mod.SCHEMA_VERSION


def _good(lib: Library) -> dict:
    return json.loads(lib.dumps())


def _mutations() -> list[tuple[str, Callable[[dict], object] | None, str]]:
    def set_(path: list, value: object) -> Callable[[dict], None]:
        def f(d: dict) -> None:
            target = d
            for key in path[:-1]:
                target = target[key]
            target[path[-1]] = value
        return f

    return [
        ("truncated", None, "not valid JSON"),
        ("empty", None, "not valid JSON"),
        ("nan literal", None, "NaN is not valid JSON"),
        ("not utf-8", None, "not UTF-8"),
        ("top-level list", lambda d: [d], "top level must be a JSON object"),
        ("no schema", lambda d: d.pop("schema_version"), "schema_version: missing"),
        ("schema string", set_(["schema_version"], "1"), "schema_version: must be an integer"),
        ("schema zero", set_(["schema_version"], 0), "schema_version: unknown version 0"),
        ("schema newer", set_(["schema_version"], 99), "schema_version: 99 is newer"),
        ("wrong format", set_(["format"], "sheer.project"), "format: expected"),
        ("unknown top field", set_(["extra"], 1), "unknown field extra"),
        ("materials not list", set_(["materials"], {}), "materials: must be a list"),
        ("negative S", set_(["materials", 2, "S", 12], -0.25), "materials[2].S[12]: negative"),
        ("overflowing K", None, "materials[1].K[0]: must be finite"),
        ("overflowing integer", None, "materials[1].K[0]: must be finite"),
        ("infinity literal", set_(["materials", 1, "K", 0], float("inf")), "Infinity is not valid JSON"),
        ("length mismatch", lambda d: d["materials"][3]["K"].pop(), "materials[3].K: has 80 values"),
        ("wrong type", set_(["materials", 0, "roughness"], "rough"), "materials[0].roughness: must be a number"),
        ("string in array", set_(["materials", 0, "S", 5], "1.0"), "materials[0].S[5]: must be a number"),
        ("missing field", lambda d: d["materials"][1].pop("category"), "materials[1]: missing field category"),
        ("bad measurement", set_(["materials", 2, "measurement", "R_inf", 7], 1.2),
         "materials[2].measurement.R_inf[7]: above 1"),
        ("duplicate names", set_(["materials", 3, "name"], "RED"), "materials[3].name: 'RED' duplicates"),
    ]


@pytest.mark.parametrize(("case", "mutate", "words"), _mutations(), ids=[m[0] for m in _mutations()])
def test_malformed_files_are_refused_naming_file_and_field(lib: Library, tmp_path: Path, case: str,
                                                          mutate: Callable[[dict], object] | None,
                                                          words: str) -> None:
    path = tmp_path / "bad.json"
    text = lib.dumps()
    if case == "truncated":
        raw = text[: len(text) // 2].encode()
    elif case == "empty":
        raw = b""
    elif case == "nan literal":
        raw = text.replace(json.dumps(_good(lib)["materials"][0]["S"][3]), "NaN", 1).encode()
    elif case == "overflowing K":  # 1e400 parses as inf
        raw = text.replace(json.dumps(_good(lib)["materials"][1]["K"][0]), "1e400", 1).encode()
    elif case == "overflowing integer":  # a JSON integer no float can hold
        raw = text.replace(json.dumps(_good(lib)["materials"][1]["K"][0]), "1" + "0" * 400, 1).encode()
    elif case == "not utf-8":
        raw = text.encode()[:100] + b"\xff\xfe" + text.encode()[100:]
    else:
        data = _good(lib)
        out = mutate(data)
        raw = json.dumps(out if out is not None and case == "top-level list" else data).encode()
    path.write_bytes(raw)
    with pytest.raises(LibraryError) as info:
        Library.load(path)
    message = str(info.value)
    assert str(path) in message and words in message, message
    assert "\n" not in message
    assert isinstance(info.value, ValueError) and isinstance(info.value, SheerError)


def test_missing_file_folder_and_size_cap(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, lib: Library) -> None:
    with pytest.raises(LibraryError, match="no such library file"):
        Library.load(tmp_path / "nope.json")
    with pytest.raises(LibraryError, match="is a folder"):
        Library.load(tmp_path)
    path = lib.save(tmp_path / "big.json")
    monkeypatch.setattr(library_mod, "MAX_FILE_BYTES", 1000)
    with pytest.raises(LibraryError, match="too large"):
        Library.load(path)


def test_failed_save_leaves_the_old_file_intact(lib: Library, tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "lib.json"
    lib.save(path)
    before = path.read_bytes()
    lib.remove("Red")
    real_fsync = os.fsync

    def failing_fsync(fd: int) -> None:  # the data has been written to the temporary file: fail mid-way
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(core.atomicio.os, "fsync", failing_fsync)
    with pytest.raises(LibraryError, match="No space left"):
        lib.save(path)
    monkeypatch.setattr(core.atomicio.os, "fsync", real_fsync)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lib.json"]  # no temporary file left behind
    assert Library.load(path).names() == ["Red", "Nude", "Rose", "Berry"]


def test_failed_rename_leaves_the_old_file_intact(lib: Library, tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "lib.json"
    lib.save(path)
    before = path.read_bytes()

    def failing_replace(src: object, dst: object) -> None:
        raise OSError(5, "Input/output error")

    lib.remove("Nude")
    monkeypatch.setattr(core.atomicio.os, "replace", failing_replace)
    with pytest.raises(LibraryError, match="Input/output error"):
        lib.save(path)
    monkeypatch.undo()
    assert path.read_bytes() == before


def test_save_keeps_a_backup(lib: Library, tmp_path: Path) -> None:
    path = tmp_path / "lib.json"
    lib.save(path)
    first = path.read_bytes()
    lib.rename("Red", "Crimson")
    lib.save()  # to where it was saved before
    assert (tmp_path / "lib.json.bak").read_bytes() == first
    assert Library.load(path).names()[0] == "Crimson"
    with pytest.raises(LibraryError, match="give a path"):
        Library([make_material("X")]).save()


def test_migrations_run_step_by_step(lib: Library, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # pretend this Sheer writes version 3 and files of version 1 named the library "title"
    monkeypatch.setattr(library_mod, "SCHEMA_VERSION", 3)
    monkeypatch.setattr(library_mod, "MIGRATIONS", Migrations(LibraryError))
    calls: list[int] = []

    @library_mod.MIGRATIONS.register(1)
    def v1_to_v2(data: dict) -> dict:
        calls.append(1)
        data["name"] = data.pop("title")
        data["schema_version"] = 2
        return data

    @library_mod.MIGRATIONS.register(2)
    def v2_to_v3(data: dict) -> dict:
        calls.append(2)
        data["name"] = data["name"].upper()
        data["schema_version"] = 3
        return data

    with pytest.raises(ValueError, match="already registered"):
        library_mod.MIGRATIONS.register(1)(v1_to_v2)
    old = _good(lib)
    old["schema_version"] = 1
    old["title"] = old.pop("name")
    path = tmp_path / "old.json"
    path.write_text(json.dumps(old))
    loaded = Library.load(path)
    assert calls == [1, 2] and loaded.name == "TEST" and loaded.names() == lib.names()
    assert json.loads(path.read_text()) == old  # loading never rewrites the file
    assert json.loads(loaded.dumps())["schema_version"] == 3

    # a migration that fails names the step; a missing step is refused
    old["title"] = 5
    path.write_text(json.dumps({k: v for k, v in old.items() if k != "title"}))
    with pytest.raises(LibraryError, match=r"old.json: migration from schema_version 1 to 2 failed \(KeyError: 'title'\)"):
        Library.load(path)
    monkeypatch.setattr(library_mod, "MIGRATIONS", Migrations(LibraryError, {1: v1_to_v2}))
    old["title"] = "t"
    path.write_text(json.dumps(old))
    with pytest.raises(LibraryError, match="old.json: no migration from schema_version 2 to 3"):
        Library.load(path)


def test_lookup_is_case_insensitive_with_suggestions(lib: Library) -> None:
    assert lib.get("red").name == "Red" and lib["  NUDE "].name == "Nude"
    assert "rose" in lib and "violet" not in lib
    with pytest.raises(LibraryError) as info:
        lib.get("Rosy")
    assert "'Rose'" in str(info.value) and "did you mean" in str(info.value)
    assert [m.name for m in lib.by_category("Lipstick")] == ["Red", "Nude", "Berry"]
    assert lib.by_category("eyeliner") == []
    assert lib.categories() == ["lipstick", "blush"]


def test_editing_keeps_names_unique(lib: Library) -> None:
    with pytest.raises(LibraryError, match="already exists"):
        lib.add(make_material("RED"))
    lib.add(make_material("red", seed=9), replace=True)
    assert lib.names() == ["red", "Nude", "Rose", "Berry"]
    dup = lib.duplicate("nude")
    assert dup.name == "Nude copy" and lib.names()[2] == "Nude copy"
    assert lib.duplicate("Nude").name == "Nude copy 2"
    assert lib.duplicate("Nude", "Beige").name == "Beige"
    with pytest.raises(LibraryError, match="already exists"):
        lib.duplicate("Nude", "berry")
    assert lib.get("Beige") == lib.get("Nude").replace(name="Beige")
    with pytest.raises(LibraryError, match="already exists"):
        lib.rename("Rose", "BERRY")
    lib.rename("berry", "BERRY")  # a change of case of the same name is fine
    assert "BERRY" in lib.names()
    with pytest.raises(LibraryError, match="cannot rename"):
        lib.rename("Rose", "")
    removed = lib.remove("ROSE")
    assert removed.name == "Rose" and "Rose" not in lib
    with pytest.raises(LibraryError, match="no material named"):
        lib.remove("Rose")
    copy = lib.copy()
    copy.remove("Beige")
    assert "Beige" in lib


# ---- the default library


def test_default_library_counts_and_provenance() -> None:
    lib = km.default_library()
    counts = {c: len(lib.by_category(c)) for c in lib.categories()}
    assert counts["foundation"] >= 5 and counts["blush"] >= 2 and counts["lipstick"] >= 7
    assert counts["eyeshadow"] >= 3 and counts["eyeliner"] >= 1
    for m in lib:
        assert m.source == "modelled"
        assert m.provenance.startswith("Modelled, not measured") and "hides" in m.provenance
        assert m.measurement is not None and m.measurement.Rg.max() < 0.05  # over a black card
        assert m.thickness_um <= m.max_thickness_um
    # the foundations span light to deep (CIE L* of the opaque colour)
    lightness = [float(km.linear_rgb_to_lab(m.swatch_rgb("opaque", encoded=False))[0])
                 for m in lib.by_category("foundation")]
    assert max(lightness) > 85 and min(lightness) < 35


def test_default_library_s_and_k_reproduce_the_measurement() -> None:
    for m in km.default_library():
        meas = m.measurement
        assert meas is not None and np.array_equal(meas.wavelengths, m.wavelengths)
        r0, t = km.layer_rt(m.S, m.K, meas.D_mm)
        np.testing.assert_allclose(m.r_inf(), meas.R_inf, atol=1e-6, rtol=0, err_msg=m.name)
        np.testing.assert_allclose(km.over(r0, t, meas.Rg), meas.R, atol=1e-6, rtol=0, err_msg=m.name)
        # and they are what the inversion of the stored triplet gives
        s, k = meas.invert()
        np.testing.assert_allclose(m.S, s, rtol=1e-8, err_msg=m.name)
        np.testing.assert_allclose(m.K, k, rtol=1e-8, atol=1e-12, err_msg=m.name)


def test_default_library_returns_independent_copies() -> None:
    a = km.default_library()
    n = len(a)
    a.remove(a.names()[0])
    a.rename(a.names()[0], "Mine")
    b = km.default_library()
    assert len(b) == n and "Mine" not in b and b.path is None


def _load_builder(monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    spec = importlib.util.spec_from_file_location("build_default_library",
                                                  ROOT / "scripts" / "build_default_library.py")
    assert spec is not None and spec.loader is not None
    builder = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, builder)
    spec.loader.exec_module(builder)
    return builder


def test_build_script_reproduces_the_file(monkeypatch: pytest.MonkeyPatch) -> None:
    """The file is a fixed point of load/dumps (fixed float formatting) and lists the builder's shades;
    the builder reproduces every shade byte for byte (run as ``--check``: see the next test)."""
    path = resource_path("materials", "default.json")
    text = path.read_text(encoding="utf-8")
    assert Library.load(path).dumps() == text
    builder = _load_builder(monkeypatch)
    assert [m[0] for m in builder.SHADES] == km.default_library().names()
    assert len(builder.SHADES) == 30


@pytest.mark.slow
def test_build_script_check_rebuilds_every_shade_byte_for_byte(tmp_path: Path) -> None:
    """The README's claim: ``scripts/build_default_library.py --check`` rebuilds the default library byte
    for byte (all 30 shades, ~4 s). It passes on the shipped file and fails on a copy where one number
    of one shade differs in its seventh digit (one build checked against both files: ``--out`` twice)."""
    shipped = resource_path("materials", "default.json")
    data = json.loads(shipped.read_text(encoding="utf-8"))
    data["materials"][-1]["K"][40] *= 1.000001
    changed = tmp_path / "default.json"
    changed.write_text(Library.from_json(data).dumps(), encoding="utf-8")
    assert changed.read_text(encoding="utf-8") != shipped.read_text(encoding="utf-8")
    run = subprocess.run([sys.executable, str(ROOT / "scripts" / "build_default_library.py"), "--check",
                          "--out", str(shipped), "--out", str(changed)], cwd=ROOT, capture_output=True, text=True,
                         timeout=600)
    assert run.returncode == 1, run.stdout + run.stderr  # one file out of date
    assert f"{shipped} is up to date" in run.stdout and f"{changed} is up to date" not in run.stdout, run.stdout
    assert f"{changed} is out of date" in run.stderr and f"{shipped} is out of date" not in run.stderr, run.stderr


def test_default_library_meets_its_hiding_criteria(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each material hides as its stated coverage says at its default thickness (a cream lipstick: full,
    contrast ratio 0.95 at 15 µm), using the S and K stored in the file; the file states the builder's
    coverage."""
    builder = _load_builder(monkeypatch)
    assert builder.COVERAGE["lipstick"].level == "full" and builder.COVERAGE["lipstick"].contrast_ratio == 0.95
    for m in km.default_library():
        stated = builder.coverage_for(m.name, m.category)
        assert (m.coverage.level, m.coverage.contrast_ratio) == (stated.level, stated.contrast_ratio), m.name
        assert m.contrast_ratio() == pytest.approx(stated.contrast_ratio, abs=1e-4), m.name


def test_special_files_are_refused(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    with pytest.raises(LibraryError, match="not a regular file"):
        Library.load(fifo)
    with pytest.raises(LibraryError, match="not a regular file"):
        Library.load("/dev/zero")


def test_every_material_states_its_finish(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each default material's provenance states its finish, the one its roughness reads as, with the
    roughness and IOR it is rendered with; the red lipstick comes in matte, satin and gloss, and the
    gloss is the smoothest (issue #16)."""
    builder = _load_builder(monkeypatch)
    lib = km.default_library()
    for m in lib:
        finish = builder.finish_of(m.roughness)
        assert f"Finish: {finish} (Beckmann roughness {m.roughness:g}, index of refraction {m.ior:g}" \
            in m.provenance, m.name
    reds = {f: lib.get(f"Lipstick Red {f.title()}") for f in ("matte", "satin", "gloss")}
    assert [builder.finish_of(m.roughness) for m in reds.values()] == ["matte", "satin", "gloss"]
    assert reds["gloss"].roughness < reds["satin"].roughness < reds["matte"].roughness
    assert builder.finish_of(0.4) == "matte" and builder.finish_of(0.119) == "gloss"
