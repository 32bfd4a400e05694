"""core.cache: one checked entry format, the size cap with LRU eviction, XDG_CACHE_HOME, damaged entries
deleted with one log line, private caches, and two real processes writing and baking at once."""

from __future__ import annotations

import logging
import os
import shutil
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from core import cache
from core.cache import (
    PrivateCache,
    cache_cap,
    cache_dir,
    cache_root,
    clear,
    entries,
    load_array,
    load_arrays,
    save_array,
    save_arrays,
)

MIB = 1024 * 1024
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _own_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A fresh cache folder, no cap from the environment or the settings."""
    root = tmp_path / "cache"
    monkeypatch.setenv("SHEER_CACHE_DIR", str(root))
    monkeypatch.delenv("SHEER_CACHE_MAX_MB", raising=False)
    cache.set_configured_max_mb(None)
    return root


def _arrays() -> dict[str, object]:
    rng = np.random.default_rng(7)
    return {"f32": rng.random((33, 17, 3), dtype=np.float32), "i64": np.arange(-5, 1000, dtype=np.int64),
            "mask": rng.random((64, 64)) > 0.5, "scalar": 2.5, "flag": True, "text": np.array("a reason"),
            "empty": np.zeros((0, 3)), "strided": np.arange(40.0).reshape(5, 8)[:, ::3]}


def _same(read: dict[str, np.ndarray], written: dict[str, object]) -> None:
    assert list(read) == list(written)
    for k, v in written.items():
        expected = np.asarray(v)
        assert read[k].dtype == expected.dtype and read[k].shape == expected.shape, k
        np.testing.assert_array_equal(read[k], expected)


@pytest.mark.parametrize("compress", [False, True])
def test_entries_round_trip_every_dtype_and_shape(compress: bool) -> None:
    path = cache_dir("layout") / "x.cache"
    data = _arrays()
    assert save_arrays(path, data, version=3, compress=compress)
    read = load_arrays(path, version=3)
    assert read is not None
    _same(read, data)
    assert read["f32"].flags.writeable  # the callers may use them as their own arrays
    assert [p.name for p in path.parent.iterdir()] == ["x.cache"]  # no temporary file left


def _damages(size: int) -> list[tuple[str, object]]:
    def cut(n: int) -> object:
        return lambda b: b[:n]

    def flip(i: int) -> object:
        return lambda b: b[:i] + bytes([b[i] ^ 0x10]) + b[i + 1:]

    return [("empty", cut(0)), ("in the magic", cut(5)), ("in the header", cut(40)), ("in the payload", cut(size - 7)),
            ("one byte short", cut(size - 1)), ("a flipped bit in the header", flip(30)),
            ("a flipped bit in the payload", flip(size // 2)), ("a flipped bit in the last byte", flip(size - 1)),
            ("one byte more", lambda b: b + b"\0"), ("not an entry", lambda b: b"\x93NUMPY" + b[6:])]


@pytest.mark.parametrize("compress", [False, True])
def test_a_damaged_entry_is_deleted_with_one_log_line_and_made_again(compress: bool,
                                                                     caplog: pytest.LogCaptureFixture) -> None:
    path = cache_dir("atlas") / "bake.cache"
    data = _arrays()
    save_arrays(path, data, 1, compress)
    good = path.read_bytes()
    for what, damage in _damages(len(good)):
        path.write_bytes(damage(good))  # type: ignore[operator]
        caplog.clear()
        with caplog.at_level(logging.DEBUG, logger="sheer.cache"):
            assert load_arrays(path, 1) is None, what
        lines = [r for r in caplog.records if r.levelno >= logging.WARNING]
        assert len(lines) == 1 and "damaged" in lines[0].getMessage() and str(path) in lines[0].getMessage(), what
        assert not path.exists(), what
        assert save_arrays(path, data, 1, compress)  # made again
        _same(load_arrays(path, 1), data)  # type: ignore[arg-type]


@pytest.mark.parametrize("forge", ["negative shape", "field beyond the payload", "unknown dtype", "object dtype",
                                   "no arrays key", "huge payload claimed"])
def test_a_forged_header_with_a_valid_checksum_is_refused_not_a_crash(forge: str) -> None:
    """A header that passes its checksum but describes impossible arrays is still refused and deleted."""
    import json
    import struct

    import xxhash

    from core.cache_entry import MAGIC

    path = cache_dir("mesh") / "m.cache"
    save_arrays(path, {"v": np.arange(12.0).reshape(4, 3)}, 1)
    raw = path.read_bytes()
    n, _sum = struct.unpack("<IQ", raw[8:20])
    header = json.loads(raw[20:20 + n])
    row = header["arrays"][0]
    if forge == "negative shape":
        row[2] = [-4, -3]
    elif forge == "field beyond the payload":
        row[3] = 10_000
    elif forge == "unknown dtype":
        row[1] = "<q99"
    elif forge == "object dtype":
        row[1] = "|O"
    elif forge == "no arrays key":
        del header["arrays"]
    else:
        header["payload"] = 1 << 40
    new = json.dumps(header).encode()
    body = raw[(20 + n + 63) // 64 * 64:]  # the payload, after the header's padding to 64 bytes
    head = MAGIC + struct.pack("<IQ", len(new), xxhash.xxh3_64_intdigest(new)) + new
    path.write_bytes(head + bytes((len(head) + 63) // 64 * 64 - len(head)) + body)
    assert load_arrays(path, 1) is None and not path.exists()


def test_an_entry_of_another_version_is_not_used(caplog: pytest.LogCaptureFixture) -> None:
    path = cache_dir("colour") / "m.cache"
    save_array(path, np.eye(3), version=1)
    with caplog.at_level(logging.WARNING, logger="sheer.cache"):
        assert load_array(path, version=2) is None
    assert "version 1, expected 2" in caplog.text and not path.exists()


def test_the_cache_lives_under_xdg_cache_home(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("SHEER_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_root() == tmp_path / "xdg" / "sheer" and cache_dir("atlas") == tmp_path / "xdg" / "sheer" / "atlas"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cache_root() == tmp_path / "home" / ".cache" / "sheer"
    monkeypatch.setenv("SHEER_CACHE_DIR", str(tmp_path / "own"))
    assert cache_root() == tmp_path / "own"


def _fill(kind: str, names: list[str], mib: float, start: float) -> list[Path]:
    """Entries of ``mib`` MiB each, written (mtime) one minute apart from ``start``, oldest first."""
    paths = []
    for i, name in enumerate(names):
        p = cache_dir(kind) / f"{name}.cache"
        assert save_array(p, np.full(int(mib * MIB) // 8, i, dtype=np.float64))
        os.utime(p, (start + 60 * i, start + 60 * i))
        paths.append(p)
    return paths


def test_the_cap_evicts_the_least_recently_used_at_write_time(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SHEER_CACHE_MAX_MB", "1.5")
    assert cache_cap().bytes == int(1.5 * MIB) and cache_cap().source == "SHEER_CACHE_MAX_MB"
    a, b, c = _fill("atlas", ["a", "b", "c"], 0.4, time.time() - 3600)  # 1.2 MiB: all kept
    assert all(p.exists() for p in (a, b, c))
    assert load_array(a) is not None  # reading a marks it used: b is now the least recently used
    d = cache_dir("looks") / "d.cache"
    assert save_array(d, np.zeros(int(0.4 * MIB) // 8))  # 1.6 MiB: one entry must go, across kinds
    assert [p.exists() for p in (a, b, c, d)] == [True, False, True, True]
    assert sum(e.size for e in entries()) <= 1.5 * MIB


def test_an_entry_larger_than_the_cap_is_not_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SHEER_CACHE_MAX_MB", "1")
    (kept,) = _fill("mesh", ["small"], 0.5, time.time())
    big = cache_dir("atlas") / "big.cache"
    assert not save_array(big, np.zeros(2 * MIB // 8))
    assert not big.exists() and kept.exists() and list(big.parent.iterdir()) == []
    monkeypatch.setenv("SHEER_CACHE_MAX_MB", "0")  # 0: keep nothing
    assert not save_array(cache_dir("mesh") / "tiny.cache", np.zeros(1))


def test_the_cap_comes_from_the_environment_then_the_settings_then_the_free_space(
        monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture, _own_cache: Path) -> None:
    _fill("render", ["r"], 0.25, time.time())
    auto = cache_cap()
    free = shutil.disk_usage(_own_cache).free
    expected = min(2 * 1024**3, int(0.10 * (free + 0.25 * MIB)))
    assert auto.source.startswith("automatic") and abs(auto.bytes - expected) <= 0.001 * expected + MIB
    cache.set_configured_max_mb(300)
    assert cache_cap() == cache.CacheCap(300 * MIB, "settings")
    monkeypatch.setenv("SHEER_CACHE_MAX_MB", "20")
    assert cache_cap() == cache.CacheCap(20 * MIB, "SHEER_CACHE_MAX_MB")
    for bad in ("lots", "-5", "nan"):
        monkeypatch.setenv("SHEER_CACHE_MAX_MB", bad)
        with caplog.at_level(logging.WARNING, logger="sheer.cache"):
            assert cache_cap().source == "settings"
        assert f"SHEER_CACHE_MAX_MB={bad!r}" in caplog.text
    with pytest.raises(ValueError, match="MiB"):
        cache.set_configured_max_mb(-1)
    cache.set_configured_max_mb(None)


def test_info_and_clear_per_kind_count_old_format_folders_and_drop_stale_temporaries() -> None:
    _fill("atlas", ["a1", "a2"], 0.1, time.time())
    _fill("looks", ["l1"], 0.1, time.time())
    legacy = cache_dir("atlas") / "old-bake-v4"  # a bake folder of an earlier Sheer: counted, evictable
    legacy.mkdir()
    (legacy / "position.npy").write_bytes(b"x" * 1000)
    fresh_tmp = cache_dir("looks") / ".l2.cache.abc.tmp"  # another process writing right now
    fresh_tmp.write_bytes(b"partial")
    stale_tmp = cache_dir("looks") / ".l3.cache.def.tmp"  # left by a crash an hour ago
    stale_tmp.write_bytes(b"partial")
    os.utime(stale_tmp, (time.time() - 7200, time.time() - 7200))
    found = entries()
    assert sorted(e.path.name for e in found) == ["a1.cache", "a2.cache", "l1.cache", "old-bake-v4"]
    assert next(e for e in found if e.path == legacy).size == 1000
    assert fresh_tmp.exists() and not stale_tmp.exists()
    assert clear("atlas")[0] == 3
    assert sorted(e.path.name for e in entries()) == ["l1.cache"]
    count, freed = clear()
    assert count == 1 and freed > 0.1 * MIB and entries() == []


def test_a_private_cache_keeps_everything_it_writes_and_removes_it(_own_cache: Path) -> None:
    shared_entry = cache_dir("atlas") / "sample.cache"
    save_array(shared_entry, np.arange(5))
    shared_before = sorted(p.relative_to(_own_cache) for p in _own_cache.rglob("*"))
    with PrivateCache() as private:
        assert cache_root() == private and os.environ["SHEER_CACHE_DIR"] == str(private)
        assert (private.stat().st_mode & 0o777) == 0o700
        np.testing.assert_array_equal(load_array(cache_dir("atlas") / "sample.cache"), np.arange(5))  # read through
        face = cache_dir("atlas") / "shopper-face.cache"
        assert save_array(face, np.ones(3)) and face.is_relative_to(private)
        assert save_array(shared_entry.with_name("elsewhere.cache"), np.ones(2))  # a shared path: redirected
        assert (private / "atlas" / "elsewhere.cache").is_file()
        assert not save_array(Path("/tmp/not-a-cache/x/y.cache"), np.ones(2))  # outside every cache: refused
    assert not private.exists() and os.environ["SHEER_CACHE_DIR"] == str(_own_cache)
    assert sorted(p.relative_to(_own_cache) for p in _own_cache.rglob("*")) == shared_before  # untouched
    assert not save_array(face, np.ones(3)) and not private.exists()  # a path kept after the session: refused


def _run(code: str, env: dict[str, str]) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], cwd=REPO, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env={**os.environ, **env})


def test_two_processes_writing_and_reading_one_entry_never_see_half_of_it(_own_cache: Path) -> None:
    """Two writers replace the same 4 MiB entry over and over while each reads it back: every read is
    whole (one value throughout, its CRC right) and nothing is ever reported damaged."""
    code = """
        import logging, sys, numpy as np
        from core.cache import cache_dir, load_array, save_array
        logging.basicConfig(level=logging.WARNING)
        path, me, reads = cache_dir("render") / "shared.cache", float(sys.argv[1]), 0
        for i in range(40):
            save_array(path, np.full(1 << 19, me * 1000 + i))
            got = load_array(path)
            if got is not None:
                assert np.all(got == got[0]), "a mixed entry"
                reads += 1
        print(reads)
    """
    procs = [subprocess.Popen([sys.executable, "-c", textwrap.dedent(code), str(n)], cwd=REPO, text=True,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              env={**os.environ, "SHEER_CACHE_DIR": str(_own_cache)}) for n in (1, 2)]
    outs = [p.communicate(timeout=120) for p in procs]
    for p, (out, err) in zip(procs, outs):
        assert p.returncode == 0, err
        assert "damaged" not in err and int(out) == 40
    assert [e.path.name for e in entries()] == ["shared.cache"]


def test_two_processes_baking_at_once_share_one_good_entry(_own_cache: Path) -> None:
    """Two real processes bake the sample head's atlas into one empty cache at the same time: both get
    the same bake as an uncached one, the cache holds one entry that reads back equal, no temporaries."""
    from painting.atlas import bake
    from tests.painting.helpers import sample_layout

    code = """
        import hashlib, numpy as np
        from painting.atlas import bake
        from tests.painting.helpers import sample_layout
        a = bake(sample_layout(), 512, cache=True)
        print(hashlib.sha256(a.position.tobytes() + a.face.tobytes() + a.pad_src.tobytes()).hexdigest())
    """
    env = {"SHEER_CACHE_DIR": str(_own_cache)}
    procs = [_run(code, env) for _ in range(2)]
    outs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), [e for _, e in outs]
    import hashlib

    truth = bake(sample_layout(), 512, cache=False)
    digest = hashlib.sha256(truth.position.tobytes() + truth.face.tobytes() + truth.pad_src.tobytes()).hexdigest()
    assert [o.strip() for o, _ in outs] == [digest, digest]
    atlas_entries = [e for e in entries() if e.kind == "atlas"]
    assert len(atlas_entries) == 1
    cached = bake(sample_layout(), 512, cache=True)
    np.testing.assert_array_equal(cached.position, truth.position)
    assert not [p for p in _own_cache.rglob(".*")]


def test_source_digest_follows_the_bytes_and_names_of_the_files(tmp_path: Path) -> None:
    a, b = tmp_path / "a.py", tmp_path / "b.py"
    a.write_text("x = 1\n")
    b.write_text("y = 2\n")
    cache.forget_source_digests()
    first = cache.source_digest((a, b))
    assert len(first) == 64 and first == cache.source_digest([str(a), str(b)])
    assert cache.source_digest((b, a)) != first  # the order given
    a.write_text("x = 2\n")
    assert cache.source_digest((a, b)) == first  # memoised for the life of the process
    cache.forget_source_digests()
    edited = cache.source_digest((a, b))
    assert edited != first
    other = tmp_path / "other"
    other.mkdir()
    shutil.copy(a, other / "a.py")
    shutil.copy(b, other / "b.py")
    assert cache.source_digest((other / "a.py", other / "b.py")) == edited  # names and bytes, not folders
    (other / "b.py").rename(other / "c.py")
    assert cache.source_digest((other / "a.py", other / "c.py")) != edited  # a renamed module
    ab = tmp_path / "ab.py"
    ab.write_text("x = 2\ny = 2\n")
    assert cache.source_digest((ab,)) != edited  # files are not merely concatenated


def test_source_digest_of_a_missing_file_is_not_an_empty_one(tmp_path: Path) -> None:
    empty, gone = tmp_path / "m.py", tmp_path / "sub" / "m.py"
    empty.write_bytes(b"")
    cache.forget_source_digests()
    missing = cache.source_digest((gone,))
    assert missing != cache.source_digest((empty,))
    gone.parent.mkdir()
    gone.write_bytes(b"")
    cache.forget_source_digests()
    assert cache.source_digest((gone,)) == cache.source_digest((empty,))
