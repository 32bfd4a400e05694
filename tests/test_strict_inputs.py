"""Every file Sheer reads is untrusted: malformed inputs to every loader raise a SheerError subclass with a
message naming the file, never another exception (and never hang or allocate without bound).

Loaders covered: material libraries (km.Library), measurement files (km.measurements), head metadata
sidecars, head meshes and textures (painting.head), photographs and masks (capture), camera files
(capture.camera), HDR environments (render.lights), looks (painting.looks), thickness maps, face
folders, the kiosk's settings. Projects have their own files (tests/project/). Every loader and the sample
head are required: a missing one fails its tests, it does not skip them.

Cases a loader does not handle yet are marked ``xfail(strict=True)`` with the reason: they flip to
failures (so the mark must be removed) as soon as the loader is fixed.
"""

from __future__ import annotations

import json
import struct
import zlib
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from core.errors import SheerError

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path


def _noise(n: int) -> bytes:
    """Deterministic random bytes (the same inputs on every run)."""
    return np.random.default_rng(n).bytes(n)


LAX = "loader too lax (reported by the project engineer): "


def edited(valid: dict[str, Any], *drop: str, **changes: Any) -> bytes:
    """The JSON of ``valid`` without the fields ``drop`` and with ``changes`` (a new field goes last)."""
    data = {key: value for key, value in valid.items() if key not in drop}
    data.update(changes)
    return json.dumps(data).encode()


def png_header_only(width: int, height: int) -> bytes:
    """A PNG that declares width × height but holds no pixel data (a decompression-bomb header)."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b"")


def raises_clean(func: Callable[[], Any], *fragments: str) -> SheerError:
    """``func()`` raises a SheerError (not anything else) whose message contains ``fragments``."""
    try:
        func()
    except SheerError as exc:
        message = str(exc)
        assert message.strip(), "empty error message"
        for fragment in fragments:
            assert fragment in message, f"{fragment!r} not in {message!r}"
        return exc
    except Exception as exc:  # the point of this file: anything else is a bug
        pytest.fail(f"raised {type(exc).__name__} instead of a SheerError: {exc}")
    pytest.fail("accepted a malformed input")


DEEP_JSON = "[" * 50_000 + "]" * 50_000
TINY_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n"


# ------------------------------------------------------------------------------------------- libraries


#: A valid (empty) library file, which each case below breaks in one way.
LIBRARY = {"format": "sheer.materials", "schema_version": 1, "name": "x", "materials": []}
LIBRARY_CASES = {
    "not json": (b"{not json", "library"),
    "binary": (_noise(64) + b"\xff", "library"),
    "deeply nested": (DEEP_JSON.encode(), "nested"),
    "NaN": (edited(LIBRARY, materials=float("nan")), "NaN"),
    "newer": (edited(LIBRARY, schema_version=99), "newer"),
    "wrong type": (edited(LIBRARY, materials={}), "materials"),
    "bad material": (edited(LIBRARY, materials=[{"name": 1}]), "materials[0]"),
    "array": (b"[]", "library"),
}


@pytest.mark.parametrize("case", sorted(LIBRARY_CASES))
def test_material_library_files(case: str, tmp_path: Path) -> None:
    import km

    data, fragment = LIBRARY_CASES[case]
    path = tmp_path / "lib.json"
    path.write_bytes(data)
    raises_clean(lambda: km.Library.load(path), fragment)


def test_material_library_size_cap(tmp_path: Path) -> None:
    import km
    from km import library

    path = tmp_path / "huge.json"
    with open(path, "wb") as fh:
        fh.truncate(library.MAX_FILE_BYTES + 10)
    raises_clean(lambda: km.Library.load(path), "huge.json")


def test_material_library_missing_file(tmp_path: Path) -> None:
    import km

    with pytest.raises((SheerError, FileNotFoundError)):
        km.Library.load(tmp_path / "missing.json")


# ------------------------------------------------------------------------------------------- measurements


MEASUREMENT_CASES = {
    "binary.csv": _noise(256) + b"\x00\xff",
    "empty.csv": b"",
    "no columns.csv": b"hello\nworld\n",
    "bad cgats.txt": b"CGATS.17\nBEGIN_DATA_FORMAT\nSAMPLE_ID SPECTRAL_400\nEND_DATA_FORMAT\nBEGIN_DATA\n1 abc\nEND_DATA\n",
    "cgats no data.txt": b"CGATS.17\nBEGIN_DATA_FORMAT\n",
}


@pytest.mark.parametrize("name", sorted(MEASUREMENT_CASES))
def test_measurement_files(name: str, tmp_path: Path) -> None:
    from km.measurement_files import import_file

    path = tmp_path / name
    path.write_bytes(MEASUREMENT_CASES[name])
    try:
        result = import_file(path, thickness_mm=0.15)
    except SheerError as exc:
        assert str(exc).strip()
        return
    except Exception as exc:
        pytest.fail(f"raised {type(exc).__name__} instead of a SheerError: {exc}")
    assert not result.accepted and result.rejected  # nothing usable: reported row by row


def test_measurement_rows_with_nan_are_rejected_with_line_numbers(tmp_path: Path) -> None:
    from km.measurement_files import import_file

    path = tmp_path / "m.csv"
    path.write_text("wavelength,R_inf,R,Rg\n400,nan,0.2,0.0\n500,0.5,0.2,x\n")
    try:
        result = import_file(path, thickness_mm=0.15)
    except SheerError:
        return
    assert not result.accepted
    assert any("line 2" in str(r) for r in result.rejected)


def test_measurement_size_cap(tmp_path: Path) -> None:
    from km.measurement_files import import_file
    from km.measurements import MAX_IMPORT_BYTES

    path = tmp_path / "big.csv"
    with open(path, "wb") as fh:
        fh.truncate(MAX_IMPORT_BYTES + 10)
    raises_clean(lambda: import_file(path, thickness_mm=0.15), "big.csv")


# ------------------------------------------------------------------------------------------- head metadata


def _head(tmp_path: Path, sidecar: bytes | None = None) -> Path:
    mesh = tmp_path / "m.obj"
    mesh.write_text(TINY_OBJ)
    if sidecar is not None:
        (tmp_path / "m.obj.sheer-head.json").write_bytes(sidecar)
    return mesh


#: A valid head metadata sidecar, which each case below but the first three breaks in one way.
SIDECAR = {"schema_version": 1, "name": "x", "mm_per_unit": 1}
SIDECAR_CASES = {
    "not json": (b"{", "cannot read head metadata"),
    "not utf-8": (b"\xff\xfe", "cannot read head metadata"),
    "array": (b"[]", "JSON object"),
    "no version": (edited(SIDECAR, "schema_version"), "schema_version"),
    "newer": (edited(SIDECAR, schema_version=2), "schema_version"),
    "NaN scale": (edited(SIDECAR, mm_per_unit=float("nan")), "mm_per_unit"),
    "negative scale": (edited(SIDECAR, mm_per_unit=-3), "mm_per_unit"),
    "missing name": (edited(SIDECAR, "name"), "name"),
    "unknown field": (edited(SIDECAR, evil=1), "evil"),
    "bad landmark": (edited(SIDECAR, landmarks={"a": [1, 2]}), "landmarks.a"),
    "zero normal": (edited(SIDECAR, midplane_normal=[0, 0, 0]), "midplane_normal"),
    "texture type": (edited(SIDECAR, albedo=3), "albedo"),
}


@pytest.mark.parametrize("case", sorted(SIDECAR_CASES))
def test_head_metadata_sidecars(case: str, tmp_path: Path) -> None:
    from painting.head import load_metadata

    data, fragment = SIDECAR_CASES[case]
    mesh = _head(tmp_path, data)
    raises_clean(lambda: load_metadata(mesh), "m.obj.sheer-head.json", fragment)


@pytest.mark.parametrize("case", ["deep", "types"])
def test_head_metadata_sidecars_deep_and_types(case: str, tmp_path: Path) -> None:
    from painting.head import load_metadata

    data = DEEP_JSON.encode() if case == "deep" else \
        b'{"schema_version": 1, "name": ["x"], "mm_per_unit": true}'
    mesh = _head(tmp_path, data)
    raises_clean(lambda: load_metadata(mesh), "m.obj.sheer-head.json")


# ------------------------------------------------------------------------------------------- meshes


MESH_CASES = {
    "garbage.glb": b"glTF" + bytes(range(256)) * 2,
    "random.glb": _noise(300),
    "empty.obj": b"",
    "no uv.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    "nan.obj": TINY_OBJ.replace("v 0 0 0", "v nan 0 0", 1).encode(),
    "bad index.obj": TINY_OBJ.replace("3/3", "99/3").encode(),
    "huge.ply": b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\nend_header\n",
    "text.ply": b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\nabc\n",
    "binary.obj": _noise(400),
}


@pytest.mark.parametrize("name", sorted(MESH_CASES))
def test_meshes(name: str, tmp_path: Path) -> None:
    import warnings

    from painting.head import load_mesh_arrays

    path = tmp_path / name
    path.write_bytes(MESH_CASES[name])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # trimesh's own numpy warnings on bad data
        raises_clean(lambda: load_mesh_arrays(path), name)


def test_truncated_sample_head(tmp_path: Path) -> None:
    from core.assets import find_asset
    from painting.head import load_mesh_arrays

    glb = find_asset("heads/lee-perry-smith/head.glb").read_bytes()
    for cut in (20, len(glb) // 3, len(glb) - 7):
        path = tmp_path / f"cut{cut}.glb"
        path.write_bytes(glb[:cut])
        raises_clean(lambda p=path: load_mesh_arrays(p), path.name)


# ------------------------------------------------------------------------------------------- images


IMAGE_CASES = {
    "garbage.png": _noise(128),
    "empty.png": b"",
    "truncated.png": None,  # filled below: a real PNG cut short
    "text.jpg": b"this is not a jpeg",
}


def _truncated_png() -> bytes:
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray((np.random.default_rng(0).random((64, 64, 3)) * 255).astype(np.uint8)).save(buf, "PNG")
    return buf.getvalue()[:300]


@pytest.mark.parametrize("name", sorted(IMAGE_CASES))
def test_head_textures(name: str, tmp_path: Path) -> None:
    from painting.head import load_head

    data = IMAGE_CASES[name] if IMAGE_CASES[name] is not None else _truncated_png()
    (tmp_path / name).write_bytes(data)
    sidecar = f'{{"schema_version": 1, "name": "x", "mm_per_unit": 1, "albedo": "{name}"}}'.encode()
    mesh = _head(tmp_path, sidecar)
    raises_clean(lambda: load_head(mesh), name)


def test_head_texture_missing(tmp_path: Path) -> None:
    from painting.head import load_head

    mesh = _head(tmp_path, b'{"schema_version": 1, "name": "x", "mm_per_unit": 1, "albedo": "gone.png"}')
    raises_clean(lambda: load_head(mesh), "gone.png", "not found")


def _bomb_png(tmp_path: Path) -> Path:
    path = tmp_path / "bomb.png"
    path.write_bytes(png_header_only(30_000, 30_000))
    return path


def test_head_texture_decompression_bomb(tmp_path: Path) -> None:
    from painting.head import load_head

    _bomb_png(tmp_path)
    mesh = _head(tmp_path, b'{"schema_version": 1, "name": "x", "mm_per_unit": 1, "albedo": "bomb.png"}')
    raises_clean(lambda: load_head(mesh), "bomb.png")


def test_head_texture_over_the_side_cap(tmp_path: Path) -> None:
    from painting.head import MAX_TEXTURE_SIDE, load_head

    (tmp_path / "wide.png").write_bytes(png_header_only(MAX_TEXTURE_SIDE + 1, 1))
    mesh = _head(tmp_path, b'{"schema_version": 1, "name": "x", "mm_per_unit": 1, "albedo": "wide.png"}')
    raises_clean(lambda: load_head(mesh), "wide.png", "limit")


@pytest.mark.parametrize("loader", ["photo", "mask"])
def test_capture_images_garbage(loader: str, tmp_path: Path) -> None:
    from capture.mask import load_mask
    from capture.pipeline import read_photo

    path = tmp_path / "x.png"
    path.write_bytes(_noise(64))
    if loader == "photo":
        raises_clean(lambda: read_photo(path), "x.png")
    else:
        raises_clean(lambda: load_mask(path, (4, 4)), "x.png")


@pytest.mark.parametrize("loader", ["photo", "mask"])
def test_capture_images_decompression_bomb(loader: str, tmp_path: Path) -> None:
    from capture.mask import load_mask
    from capture.pipeline import read_photo

    path = _bomb_png(tmp_path)
    if loader == "photo":
        raises_clean(lambda: read_photo(path), "bomb.png")
    else:
        raises_clean(lambda: load_mask(path, (4, 4)), "bomb.png")


# ------------------------------------------------------------------------------------------- camera files


CAMERA_CASES = {
    "not json": b"{",
    "array": b"[]",
    "NaN matrix": b'{"P": [[NaN, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]}',
    "short matrix": b'{"P": [[1, 0, 0], [0, 1, 0]]}',
    "strings": b'{"P": "identity"}',
}


@pytest.mark.parametrize("case", sorted(CAMERA_CASES))
def test_camera_files(case: str, tmp_path: Path) -> None:
    from capture import camera

    path = tmp_path / "cam.json"
    path.write_bytes(CAMERA_CASES[case])
    raises_clean(lambda: camera.load_camera(path, 64, 64), "cam.json")


def test_camera_file_deeply_nested(tmp_path: Path) -> None:
    from capture import camera

    path = tmp_path / "cam.json"
    path.write_text(DEEP_JSON)
    raises_clean(lambda: camera.load_camera(path, 64, 64), "cam.json")


def test_point_files(tmp_path: Path) -> None:
    from capture import camera

    path = tmp_path / "pts.json"
    path.write_bytes(b'{"points": [{"image": [1, "x"], "mesh": [0, 0, 0]}]}')
    raises_clean(lambda: camera.load_points(path, 64, 64), "pts.json")


# ------------------------------------------------------------------------------------------- environments


@pytest.mark.parametrize("data", [b"\x76\x2f\x31\x01" + bytes(100), b"not an exr", b""])
def test_environment_exr(data: bytes, tmp_path: Path) -> None:
    from render import lights

    path = tmp_path / "env.exr"
    path.write_bytes(data)
    raises_clean(lambda: lights.read_exr_rgb(path), "env.exr")


# ------------------------------------------------------------------------------------------- looks


LOOK_CASES = {
    "not json": (b"{", "cannot read look"),
    "array": (b"[]", "JSON object"),
    "newer": (b'{"schema_version": 99}', "schema_version"),
    "binary": (_noise(64), "look"),
    "layers not a list": (b'{"schema_version": 1, "layers": 3}', "layers"),
    "no material": (b'{"schema_version": 1, "layers": [{"name": "x"}]}', "layers[0]"),
    "unknown stroke field": (b'{"schema_version": 1, "layers": [{"material": "m", "strokes": [{"points": ["chin"], '
                             b'"evil": 1}]}]}', "evil"),
    "empty points": (b'{"schema_version": 1, "layers": [{"material": "m", "strokes": [{"points": []}]}]}', "points"),
}
LOOK_MORE = {
    "deeply nested": DEEP_JSON.encode(),
    "strokes not a list": b'{"schema_version": 1, "layers": [{"material": "m", "strokes": 5}]}',
    "radius a string": b'{"schema_version": 1, "layers": [{"material": "m", "strokes": [{"points": ["chin"], '
                       b'"radius_mm": "big"}]}]}',
    "NaN strength": b'{"schema_version": 1, "layers": [{"material": "m", "strokes": [{"points": ["chin"], '
                    b'"strength": NaN}]}]}',
}


@pytest.mark.parametrize("case", sorted(LOOK_CASES))
def test_look_files(case: str, tmp_path: Path) -> None:
    from painting import looks

    data, fragment = LOOK_CASES[case]
    path = tmp_path / "look.json"
    path.write_bytes(data)
    raises_clean(lambda: looks.load_look(path), "look.json", fragment)


@pytest.mark.parametrize("case", sorted(LOOK_MORE))
def test_look_files_deep_and_stroke_values(case: str, tmp_path: Path) -> None:
    from painting import looks

    path = tmp_path / "look.json"
    path.write_bytes(LOOK_MORE[case])
    raises_clean(lambda: looks.load_look(path), "look.json")


# ------------------------------------------------------------------------------------------- thickness maps


def _exr(arr: np.ndarray) -> bytes:
    from painting.maps_io import encode_exr

    return encode_exr(arr)


MAP_CASES = {
    "garbage.png": (_noise(200), ""),
    "garbage.exr": (b"\x76\x2f\x31\x01" + _noise(200), ""),
    "nan.exr": (_exr(np.full((64, 64), np.nan, np.float32)), ""),
    "negative.exr": (_exr(np.full((64, 64), -1.0, np.float32)), ""),
    "wrong size.exr": (_exr(np.zeros((32, 64), np.float32)), ""),
    "wide.png": (png_header_only(20_000, 1), ""),
}


@pytest.mark.parametrize("name", sorted(MAP_CASES))
def test_thickness_map_import(name: str, tmp_path: Path) -> None:
    from painting import maps_io

    path = tmp_path / name
    path.write_bytes(MAP_CASES[name][0])
    raises_clean(lambda: maps_io.read_thickness(path, expected_shape=(64, 64), scale_um=1.0), name)


def test_thickness_map_decompression_bomb(tmp_path: Path) -> None:
    from painting import maps_io

    path = _bomb_png(tmp_path)
    raises_clean(lambda: maps_io.read_thickness(path, expected_shape=(64, 64), scale_um=1.0), "bomb.png")


# ------------------------------------------------------------------------------------------- face folders


def _face_folder(tmp_path: Path, face_json: bytes) -> Path:
    import io

    import OpenEXR

    folder = tmp_path / "face"
    folder.mkdir()
    (folder / "face.json").write_bytes(face_json)
    buf = io.BytesIO()
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"RGB": np.ones((8, 8, 3), np.float32)}).write(buf)
    (folder / "detail.exr").write_bytes(buf.getvalue())
    return folder


def _face_json(case: str, version: int) -> bytes:
    return {"not json": b"{", "newer": b'{"schema_version": 999}', "array": b"[]", "deep": DEEP_JSON.encode(),
            "no phong": f'{{"schema_version": {version}}}'.encode(),
            "bad phong": f'{{"schema_version": {version}, "phong": {{"x": "y"}}}}'.encode()}[case]


@pytest.mark.parametrize("case", ["not json", "newer"])
def test_face_folders(case: str, tmp_path: Path) -> None:
    from capture import face

    folder = _face_folder(tmp_path, _face_json(case, face.FACE_SCHEMA_VERSION))
    raises_clean(lambda: face.load_face(folder), "face")


@pytest.mark.parametrize("case", ["array", "deep", "no phong", "bad phong"])
def test_face_folders_malformed_json(case: str, tmp_path: Path) -> None:
    from capture import face

    folder = _face_folder(tmp_path, _face_json(case, face.FACE_SCHEMA_VERSION))
    raises_clean(lambda: face.load_face(folder), "face")


# ------------------------------------------------------------------------------------------- kiosk settings


@pytest.mark.parametrize("case", ["deep", "nan", "garbage"])
def test_kiosk_config_falls_back_to_sane_defaults(case: str, tmp_path: Path) -> None:
    """The kiosk's config is read unattended: a broken file must give finite, bounded settings."""
    from app.kiosk import window as kiosk

    path = tmp_path / "kiosk.json"
    path.write_bytes({"deep": DEEP_JSON.encode(), "nan": b'{"idle_seconds": NaN, "look_seconds": Infinity}',
                      "garbage": _noise(100)}[case])
    try:
        cfg = kiosk.KioskConfig.load(path)
    except SheerError:
        return
    except Exception as exc:
        pytest.fail(f"raised {type(exc).__name__}: {exc}")
    assert 5.0 <= cfg.idle_seconds <= 3600.0 and 2.0 <= cfg.look_seconds <= 120.0


def test_thickness_map_exr_too_large_is_refused_from_its_header(tmp_path: Path) -> None:
    from painting import maps_io

    path = tmp_path / "wide.exr"
    path.write_bytes(_exr(np.zeros((1, maps_io.MAX_SIDE + 1), np.float32)))
    raises_clean(lambda: maps_io.read_thickness(path, expected_shape=(64, 64)), "wide.exr", "limit")


def test_environment_with_nan_pixels_is_refused(tmp_path: Path) -> None:
    import OpenEXR

    from render import lights
    from render.errors import RenderError

    rgb = np.ones((8, 16, 3), dtype=np.float32)
    rgb[2, 3, 1] = np.nan
    rgb[4, 5, 0] = np.inf
    path = tmp_path / "nan.exr"
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, {"RGB": rgb}).write(str(path))
    with pytest.raises(RenderError, match="2 pixel"):
        lights.read_exr_rgb(path)
    rgb[:] = -0.5  # compression ringing: clipped to 0, not refused
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, {"RGB": rgb}).write(str(path))
    assert float(lights.read_exr_rgb(path).min()) == 0.0
