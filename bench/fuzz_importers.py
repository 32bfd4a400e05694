"""Importer fuzzing (``sheer bench fuzz --importers N``): damaged user files through every loader.

Formats and the loaders each case goes through (:data:`LOADERS`):

- ``obj``, ``glb``, ``gltf``, ``ply`` head meshes: :func:`painting.head.load_head` (from a file) and
  :func:`painting.head.load_head_from_bytes` (a head embedded in a project).
- ``png``, ``jpeg`` photographs and textures: the capture's readers (:func:`capture.pipeline.read_photo`,
  :func:`capture.auto.read_photo_srgb8`), ``sheer shade match --photo`` (:func:`shade.photo.read_photo`),
  the mirror's ``--photo`` (:func:`app.commands.render_views.read_photo_srgb8`), the kiosk's watched folder
  (:func:`app.camera_source.read_photo_file`) and head textures (:func:`painting.head.decode_texture`).
- ``exr``: environment maps (:meth:`render.lights.Environment.load`) and layer maps
  (:func:`painting.maps_io.decode_exr`).
- ``project``: ``.sheer`` files with an embedded head, opened as the studio opens them
  (:func:`project.io.open_project` + :func:`project.document.document_from_project`, which parses the
  embedded mesh).

Each case is a valid seed file (generated here: :func:`seed_files`; with ``assets``, also the sample
assets found on the asset search path) damaged once by a seeded mutator (:func:`mutate_case`): bit
flips, truncations, byte runs inserted, deleted or overwritten, splices of two seeds, odd 32-bit
integers written into the header (huge counts and sizes), numeric tokens of text formats (OBJ, PLY
headers, glTF JSON) replaced, a GLB's JSON chunk edited (lengths fixed), PNG chunks edited (CRCs fixed),
a JPEG's frame size replaced, and for projects an embedded head mesh damaged with its SHA-256 updated so
the damage reaches the mesh parser.

Cases run in a worker process (:class:`Worker`) that measures each loader call's time and peak RSS
growth (the kernel's high-water mark, reset before each call through ``/proc/self/clear_refs``). A call
that runs past ``hang_s`` kills the worker (outcome ``hang``); a dead worker is ``crash``. Outcomes per
loader call: ``accepted``; ``refused`` (a :class:`core.errors.SheerError` whose message is one line
naming the file); ``bad_message`` (a SheerError of several lines or not naming the file);
``memory_error`` (a SheerError wrapping a failed allocation); ``other`` (any other exception); ``hang``; ``crash``. Every outcome but the first two is a defect, and so is a call
over :data:`CASE_SECONDS` or :data:`CASE_MIB` (counted as ``over_time`` / ``over_memory``).
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
import multiprocessing
import os
import random
import re
import resource
import struct
import sys
import tempfile
import time
import zipfile
import zlib
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable

#: The formats fuzzed, in order.
FORMATS = ("obj", "glb", "gltf", "ply", "png", "jpeg", "exr", "project")
#: A loader call must finish within this many seconds ...
CASE_SECONDS = 2.0
#: ... and grow the process's peak resident memory by at most this many MiB.
CASE_MIB = 1024.0
#: Outcomes that are not defects.
GOOD = ("accepted", "refused")
#: Address space the worker may add to what it has after its imports (a larger allocation is a
#: MemoryError, reported as a defect, instead of a machine out of memory).
ADDRESS_SPACE_HEADROOM = 4 * 1024**3

# ------------------------------------------------------------------------------------------- seeds


def _uv_box() -> Any:
    """The unit box of ``trimesh.creation.box`` with UV coordinates (a head must have UVs)."""
    import trimesh

    box = trimesh.creation.box()
    corners = box.vertices[box.faces].reshape(-1, 3)  # every triangle its own three vertices ...
    cells = np.repeat(np.arange(len(box.faces)), 3)
    offsets = np.tile([[0.05, 0.05], [0.9, 0.05], [0.05, 0.9]], (len(box.faces), 1))
    uv = (np.stack([cells % 4, cells // 4], axis=1) + offsets) / 4.0  # ... in its own UV cell: no overlaps
    mesh = trimesh.Trimesh(corners, np.arange(len(corners)).reshape(-1, 3), process=False)
    mesh.visual = trimesh.visual.TextureVisuals(uv=uv)
    return mesh


def mesh_seeds() -> dict[str, list[tuple[str, bytes]]]:
    """Valid head meshes by format: a box with UVs as OBJ, GLB, glTF (embedded buffer), PLY (binary, ASCII)."""
    import trimesh

    mesh = _uv_box()
    gltf = trimesh.exchange.gltf.export_gltf(trimesh.Scene(mesh), embed_buffers=True)
    obj = b"\n".join(line for line in mesh.export(file_type="obj").encode().split(b"\n")
                     if not line.startswith((b"mtllib", b"usemtl")))  # no material file to find
    return {
        "obj": [("case.obj", obj)],
        "glb": [("case.glb", mesh.export(file_type="glb"))],
        "gltf": [("case.gltf", next(iter(gltf.values())))],
        "ply": [("case.ply", mesh.export(file_type="ply")),
                ("case.ply", mesh.export(file_type="ply", encoding="ascii"))],
    }


def image_seeds() -> dict[str, list[tuple[str, bytes]]]:
    """Valid small photographs: PNG (RGB, RGBA, 16-bit grey, palette) and JPEG (plain, EXIF-rotated)."""
    from PIL import Image

    rng = np.random.default_rng(0)
    rgb = Image.fromarray((rng.random((24, 32, 3)) * 255).astype(np.uint8), "RGB")
    pngs = []
    for im in (rgb, rgb.convert("RGBA"), Image.fromarray((rng.random((16, 16)) * 65535).astype(np.uint16)),
               rgb.convert("P")):
        buf = io.BytesIO()
        im.save(buf, "PNG")
        pngs.append(("case.png", buf.getvalue()))
    jpegs = []
    for orientation in (None, 6):
        buf = io.BytesIO()
        exif = Image.Exif()
        if orientation:
            exif[0x0112] = orientation
        rgb.save(buf, "JPEG", quality=90, exif=exif.tobytes())
        jpegs.append(("case.jpg", buf.getvalue()))
    return {"png": pngs, "jpeg": jpegs}


def exr_seeds() -> list[tuple[str, bytes]]:
    """Valid small EXR files: an RGB half-float environment and a one-channel ``Y`` layer map."""
    import OpenEXR

    from painting.maps_io import encode_exr

    rng = np.random.default_rng(1)
    env = (rng.random((8, 16, 3)) * 4).astype(np.float16)
    buf = io.BytesIO()
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"RGB": env}).write(buf)
    return [("case.exr", buf.getvalue()), ("case.exr", encode_exr((rng.random((16, 16)) * 30).astype(np.float32)))]


def project_seeds() -> list[tuple[str, bytes]]:
    """Valid projects with an embedded head: the fuzzing sample's OBJ triangle, and a GLB box."""
    from bench.fuzz import sample_project
    from project.io import project_bytes

    with_obj = sample_project(64, 1, seed=0, embedded=True)
    with_glb = sample_project(64, 1, seed=1, embedded=True)
    glb = _uv_box().export(file_type="glb")
    assert with_glb.head.data is not None
    with_glb.head.data = {"head.glb": glb}
    with_glb.head.files = {"head.glb": hashlib.sha256(glb).hexdigest()}
    with_glb.head.mesh = "head.glb"
    return [("case.sheer", project_bytes(p, self_contained=True)) for p in (with_obj, with_glb)]


def asset_seeds() -> dict[str, list[tuple[str, bytes]]]:
    """The sample assets on the asset search path as extra seeds (those found; none in a bare checkout)."""
    from core.assets import find_asset

    wanted = {"obj": "heads/canonical-face/canonical_face_model.obj", "glb": "heads/lee-perry-smith/head.glb",
              "png": "photos/astronaut.png", "jpeg": "photos/grace_hopper.jpg", "exr": "environments/studio.exr"}
    out: dict[str, list[tuple[str, bytes]]] = {}
    for fmt, rel in wanted.items():
        try:
            path = find_asset(rel)
        except Exception:  # not installed here: the generated seeds are enough
            continue
        out.setdefault(fmt, []).append(("case" + Path(rel).suffix, path.read_bytes()))
    return out


def seed_files(assets: bool = False) -> dict[str, list[tuple[str, bytes]]]:
    """Valid seed files by format: (file name, bytes); ``assets`` adds :func:`asset_seeds`."""
    seeds = {**mesh_seeds(), **image_seeds(), "exr": exr_seeds(), "project": project_seeds()}
    if assets:
        for fmt, extra in asset_seeds().items():
            seeds[fmt] = seeds[fmt] + extra
    return seeds


# --------------------------------------------------------------------------------------- mutations

#: 32-bit values written over header fields: zero, negatives, huge counts and sizes.
ODD_INTS = (0, 1, 2, 3, 255, 65535, 65536, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF, 0xFFFFFFFE, 1 << 24, 100_000_000)
#: Tokens written over numbers in text formats.
ODD_TOKENS = (b"0", b"-1", b"4294967295", b"2147483648", b"999999999999", b"1e308", b"-1e308", b"nan", b"inf",
              b"-0", b"3.5", b"100000000", b"x", b"")
BYTE_MUTATIONS = ("bitflip", "truncate", "insert", "delete", "overwrite", "splice", "int_field")
_NUMBER = re.compile(rb"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def _random_bytes(rng: random.Random, n: int) -> bytes:
    return bytes(rng.randrange(256) for _ in range(n))


def mutate_bytes(blob: bytes, rng: random.Random, kind: str, other: bytes = b"") -> bytes:
    """``blob`` damaged one way (:data:`BYTE_MUTATIONS`); ``other`` (a second seed) is spliced in."""
    data = bytearray(blob)
    n = max(len(data), 1)
    pos = rng.randrange(n)
    if kind == "bitflip":
        for _ in range(rng.choice([1, 1, 2, 8, 32])):
            i = rng.randrange(n)
            if i < len(data):
                data[i] ^= 1 << rng.randrange(8)
        return bytes(data)
    if kind == "truncate":
        return bytes(data[:pos])
    if kind == "insert":
        return bytes(data[:pos] + _random_bytes(rng, rng.choice([1, 4, 16, 300])) + data[pos:])
    if kind == "delete":
        return bytes(data[:pos] + data[pos + rng.choice([1, 4, 16, 300]):])
    if kind == "overwrite":
        run = _random_bytes(rng, rng.randrange(1, 32))
        return bytes(data[:pos] + run + data[pos + len(run):])
    if kind == "splice":
        donor = other or blob
        start = rng.randrange(max(len(donor), 1))
        return bytes(data[:pos]) + donor[start:start + rng.randrange(1, 2048)] + bytes(data[pos:])
    # int_field: an odd 32-bit integer over a field near the start (the header: counts, sizes, offsets)
    at = rng.randrange(min(n, 512)) & ~3 if rng.random() < 0.7 else rng.randrange(min(n, 512))
    packed = struct.pack(rng.choice(["<I", ">I"]), rng.choice(ODD_INTS))
    return bytes(data[:at] + packed + data[at + 4:])


def mutate_numbers(text: bytes, rng: random.Random, limit: int | None = None) -> bytes:
    """A text format with one to three numeric tokens (among the first ``limit`` bytes) replaced."""
    head = text if limit is None else text[:limit]
    spans = [m.span() for m in _NUMBER.finditer(head)]
    if not spans:
        return text
    for start, end in sorted(rng.sample(spans, min(len(spans), rng.choice([1, 1, 2, 3]))), reverse=True):
        text = text[:start] + rng.choice(ODD_TOKENS) + text[end:]
    return text


def mutate_lines(text: bytes, rng: random.Random) -> bytes:
    """A text format with a line dropped, duplicated many times, or cut in the middle."""
    lines = text.split(b"\n")
    i = rng.randrange(len(lines))
    choice = rng.random()
    if choice < 0.4:
        del lines[i]
    elif choice < 0.7:
        lines[i:i] = [lines[i]] * rng.choice([2, 50])
    else:
        lines[i] = lines[i][: rng.randrange(len(lines[i]) + 1)]
    return b"\n".join(lines)


def _ply_header_end(blob: bytes) -> int:
    end = blob.find(b"end_header")
    return end if end >= 0 else min(len(blob), 512)


def mutate_glb_json(blob: bytes, rng: random.Random) -> bytes:
    """A GLB whose JSON chunk has numbers replaced (counts, offsets, lengths), the chunk lengths fixed."""
    if len(blob) < 20 or blob[:4] != b"glTF":
        return blob
    json_len = struct.unpack_from("<I", blob, 12)[0]
    text = mutate_numbers(blob[20:20 + json_len].rstrip(b" "), rng)
    text += b" " * (-len(text) % 4)
    rest = blob[20 + json_len:]
    return blob[:4] + struct.pack("<II", struct.unpack_from("<I", blob, 4)[0], 20 + len(text) + len(rest)) + \
        struct.pack("<I", len(text)) + blob[16:20] + text + rest


def _png_chunks(blob: bytes) -> list[tuple[bytes, bytes]]:
    chunks, at = [], 8
    while at + 8 <= len(blob):
        length, kind = struct.unpack_from(">I4s", blob, at)
        chunks.append((kind, blob[at + 8:at + 8 + length]))
        at += 12 + length
    return chunks


def mutate_png_chunk(blob: bytes, rng: random.Random) -> bytes:
    """A PNG with one chunk's data edited and its CRC fixed: IHDR sizes, depth, type; other chunks' bytes."""
    chunks = _png_chunks(blob)
    if not chunks:
        return blob
    i = rng.randrange(len(chunks))
    kind, data = chunks[i]
    if kind == b"IHDR" and len(data) >= 13:
        w, h, depth, ctype = struct.unpack_from(">IIBB", data)
        field = rng.randrange(4)
        values = [w, h, depth, ctype]
        values[field] = rng.choice(ODD_INTS) if field < 2 else rng.choice([0, 1, 2, 3, 4, 6, 8, 16, 255])
        data = struct.pack(">IIBB", *values) + data[10:]
    elif data:
        data = mutate_bytes(data, rng, rng.choice(["bitflip", "truncate", "overwrite", "insert"]))
    if kind == b"IDAT" and rng.random() < 0.3:  # a valid zlib stream of the wrong size (or a bomb)
        data = zlib.compress(b"\0" * rng.choice([1, 100, 10_000_000]))
    chunks[i] = (kind, data)
    return blob[:8] + b"".join(struct.pack(">I", len(d)) + k + d + struct.pack(">I", zlib.crc32(k + d))
                               for k, d in chunks)


def mutate_jpeg_frame(blob: bytes, rng: random.Random) -> bytes:
    """A JPEG whose frame header (SOF0/SOF2) has its height, width or component count replaced."""
    at = max(blob.find(b"\xff\xc0"), blob.find(b"\xff\xc2"))
    if at < 0 or at + 10 > len(blob):
        return blob
    data = bytearray(blob)
    field = rng.choice([5, 7, 9])
    if field == 9:
        data[9 + at] = rng.choice([0, 1, 2, 4, 255])
    else:
        struct.pack_into(">H", data, at + field, rng.choice([0, 1, 0xFFFF, 0x7FFF, 30000]))
    return bytes(data)


def mutate_project_head(blob: bytes, rng: random.Random) -> bytes:
    """A project whose embedded head mesh is damaged, its SHA-256 in ``project.json`` updated to match."""
    with zipfile.ZipFile(io.BytesIO(blob)) as zf:
        entries = {info.filename: zf.read(info) for info in zf.infolist()}
    doc = json.loads(entries["project.json"])
    mesh = doc["head"]["mesh"]
    fmt = "glb" if mesh.endswith(".glb") else "obj"
    _, damaged = mutate_case(fmt, entries["head/" + mesh], rng, [])
    entries["head/" + mesh] = damaged
    doc["head"]["files"][mesh] = hashlib.sha256(damaged).hexdigest()
    entries["project.json"] = json.dumps(doc).encode()
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as zf:
        for name, data in entries.items():
            kind = zipfile.ZIP_STORED if name == "mimetype" else zipfile.ZIP_DEFLATED
            zf.writestr(zipfile.ZipInfo(name, date_time=(2020, 1, 1, 0, 0, 0)), data, compress_type=kind)
    return out.getvalue()


def _format_mutations(fmt: str) -> dict[str, Callable[[bytes, random.Random], bytes]]:
    """The format-aware mutations of ``fmt`` (besides :data:`BYTE_MUTATIONS`)."""
    if fmt == "obj":
        return {"numbers": mutate_numbers, "lines": mutate_lines}
    if fmt == "ply":
        return {"header_numbers": lambda b, r: mutate_numbers(b, r, _ply_header_end(b)),
                "header_lines": lambda b, r: mutate_lines(b[:_ply_header_end(b)], r) + b[_ply_header_end(b):]}
    if fmt == "gltf":
        return {"numbers": mutate_numbers, "lines": mutate_lines}
    if fmt == "glb":
        return {"json_numbers": mutate_glb_json}
    if fmt == "png":
        return {"chunk": mutate_png_chunk}
    if fmt == "jpeg":
        return {"frame": mutate_jpeg_frame}
    if fmt == "project":
        from bench.fuzz import mutate

        return {"zip": lambda b, r: mutate(b, r)[1], "head_mesh": mutate_project_head}
    return {}


def mutate_case(fmt: str, blob: bytes, rng: random.Random, others: list[tuple[str, bytes]]) -> tuple[str, bytes]:
    """One damaged variant of the seed ``blob`` of format ``fmt``: (mutation, bytes).

    Half the time a format-aware mutation (:func:`_format_mutations`), else a byte mutation; ``others``
    are the format's seeds, spliced in.
    """
    special = _format_mutations(fmt)
    if special and rng.random() < 0.5:
        kind = rng.choice(sorted(special))
        return kind, special[kind](blob, rng)
    kind = rng.choice(BYTE_MUTATIONS)
    other = rng.choice(others)[1] if others else b""
    return kind, mutate_bytes(blob, rng, kind, other)


# ----------------------------------------------------------------------------------------- loaders


def _load_head_file(path: Path) -> None:
    from painting.head import load_head

    load_head(path)


def _load_head_bytes(path: Path) -> None:
    from painting.head import load_head_from_bytes

    load_head_from_bytes({path.name: path.read_bytes()}, path.name)


def _capture_read_photo(path: Path) -> None:
    from capture.pipeline import read_photo

    read_photo(path)


def _capture_auto_photo(path: Path) -> None:
    from capture.auto import read_photo_srgb8

    read_photo_srgb8(path)


def _shade_photo(path: Path) -> None:
    from shade.photo import read_photo

    read_photo(path)


def _mirror_photo(path: Path) -> None:
    from app.commands.render_views import read_photo_srgb8

    read_photo_srgb8(str(path))


def _kiosk_photo(path: Path) -> None:
    from app.camera_source import read_photo_file

    read_photo_file(path)


def _head_texture(path: Path) -> None:
    from painting.head import decode_texture

    decode_texture(path.read_bytes(), str(path), "RGB")


def _environment(path: Path) -> None:
    from render.lights import Environment

    Environment.load(str(path))


def _layer_map(path: Path) -> None:
    from painting.maps_io import decode_exr

    decode_exr(path.read_bytes(), str(path))


def _project(path: Path) -> None:
    from project.document import document_from_project
    from project.io import open_project

    document_from_project(open_project(path))


_MESH: dict[str, Callable[[Path], None]] = {"load_head": _load_head_file, "load_head_from_bytes": _load_head_bytes}
_PHOTO: dict[str, Callable[[Path], None]] = {"capture.read_photo": _capture_read_photo, "capture.read_photo_srgb8": _capture_auto_photo,
          "shade.read_photo": _shade_photo, "mirror.read_photo_srgb8": _mirror_photo,
          "kiosk.read_photo_file": _kiosk_photo, "head.decode_texture": _head_texture}
#: format -> {loader name: loader(path)}
LOADERS: dict[str, dict[str, Callable[[Path], None]]] = {
    "obj": _MESH, "glb": _MESH, "gltf": _MESH, "ply": _MESH, "png": _PHOTO, "jpeg": _PHOTO,
    "exr": {"Environment.load": _environment, "maps_io.decode_exr": _layer_map},
    "project": {"open_project+document": _project},
}


# ------------------------------------------------------------------------------------------ worker


def _status_kib(field: str) -> int:
    """A ``/proc/self/status`` memory field (``VmRSS``, ``VmHWM``, ``VmSize``) in KiB; 0 where unknown."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(field + ":"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def _reset_peak() -> int:
    """Reset the peak resident size to the current one (Linux); returns the baseline in KiB."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return _status_kib("VmRSS")
    except OSError:  # elsewhere the high-water mark cannot be reset: growth is measured from the old peak
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def _peak_kib() -> int:
    return _status_kib("VmHWM") or resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


_OUT_OF_MEMORY = re.compile(r"MemoryError|Unable to allocate|cannot allocate|bad_alloc|out of memory", re.I)


def classify_call(loader: Callable[[Path], None], path: Path) -> tuple[str, str, float, float, float]:
    """Run ``loader(path)``: (outcome, message, seconds, peak MiB growth, CPU seconds); see the module docstring."""
    from core.errors import SheerError

    base = _reset_peak()
    start, cpu = time.perf_counter(), time.process_time()
    try:
        loader(path)
        outcome, message = "accepted", ""
    except SheerError as exc:
        message = str(exc)
        named = path.name in message
        outcome = "refused" if named and "\n" not in message.strip() else "bad_message"
        if _OUT_OF_MEMORY.search(message):  # a loader wrapped a failed allocation: still a defect
            outcome = "memory_error"
    except Exception as exc:  # anything else is a defect in the loader
        outcome, message = "other", f"{type(exc).__name__}: {exc}"
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    return outcome, message[:300], seconds, max(0, _peak_kib() - base) / 1024.0, cpu


def _warm_up(folder: Path) -> None:
    """Import every loader's modules and run each on its valid seeds (so cases time the parsing only)."""
    for fmt, files in seed_files().items():
        name, blob = files[0]
        path = folder / name
        path.write_bytes(blob)
        for loader in LOADERS[fmt].values():
            classify_call(loader, path)


def _worker_main(conn: Any, folder: str) -> None:
    """The worker process: warm up, cap the address space, then run cases from ``conn`` until None."""
    import logging
    import warnings

    os.environ["SHEER_CACHE_DIR"] = str(Path(folder) / "cache")  # the mesh cache never sees fuzzed files
    logging.disable(logging.CRITICAL)  # trimesh logs what it skips in a damaged file
    warnings.simplefilter("ignore")
    _warm_up(Path(folder))
    size = _status_kib("VmSize") * 1024
    if size:
        resource.setrlimit(resource.RLIMIT_AS, (size + ADDRESS_SPACE_HEADROOM, resource.RLIM_INFINITY))
    conn.send("ready")
    while True:
        case = conn.recv()
        if case is None:
            return
        fmt, name, blob = case
        path = Path(folder) / name
        path.write_bytes(blob)
        for loader_name, loader in LOADERS[fmt].items():
            conn.send((loader_name, *classify_call(loader, path)))
        path.unlink()


class Worker:
    """A process running loader calls; restarted after a hang or a crash.

    Args:
        hang_s: a loader call running longer than this is a hang: the worker is killed.
        folder: where the worker writes each case's file (a temporary folder by default).
    """

    def __init__(self, hang_s: float = 30.0, folder: str | Path | None = None) -> None:
        self.hang_s = hang_s
        self._tmp = tempfile.TemporaryDirectory(dir=folder, prefix="sheer-fuzz-")
        methods = multiprocessing.get_all_start_methods()
        self._ctx: Any = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
        self._proc: Any = None
        self._conn: Any = None
        self.restarts = 0

    def _start(self) -> None:
        parent, child = self._ctx.Pipe()
        self._proc = self._ctx.Process(target=_worker_main, args=(child, self._tmp.name), daemon=True)
        self._proc.start()
        child.close()
        self._conn = parent
        if not parent.poll(300) or parent.recv() != "ready":
            raise RuntimeError("the fuzzing worker did not start")

    def _stop(self) -> None:
        if self._proc is not None:
            self._proc.kill()
            self._proc.join(10)
            self._proc = None
            self.restarts += 1

    def run(self, fmt: str, name: str, blob: bytes) -> list[tuple[str, str, str, float, float, float]]:
        """Each loader of ``fmt`` on ``blob`` saved as ``name``: (loader, outcome, message, s, MiB, CPU s)."""
        if self._proc is None:
            self._start()
        self._conn.send((fmt, name, blob))
        results: list[tuple[str, str, str, float, float, float]] = []
        for loader_name in LOADERS[fmt]:
            start = time.perf_counter()
            try:
                ready = self._conn.poll(self.hang_s)
                got = self._conn.recv() if ready else None
            except (EOFError, OSError):
                got = (loader_name, "crash", f"worker died (exit code {self._proc.exitcode})",
                       time.perf_counter() - start, 0.0, 0.0)
                self._stop()
                return [*results, got]
            if got is None:
                self._stop()
                return [*results, (loader_name, "hang", f"no answer in {self.hang_s:g} s", self.hang_s, 0.0, 0.0)]
            results.append(got)
        return results

    def close(self) -> None:
        """Stop the worker and remove its folder."""
        if self._proc is not None:
            try:
                self._conn.send(None)
                self._proc.join(10)
            except OSError:
                pass
            if self._proc.is_alive():
                self._proc.kill()
                self._proc.join(10)
            self._proc = None
        self._tmp.cleanup()


# ------------------------------------------------------------------------------------------ report


def _percentiles(values: list[float], digits: int) -> dict[str, float]:
    """p50, p90 and max of ``values`` (empty: zeros)."""
    if not values:
        return {"p50": 0.0, "p90": 0.0, "max": 0.0}
    arr = np.asarray(values, dtype=np.float64)
    return {"p50": round(float(np.percentile(arr, 50)), digits), "p90": round(float(np.percentile(arr, 90)), digits),
            "max": round(float(arr.max()), digits)}


def _format_report(calls: list[tuple[str, str, str, str, float, float, float]], cases: int) -> dict[str, Any]:
    """One format's figures from its loader calls (mutation, loader, outcome, message, seconds, MiB, CPU s)."""
    outcomes: Counter[str] = Counter()
    by_loader: dict[str, Counter[str]] = {}
    examples: list[str] = []
    for mutation, loader, outcome, message, seconds, mib, _cpu in calls:
        outcomes[outcome] += 1
        by_loader.setdefault(loader, Counter())[outcome] += 1
        flags = [f for f, bad in (("over_time", seconds > CASE_SECONDS), ("over_memory", mib > CASE_MIB)) if bad]
        for flag in flags:
            outcomes[flag] += 1
        if (outcome not in GOOD or flags) and len(examples) < 5:
            examples.append(f"{loader} [{mutation}] {outcome}{' ' + ','.join(flags) if flags else ''}: {message}")
    defects = sum(n for k, n in outcomes.items() if k not in GOOD)
    return {"cases": cases, "loader_calls": len(calls), "outcomes": dict(sorted(outcomes.items())),
            "defects": defects, "defect_examples": examples,
            "by_loader": {k: dict(sorted(v.items())) for k, v in sorted(by_loader.items())},
            "seconds": _percentiles([c[4] for c in calls], 4), "peak_mib": _percentiles([c[5] for c in calls], 1),
            "cpu_seconds": round(sum(c[6] for c in calls), 2)}


def run_importers(cases: int, seed: int = 0, formats: tuple[str, ...] = FORMATS, assets: bool = False,
                  hang_s: float = 30.0, keep: str | Path | None = None) -> dict[str, Any]:
    """Fuzz every loader with ``cases`` damaged files per format; figures per format and in total.

    Args:
        cases: damaged files per format.
        seed: seeds the mutator (the same seed gives the same files).
        formats: which of :data:`FORMATS`.
        assets: add the sample assets as seeds (:func:`asset_seeds`).
        hang_s: a loader call longer than this is a hang (the worker is killed and restarted).
        keep: a folder to write the damaged files of defects to (for reproducing them), or None.
    """
    rng = random.Random(seed)
    seeds = seed_files(assets)
    worker = Worker(hang_s)
    report: dict[str, Any] = {}
    load_before = os.getloadavg()
    t0 = time.perf_counter()
    try:
        for fmt in formats:
            calls: list[tuple[str, str, str, str, float, float, float]] = []
            for i in range(cases):
                name, base = rng.choice(seeds[fmt])
                mutation, blob = mutate_case(fmt, base, rng, seeds[fmt])
                results = worker.run(fmt, name, blob)
                calls += [(mutation, *r) for r in results]
                bad = [r for r in results if r[1] not in GOOD or r[3] > CASE_SECONDS or r[4] > CASE_MIB]
                if keep is not None and bad:
                    Path(keep).mkdir(parents=True, exist_ok=True)
                    (Path(keep) / f"{fmt}-{i}-{mutation}{Path(name).suffix}").write_bytes(blob)
            report[fmt] = _format_report(calls, cases)
    finally:
        worker.close()
    return {"cases_per_format": cases, "seed": seed, "assets": assets,
            "cases": sum(r["cases"] for r in report.values()),
            "defects": sum(r["defects"] for r in report.values()), "worker_restarts": worker.restarts,
            "bounds": {"seconds": CASE_SECONDS, "peak_mib": CASE_MIB},
            "wall_seconds": round(time.perf_counter() - t0, 1),
            "loader_cpu_seconds": round(sum(r["cpu_seconds"] for r in report.values()), 1),
            "load_average": {"before": [round(x, 2) for x in load_before],
                             "after": [round(x, 2) for x in os.getloadavg()]},
            "formats": report}


def main(argv: list[str]) -> int:
    """``sheer bench fuzz``: with ``--importers N`` :func:`run_importers`'s JSON, else :func:`bench.fuzz.bench_main`.

    Exits 1 when a loader call was a defect (anything but accepted, or refused with a one-line
    SheerError naming the file, within the time and memory bounds).
    """
    if not any(a == "--importers" or a.startswith("--importers=") for a in argv):
        from bench.fuzz import bench_main

        return bench_main(argv)
    parser = argparse.ArgumentParser(prog="sheer bench fuzz", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--importers", type=int, required=True, metavar="N", help="damaged files per format")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--formats", default=",".join(FORMATS), help="comma-separated (default: all)")
    parser.add_argument("--no-assets", action="store_true", help="generated seeds only (not the sample assets)")
    parser.add_argument("--keep", default=None, metavar="DIR", help="save the files of defects here")
    parser.add_argument("--hang-s", type=float, default=30.0, help="a loader call longer than this is a hang")
    parser.add_argument("--json", action="store_true", help="print JSON (the only format)")
    args = parser.parse_args(argv)
    formats = tuple(f.strip() for f in args.formats.split(",") if f.strip())
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        parser.error(f"unknown format {unknown[0]!r} (known: {', '.join(FORMATS)})")
    result = run_importers(args.importers, args.seed, formats, assets=not args.no_assets, hang_s=args.hang_s,
                           keep=args.keep)
    result["pid"] = os.getpid()
    json.dump(result, sys.stdout, indent=2)
    print()
    return 0 if result["defects"] == 0 else 1
