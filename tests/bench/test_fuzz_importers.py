"""Importer fuzzing: damaged meshes, photographs, EXR files and projects raise Sheer's own errors only.

``run_importers`` (the engine of ``sheer bench fuzz --importers N``) runs 40 damaged files per format with
a fixed seed through every loader in a worker process; the other tests pin the defects it found, each
with a file built here.
"""

from __future__ import annotations

import io
import random
import struct
import zlib
from typing import TYPE_CHECKING

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image

from bench.fuzz_importers import (
    CASE_MIB,
    CASE_SECONDS,
    FORMATS,
    LOADERS,
    classify_call,
    mesh_seeds,
    mutate_case,
    run_importers,
    seed_files,
)
from core.errors import SheerError
from painting.head import HeadError, load_head_from_bytes

if TYPE_CHECKING:
    from pathlib import Path


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def _png(side: int = 32) -> bytes:
    buf = io.BytesIO()
    Image.fromarray((np.random.default_rng(0).random((side, side, 3)) * 255).astype(np.uint8)).save(buf, "PNG")
    return buf.getvalue()


def _png_sized(width: int, height: int) -> bytes:
    """A small PNG whose header claims ``width`` × ``height`` (its CRC correct, its pixel data short)."""
    png = _png()
    ihdr = struct.pack(">II", width, height) + png[24:29]
    return png[:8] + _chunk(b"IHDR", ihdr) + png[33:]


def _png_broken_chunk() -> bytes:
    """A PNG with a chunk of a non-ASCII type between two IDAT chunks: Pillow raises SyntaxError on load."""
    png = _png()
    at = png.find(b"IDAT") - 4
    n = struct.unpack_from(">I", png, at)[0]
    data = png[at + 8:at + 8 + n]
    junk = struct.pack(">I", 4) + b"\x03\xf3\xff\xfd" + b"abcd\0\0\0\0"
    return png[:at] + _chunk(b"IDAT", data[: n // 2]) + junk + _chunk(b"IDAT", data[n // 2:]) + png[at + 12 + n:]


# ------------------------------------------------------------------------------------ the fuzzer


def test_every_seed_loads() -> None:
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        for fmt, files in seed_files().items():
            for name, blob in files:
                path = Path(tmp) / name
                path.write_bytes(blob)
                outcomes = [classify_call(loader, path)[0] for loader in LOADERS[fmt].values()]
                assert "accepted" in outcomes and set(outcomes) <= {"accepted", "refused"}, (fmt, outcomes)


def test_importer_fuzz_finds_no_defects() -> None:
    result = run_importers(40, seed=0, hang_s=20.0)
    assert set(result["formats"]) == set(FORMATS)
    for fmt, figures in result["formats"].items():
        assert figures["cases"] == 40
        assert figures["defects"] == 0, (fmt, figures["defect_examples"])
        assert set(figures["outcomes"]) <= {"accepted", "refused"}, (fmt, figures["outcomes"])
        assert figures["seconds"]["max"] < CASE_SECONDS and figures["peak_mib"]["max"] < CASE_MIB, (fmt, figures)
    assert result["defects"] == 0 and result["worker_restarts"] == 0


def test_the_mutator_is_deterministic() -> None:
    seeds = seed_files()
    for fmt in FORMATS:
        a = [mutate_case(fmt, seeds[fmt][0][1], random.Random(7), seeds[fmt]) for _ in range(3)]
        b = [mutate_case(fmt, seeds[fmt][0][1], random.Random(7), seeds[fmt]) for _ in range(3)]
        assert a == b


MESHES = mesh_seeds()


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # trimesh's, on NaN texture indices
@settings(max_examples=60, deadline=None, database=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(rng=st.randoms(use_true_random=False), fmt=st.sampled_from(["obj", "glb", "gltf", "ply"]))
def test_damaged_embedded_meshes_raise_head_errors_only(rng: random.Random, fmt: str) -> None:
    name, blob = MESHES[fmt][0]
    _, damaged = mutate_case(fmt, blob, rng, MESHES[fmt])
    try:
        load_head_from_bytes({name: damaged}, name)
    except HeadError as exc:
        assert name in str(exc) and "\n" not in str(exc)


# ----------------------------------------------------------------------- defects the fuzzer found


def test_an_obj_face_index_beyond_the_file_is_refused_before_parsing() -> None:
    obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 4294967295/3\n"
    with pytest.raises(HeadError, match=r"'h\.obj': a face refers to vertex 4294967295"):
        load_head_from_bytes({"h.obj": obj}, "h.obj")


def test_an_obj_with_two_coordinates_per_vertex_is_refused() -> None:
    obj = b"v 0 0\nv 1 0\nv 0 1\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n"
    with pytest.raises(HeadError, match=r"'h\.obj': the mesh's vertices have shape \(3, 2\)"):
        load_head_from_bytes({"h.obj": obj}, "h.obj")


@pytest.mark.parametrize(("v", "vt", "said"), [("0 1e308 0", "0 1", r"a vertex coordinate is 1e\+308, over the limit"),
                                              ("0 1 0", "0 1e29", r"a UV coordinate is 1e\+29, over the limit")])
def test_huge_finite_coordinates_are_refused(v: str, vt: str, said: str) -> None:
    obj = f"v 0 0 0\nv 1 0 0\nv {v}\nvt 0 0\nvt 1 0\nvt {vt}\nf 1/1 2/2 3/3\n".encode()
    with pytest.raises(HeadError, match=r"'h\.obj': " + said):
        load_head_from_bytes({"h.obj": obj}, "h.obj")


def test_a_sliver_triangle_unwraps_in_moments() -> None:
    import time

    from painting.layout import build_layout

    obj = b"v 0 0 1000000\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 0 0\nvt 0 0\nf 1/1 2/2 3/3\n"  # flat UVs: unwrapped
    head = load_head_from_bytes({"h.obj": obj}, "h.obj")
    start = time.perf_counter()
    layout = build_layout(head)
    assert layout.source == "xatlas" and time.perf_counter() - start < CASE_SECONDS  # was 9 s (1e8: hours)
    assert np.all((layout.uv >= 0) & (layout.uv <= 1))


def test_faces_out_of_range_are_refused() -> None:
    import trimesh

    from painting.head import _mesh_arrays_from_loaded

    mesh = trimesh.Trimesh(np.eye(3), [[0, 1, 2]], process=False, validate=False)
    mesh.visual = trimesh.visual.TextureVisuals(uv=np.zeros((3, 2)))
    mesh.faces = np.array([[0, 1, 7]])
    with pytest.raises(HeadError, match=r"x\.obj: a face refers to vertex 7, outside the mesh's 3 vertices"):
        _mesh_arrays_from_loaded(mesh, "x.obj")


def _glb_with_broken_texture() -> bytes:
    import trimesh

    box = trimesh.creation.box()
    texture = Image.fromarray((np.random.default_rng(1).random((16, 16, 3)) * 255).astype(np.uint8))
    mesh = trimesh.Trimesh(box.vertices, box.faces, process=False)
    mesh.visual = trimesh.visual.TextureVisuals(uv=box.vertices[:, :2] + 0.5, image=texture)
    glb = bytearray(mesh.export(file_type="glb"))
    at = glb.find(b"IDAT")
    n = struct.unpack_from(">I", glb, at - 4)[0]
    glb[at + 4:at + 4 + n] = bytes((i * 7 + 3) % 256 for i in range(n))  # not a zlib stream
    glb[at + 4 + n:at + 8 + n] = struct.pack(">I", zlib.crc32(bytes(glb[at:at + 4 + n])))
    return bytes(glb)


def test_a_glb_whose_texture_fails_to_decode_is_a_head_error() -> None:
    with pytest.raises(HeadError, match=r"'h\.glb': cannot read mesh"):
        load_head_from_bytes({"h.glb": _glb_with_broken_texture()}, "h.glb")


def test_a_project_head_error_names_the_project_file(tmp_path: Path) -> None:
    from bench.fuzz import sample_project
    from project.document import document_from_project
    from project.errors import ProjectError
    from project.io import open_project, save_project

    project = sample_project(64, 1, embedded=True)
    assert project.head.data is not None
    project.head.data["head.obj"] = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"  # no UVs
    import hashlib

    project.head.files["head.obj"] = hashlib.sha256(project.head.data["head.obj"]).hexdigest()
    path = save_project(project, tmp_path / "her look.sheer", self_contained=True)
    with pytest.raises(ProjectError, match=r"her look\.sheer: embedded head 'head\.obj': the mesh has no UV"):
        document_from_project(open_project(path))


def test_a_project_head_that_cannot_be_painted_names_the_project_file(tmp_path: Path) -> None:
    import hashlib

    from bench.fuzz import sample_project
    from project.document import document_from_project
    from project.errors import ProjectError
    from project.io import open_project, save_project

    project = sample_project(64, 1, embedded=True)
    assert project.head.data is not None
    flat = b"v 0 0 0\nv 0 0 0\nv 0 0 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n"  # one degenerate triangle
    project.head.data["head.obj"] = flat
    project.head.files["head.obj"] = hashlib.sha256(flat).hexdigest()
    project.layout = None
    path = save_project(project, tmp_path / "flat.sheer", self_contained=True)
    with pytest.raises(ProjectError, match=r"flat\.sheer: the head cannot be painted: .*degenerate"):
        document_from_project(open_project(path))


@pytest.mark.parametrize("reader", ["capture.read_photo", "mirror.read_photo_srgb8", "kiosk.read_photo_file",
                                    "shade.read_photo", "capture.read_photo_srgb8"])
def test_a_png_with_a_broken_chunk_is_a_sheer_error(reader: str, tmp_path: Path) -> None:
    path = tmp_path / "broken.png"
    path.write_bytes(_png_broken_chunk())
    with pytest.raises(SheerError, match=r"broken\.png"):
        LOADERS["png"][reader](path)


def test_shade_refuses_a_decompression_bomb_with_its_own_error(tmp_path: Path) -> None:
    from shade.photo import PhotoError, read_photo

    path = tmp_path / "bomb.png"
    path.write_bytes(_png_sized(65535, 65535))
    with pytest.raises(PhotoError, match=r"bomb\.png"):
        read_photo(path)


@pytest.mark.parametrize("module", ["capture.pipeline", "shade.photo"])
def test_a_photo_over_the_pixel_limit_is_refused_from_its_header(module: str, tmp_path: Path) -> None:
    import importlib

    reader = importlib.import_module(module)
    assert reader.MAX_PHOTO_PIXELS * 27 < CASE_MIB * 1024**2  # read as float64, it fits the bound
    path = tmp_path / "huge.png"
    path.write_bytes(_png_sized(6000, 6001))  # 36.0 Mpx: over both limits, under Pillow's bomb threshold
    with pytest.raises(SheerError, match=r"huge\.png: .*(limit|too large)") as caught:
        reader.read_photo(path)
    assert str(caught.value).count("huge.png") == 1  # said once, not wrapped in "cannot read"


def test_capture_reads_a_photo_as_before(tmp_path: Path) -> None:
    from capture.pipeline import read_photo
    from km.srgb import srgb_decode

    path = tmp_path / "p.png"
    path.write_bytes(_png())
    with Image.open(path) as im:
        expected = srgb_decode(np.asarray(im.convert("RGB"), dtype=np.float64) / 255.0)
    got = read_photo(path)
    assert got.dtype == np.float64 and np.array_equal(got, expected)


def test_sheer_bench_fuzz_importers_prints_the_figures(capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from bench.cli import BENCHMARKS
    from bench.fuzz_importers import main

    assert BENCHMARKS["fuzz"] == "bench.fuzz_importers:main"
    assert main(["--importers", "3", "--formats", "obj,png", "--no-assets", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["cases"] == 6 and result["defects"] == 0 and set(result["formats"]) == {"obj", "png"}
    figures = result["formats"]["png"]
    assert figures["loader_calls"] == 3 * len(LOADERS["png"])
    assert set(figures["seconds"]) == {"p50", "p90", "max"} and set(figures["peak_mib"]) == {"p50", "p90", "max"}
    assert len(result["load_average"]["before"]) == 3


def test_sheer_bench_fuzz_without_importers_is_the_project_fuzzer(capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from bench.fuzz_importers import main

    assert main(["--cases", "5", "--crash-runs", "0", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["cases_run"] == 5
