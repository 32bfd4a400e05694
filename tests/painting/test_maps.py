"""Thickness maps and masks in and out: 16-bit PNG with scale metadata, 32-bit EXR, size checks."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pytest
from PIL import Image

from painting.maps_io import MapError, read_mask, read_thickness, write_mask, write_thickness
from tests.painting.helpers import make_doc

if TYPE_CHECKING:
    from pathlib import Path


def _map(shape=(64, 128)) -> np.ndarray:
    rng = np.random.default_rng(1)
    return (rng.random(shape) * 37.5).astype(np.float32)


def test_png16_round_trip_with_scale_metadata(tmp_path: Path) -> None:
    values = _map()
    path = tmp_path / "t.png"
    scale = write_thickness(path, values, scale_um=40.0)
    assert scale == 40.0
    with Image.open(path) as im:
        assert im.mode.startswith("I;16") and im.text["sheer:scale_um"] == "40.0"
    back = read_thickness(path, expected_shape=values.shape)
    assert back.dtype == np.float32
    assert np.abs(back - values).max() <= 40.0 / 65535 / 2 + 1e-5
    with pytest.raises(MapError, match="expected"):
        read_thickness(path, expected_shape=(128, 128))
    with pytest.raises(MapError, match="does not fit"):
        write_thickness(tmp_path / "u.png", values, scale_um=10.0)


def test_exr_round_trip_is_exact(tmp_path: Path) -> None:
    values = _map((32, 32))
    path = tmp_path / "t.exr"
    write_thickness(path, values)
    assert np.array_equal(read_thickness(path, expected_shape=(32, 32)), values)


def test_masks_and_bad_files(tmp_path: Path) -> None:
    mask = np.zeros((16, 16), bool)
    mask[4:9, 2:7] = True
    for ext in (".png", ".exr"):
        write_mask(tmp_path / f"m{ext}", mask)
        assert np.array_equal(read_mask(tmp_path / f"m{ext}", expected_shape=(16, 16)) > 0.5, mask)
    with pytest.raises(MapError, match="unsupported"):
        write_thickness(tmp_path / "t.tif", _map())
    with pytest.raises(MapError, match="finite"):
        write_thickness(tmp_path / "t.exr", np.full((4, 4), np.nan, np.float32))
    (tmp_path / "junk.png").write_bytes(b"not a png")
    with pytest.raises(MapError, match="junk.png"):
        read_thickness(tmp_path / "junk.png", scale_um=1.0)
    Image.fromarray(np.zeros((8, 8), np.uint8)).save(tmp_path / "plain.png")
    with pytest.raises(MapError, match="scale"):
        read_thickness(tmp_path / "plain.png")
    assert not list(tmp_path.glob(".*.tmp"))  # atomic writes leave no temporary files


def test_document_export_import_layer(tmp_path: Path) -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1")
    doc.fill(layer, 12.5)
    doc.export_layer(layer, tmp_path / "f.exr")
    doc.export_layer(layer, tmp_path / "f.png")
    other = doc.add_layer("Blush 1")
    doc.import_layer(other, tmp_path / "f.exr")
    assert np.array_equal(other.thickness, layer.thickness)
    doc.undo()
    assert not other.thickness.any()
    doc.import_layer(other, tmp_path / "f.png")
    assert np.allclose(other.thickness, layer.thickness, atol=1e-3)
    small = tmp_path / "small.exr"
    write_thickness(small, np.zeros((64, 64), np.float32))
    before = other.thickness.copy()
    with pytest.raises(MapError, match="expected 256×256"):
        doc.import_layer(other, small)
    assert np.array_equal(other.thickness, before)


def _png_header(width: int, height: int) -> bytes:
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b"")


def test_huge_images_are_refused_cleanly(tmp_path: Path) -> None:
    from painting.head import HeadError, _read_image

    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(_png_header(30_000, 30_000))
    with pytest.raises(MapError, match="bomb.png"):
        read_thickness(bomb, scale_um=1.0)
    with pytest.raises(MapError, match="bomb.png"):
        read_mask(bomb)
    with pytest.raises(HeadError, match="bomb.png"):
        _read_image(bomb, "RGB")
