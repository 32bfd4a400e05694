"""Loading trusts nothing: every rejection is a ProjectError whose message names the entry and the problem."""

from __future__ import annotations

import io
import json
import os
import stat
import zipfile
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

import project.container as pz
from bench.fuzz import sample_project
from painting.maps_io import encode_exr
from project.errors import ProjectContainerError, ProjectError, ProjectVersionError
from project.io import open_project, project_bytes, read_project
from project.migrations import SCHEMA_VERSION

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

BASE = project_bytes(sample_project(64, 2, seed=0), self_contained=True)


def entries(blob: bytes = BASE) -> list[tuple[str, bytes]]:
    with zipfile.ZipFile(io.BytesIO(blob)) as zf:
        return [(i.filename, zf.read(i)) for i in zf.infolist()]


def rezip(items: list[tuple[str, bytes]], tweak: Callable[[zipfile.ZipInfo], None] | None = None,
          method: int = zipfile.ZIP_STORED) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name, data in items:
            info = zipfile.ZipInfo(name, date_time=(2020, 1, 1, 0, 0, 0))
            info.compress_type = method
            if tweak:
                tweak(info)
            zf.writestr(info, data)
    return buf.getvalue()


def with_json(change: Callable[[dict[str, Any]], Any]) -> bytes:
    items = entries()
    out = []
    for name, data in items:
        if name == "project.json":
            doc = json.loads(data)
            change(doc)
            data = json.dumps(doc).encode()
        out.append((name, data))
    return rezip(out)


def with_entry(name: str, data: bytes, fix_digest: bool = True, blob: bytes | None = None) -> bytes:
    """Replace entry ``name``; for a layer map, also record its new SHA-256 in project.json (so the
    check under test is reached) unless ``fix_digest`` is False."""
    import hashlib

    items = entries(BASE if blob is None else blob)
    out = []
    for n, d in items:
        if n == name:
            d = data
        elif n == "project.json" and fix_digest and name.startswith("layers/"):
            doc = json.loads(d)
            for layer in doc["layers"]:
                if layer["map"] == name:
                    layer["sha256"] = hashlib.sha256(data).hexdigest()
            d = json.dumps(doc).encode()
        out.append((n, d))
    return rezip(out)


def rejected(blob: bytes, *fragments: str, kind: type[ProjectError] = ProjectError) -> str:
    with pytest.raises(kind) as info:
        read_project(io.BytesIO(blob), name="t.sheer", verify_head=False)
    message = str(info.value)
    assert isinstance(info.value, ValueError)
    for fragment in fragments:
        assert fragment in message, f"{fragment!r} not in {message!r}"
    assert "\n" not in message
    return message


def test_the_base_project_is_valid() -> None:
    read_project(io.BytesIO(BASE), name="t.sheer", verify_head=False)


# ------------------------------------------------------------------------------------------ the container


@pytest.mark.parametrize(("name", "problem"), [
    ("/etc/passwd", "absolute path"),
    ("../escape.txt", "'..'"),
    ("layers/../../x", "'..'"),
    ("C:/windows.txt", "drive letter"),
    ("a\\b.txt", "backslash"),
    ("a//b", "empty or '.'"),
    ("./x", "empty or '.'"),
    ("bad\x01name", "control character"),
    ("x" * 300, "longer than"),
])
def test_unsafe_entry_names(name: str, problem: str) -> None:
    rejected(rezip([*entries(), (name, b"x")]), problem, repr(name)[:20].strip("'"), kind=ProjectContainerError)


def test_symlink_entry() -> None:
    items = [*entries(), ("link", b"/etc/passwd")]

    def tweak(info: zipfile.ZipInfo) -> None:
        if info.filename == "link":
            info.create_system = 3
            info.external_attr = (stat.S_IFLNK | 0o777) << 16

    rejected(rezip(items, tweak), "'link'", "symbolic link")


def test_duplicate_names_exact_and_case_folded() -> None:
    items = entries()
    with pytest.warns(UserWarning):
        blob = rezip([*items, items[1]])
    rejected(blob, "'project.json'", "duplicate entry name")
    rejected(rezip([*items, ("PROJECT.JSON", b"{}")]), "'PROJECT.JSON'", "duplicate")


def test_unexpected_and_missing_entries() -> None:
    rejected(rezip([*entries(), ("notes.txt", b"hi")]), "'notes.txt'", "unexpected entry")
    rejected(rezip([(n, d) for n, d in entries() if n != "layers/001.png"]), "missing entry 'layers/001.png'")
    rejected(rezip([(n, d) for n, d in entries() if n != "project.json"]), "missing entry 'project.json'")
    rejected(rezip([(n, d) for n, d in entries() if n != "head/head.obj"]), "missing entry 'head/head.obj'")
    rejected(rezip([*entries(), ("layers/", b"")]), "'layers/'", "unexpected")


def test_mimetype_must_be_first_and_right() -> None:
    items = entries()
    rejected(rezip(items[1:] + items[:1]), "'mimetype'", "first entry")
    rejected(with_entry("mimetype", b"application/zip"), "'mimetype'", "not application/x-sheer-project")


def test_not_a_zip_and_truncated() -> None:
    rejected(b"hello", "not a Sheer project", kind=ProjectContainerError)
    rejected(BASE[: len(BASE) // 2], "t.sheer", kind=ProjectContainerError)
    rejected(b"", "not a Sheer project")


def test_crc_damage_names_the_entry() -> None:
    blob = bytearray(BASE)
    start = blob.find(b'"schema_version"') if b'"schema_version"' in blob else -1
    if start < 0:  # project.json is deflated: damage a stored map instead
        data = entries()
        exr = dict(data)["layers/000.exr"]
        start = bytes(blob).find(exr[:64]) + 200
    blob[start] ^= 0xFF
    rejected(bytes(blob), "entry '")


def test_zip_bomb_ratio_and_total_size(monkeypatch: pytest.MonkeyPatch) -> None:
    bomb = rezip([*entries(), ("zeros", bytes(2 * 1024 * 1024))], method=zipfile.ZIP_DEFLATED)
    rejected(bomb, "'zeros'", "compression ratio", "zip bomb")
    monkeypatch.setattr(pz, "MAX_TOTAL_UNCOMPRESSED", 20_000)
    rejected(rezip([*entries(), ("big", os.urandom(30_000))]), "total uncompressed size over the limit")
    monkeypatch.setattr(pz, "MAX_ENTRIES", 5)
    rejected(BASE, "entries, over the limit of 5")


def test_forged_entry_count_is_refused_before_parsing() -> None:
    blob = bytearray(BASE)
    at = blob.rfind(b"PK\x05\x06")
    blob[at + 8:at + 12] = (60000).to_bytes(2, "little") * 2  # entries on this disk / in total
    rejected(bytes(blob), "60000 entries, over the limit")


def test_a_folder_or_fifo_is_not_a_project(tmp_path: Path) -> None:
    with pytest.raises(ProjectError, match="not a regular file"):
        open_project(tmp_path)
    fifo = tmp_path / "fifo.sheer"
    os.mkfifo(fifo)
    with pytest.raises(ProjectError, match="not a regular file"):
        open_project(fifo)


def test_entry_declaring_a_false_size_is_caught() -> None:
    """A forged header declaring a small size cannot make the reader return more (nor less) bytes."""
    items = entries()
    blob = bytearray(rezip(items))
    # find project.json's central directory record and shrink its declared uncompressed size by one
    cd = blob.rfind(b"PK\x01\x02", 0, blob.find(b"PK\x05\x06"))
    pos = 0
    while True:
        pos = blob.find(b"PK\x01\x02", pos)
        name_len = int.from_bytes(blob[pos + 28:pos + 30], "little")
        if blob[pos + 46:pos + 46 + name_len] == b"project.json":
            break
        pos += 4
        assert pos <= cd
    size = int.from_bytes(blob[pos + 24:pos + 28], "little")
    blob[pos + 24:pos + 28] = (size - 1).to_bytes(4, "little")
    rejected(bytes(blob), "t.sheer")


# ------------------------------------------------------------------------------------------ project.json


@pytest.mark.parametrize(("change", "fragments"), [
    (lambda d: d.pop("layers"), ["(top level)", "'layers' is a required property"]),
    (lambda d: d.update(colour="red"), ["Additional properties are not allowed", "'colour'"]),
    (lambda d: d["layers"][0].update(opacity=1.5), ["layers[0].opacity", "maximum"]),
    (lambda d: d["layers"][0].update(opacity="0.5"), ["layers[0].opacity", "not of type 'number'"]),
    (lambda d: d["layers"][0].update(visible=1), ["layers[0].visible", "not of type 'boolean'"]),
    (lambda d: d["layers"][1].pop("scale_um"), ["layers[1]", "'scale_um' is a required property"]),
    (lambda d: d["layers"][0].update(map="layers/001.png"), ["layers[0].map", "expected 'layers/000.exr'"]),
    (lambda d: d["layers"][0].update(material="Mystery"), ["layers[0].material", "unknown material 'Mystery'"]),
    (lambda d: d["materials"]["Foundation F"]["S"].__setitem__(1, -2.0), ["materials['Foundation F']", "S[1]"]),
    (lambda d: d["materials"]["Foundation F"].update(name="Other"), ["materials['Foundation F'].name"]),
    (lambda d: d.update(resolution=0), ["resolution", "less than the minimum"]),
    (lambda d: d.update(resolution=100032), ["resolution", "greater than the maximum"]),
    (lambda d: d.update(resolution=100), ["resolution", "not a multiple of 64"]),
    (lambda d: d.update(resolution=True), ["resolution", "not of type 'integer'"]),
    (lambda d: d.update(layout={"source": "magic", "sha256": "0" * 64}), ["layout"]),
    (lambda d: d["lights"][0].pop("direction"), ["lights[0]", "'direction' is a required property"]),
    (lambda d: d["lights"][0].update(direction=[0, 0, 0]), ["lights[0].direction", "must not be zero"]),
    (lambda d: d["lights"][0].update(type="laser"), ["lights[0].type", "'laser' is not one of"]),
    (lambda d: d["lights"].append({"type": "environment", "color": [1, 1, 1], "intensity": 1,
                                   "environment": "../../etc/passwd"}), ["lights[1].environment", "'..'"]),
    (lambda d: d["camera"].update(far=0.01), ["camera.far", "greater than camera.near"]),
    (lambda d: d["camera"].update(position=[0, 0]), ["camera"]),
    (lambda d: d["head"]["files"].update({"../x": "0" * 64}), ["head.files"]),
    (lambda d: d["head"].update(mesh="other.obj"), ["head.mesh", "not in head.files"]),
    (lambda d: d["head"].update(path="/somewhere/head.obj"), ["head.path", "null for an embedded head"]),
    (lambda d: d.update(schema_version="2"), ["schema_version '2' is not a version number"]),
    (lambda d: d.update(format="zip"), ["format"]),
    (lambda d: d["look"].update(tags="x"), ["look"]),
])
def test_json_rejections_name_the_field(change: Callable[[dict[str, Any]], Any], fragments: list[str]) -> None:
    message = rejected(with_json(change), "t.sheer: project.json", *fragments)
    assert len(message) < 400


@pytest.mark.parametrize(("text", "fragment"), [
    (b'{"schema_version": NaN}', "NaN is not a valid number"),
    (b'{"schema_version": 2, "x": Infinity}', "Infinity is not a valid number"),
    (b'{"schema_version": 2, "x": 1e999}', "out of range"),
    (b'{"schema_version": 2, "schema_version": 2}', "duplicate key 'schema_version'"),
    (b'{"schema_version": 2,', "invalid JSON"),
    (b"\xff\xfe{}", "not UTF-8"),
    (b"[" * 100 + b"]" * 100, "nested deeper"),
    (b"[1, 2]", "must be a JSON object"),
    (b'{"name": "x"}', "missing schema_version"),
])
def test_malformed_json(text: bytes, fragment: str) -> None:
    rejected(with_entry("project.json", text), "project.json", fragment)


def test_newer_version_is_refused_with_a_message_that_says_so() -> None:
    message = rejected(with_json(lambda d: d.update(schema_version=99)), "newer Sheer", "schema_version 99",
                       f"reads up to {SCHEMA_VERSION}", kind=ProjectVersionError)
    assert "update Sheer" in message
    rejected(with_json(lambda d: d.update(schema_version=0)), "older than any", kind=ProjectVersionError)


# ------------------------------------------------------------------------------------------ the maps


def test_map_values_nan_inf_negative() -> None:
    for value, fragment in ((np.nan, "NaN or infinite"), (np.inf, "NaN or infinite"), (-1.0, "negative thickness"),
                            (20000.0, "over the 10000 µm limit")):
        thickness = np.zeros((64, 64), np.float32)
        thickness[3, 4] = value
        rejected(with_entry("layers/000.exr", encode_exr(thickness)), "'layers/000.exr'", "layer 0", fragment)


def test_map_shape_dtype_and_size_caps() -> None:
    rejected(with_entry("layers/000.exr", encode_exr(np.zeros((32, 64), np.float32))),
             "'layers/000.exr'", "64×32 does not match the layer's resolution 64×64")
    rejected(with_json(lambda d: d["layers"][0].update(resolution=128)), "'layers/000.exr'",
             "64×64 does not match the layer's resolution 128×128")
    import OpenEXR

    half = io.BytesIO()
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"Y": np.zeros((64, 64), np.float16)}).write(half)
    rejected(with_entry("layers/000.exr", half.getvalue()), "'layers/000.exr'", "32-bit float expected")
    rgb = io.BytesIO()
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"RGB": np.zeros((64, 64, 3), np.float32)}).write(rgb)
    rejected(with_entry("layers/000.exr", rgb.getvalue()), "EXR channels", "exactly ['Y']")
    rejected(with_entry("layers/000.exr", b"\x76\x2f\x31\x01garbage"), "'layers/000.exr'", "EXR header")
    rejected(with_entry("layers/000.exr", b"not an exr"), "not an OpenEXR file")
    big = encode_exr(np.zeros((1, 9000), np.float32))
    rejected(with_json(lambda d: d["layers"][0].update(resolution=9024)), "layers[0].resolution", "maximum")
    rejected(with_entry("layers/000.exr", big), "9000×1", "outside 1..8192")


def test_png_map_checks() -> None:
    from PIL import Image

    def png(arr: np.ndarray) -> bytes:
        buf = io.BytesIO()
        Image.fromarray(arr).save(buf, format="PNG")
        return buf.getvalue()

    rejected(with_entry("layers/001.png", png(np.zeros((64, 64), np.uint8))), "'layers/001.png'",
             "PNG mode L, 16-bit greyscale expected")
    rejected(with_entry("layers/001.png", png(np.zeros((4, 64), np.uint16))), "64×4 does not match")
    rejected(with_entry("layers/001.png", b"\x89PNG\r\n\x1a\n" + b"\0" * 40), "cannot decode the PNG")


def test_damaged_or_swapped_maps_are_caught_by_their_digest() -> None:
    exr = dict(entries())["layers/000.exr"]
    damaged = bytearray(exr)
    damaged[-10] ^= 0x01
    rejected(with_entry("layers/000.exr", bytes(damaged), fix_digest=False), "'layers/000.exr'",
             "does not match layers[0].sha256", "damaged or belongs to another layer")
    three = project_bytes(sample_project(64, 3, seed=4), self_contained=True)  # layers 000 and 002 are EXR
    maps = dict(entries(three))
    swapped = rezip([(n, maps["layers/002.exr"] if n == "layers/000.exr" else maps["layers/000.exr"]
                      if n == "layers/002.exr" else d) for n, d in entries(three)])
    rejected(swapped, "'layers/000.exr'", "does not match layers[0].sha256")


def test_embedded_head_damage_is_detected() -> None:
    rejected(with_entry("head/head.obj", b"v 9 9 9\n"), "'head/head.obj'", "embedded head is damaged")


# ------------------------------------------------------------------------------------------ nothing written


def test_loading_writes_nothing_anywhere(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every open() for writing and every mkdir is forbidden while loading (good and bad files)."""
    import builtins

    path = tmp_path / "p.sheer"
    path.write_bytes(BASE)
    bad = tmp_path / "bad.sheer"
    bad.write_bytes(rezip([*entries(), ("../../escape", b"x")]))
    before = sorted(p.name for p in tmp_path.iterdir())
    real_open = builtins.open
    real_os_open = os.open

    def guarded_open(file: Any, mode: str = "r", *a: Any, **k: Any) -> Any:
        assert not any(c in mode for c in "wax+"), f"write attempted: {file} {mode}"
        return real_open(file, mode, *a, **k)

    def guarded_os_open(file: Any, flags: int, *a: Any, **k: Any) -> int:
        assert not flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT), f"write attempted: {file}"
        return real_os_open(file, flags, *a, **k)

    monkeypatch.setattr(builtins, "open", guarded_open)
    monkeypatch.setattr(os, "open", guarded_os_open)
    monkeypatch.setattr(os, "mkdir", lambda *a, **k: pytest.fail("mkdir while loading"))
    open_project(path, verify_head=False)
    with pytest.raises(ProjectError):
        open_project(bad, verify_head=False)
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert not (tmp_path.parent / "escape").exists()
