"""Thickness maps inside a project: EXR float32 (exact) or 16-bit PNG with a scale, in memory.

A thickness map is float32 (H, W), micrometres, finite and ≥ 0, top row first (texel row ``i`` covers
``v ∈ [i/H, (i+1)/H)``, see :mod:`painting.head`).

- ``exr-float32``: one ``Y`` channel of 32-bit floats, OpenEXR's own ZIP compression; bit-exact.
- ``png16``: a greyscale 16-bit PNG; thickness (µm) = value × ``scale_um``. Quantised: the step is
  ``scale_um`` µm (the writer picks ``max / 65535``).

Encoding and decoding go through OpenEXR's and Pillow's in-memory streams (no temporary files:
loading writes nothing anywhere). Decoding reads the header first and refuses a map whose size is not
the expected one or is over :data:`MAX_MAP_SIDE` before any pixel is decompressed; every decoding
failure becomes a :class:`ProjectError` naming the entry.
"""

from __future__ import annotations

import contextlib
import fcntl
import io
import os
import sys
import threading
import warnings
from typing import TYPE_CHECKING

import numpy as np

from project.errors import ProjectError

if TYPE_CHECKING:
    from collections.abc import Iterator

#: Largest side of a thickness map (texels).
MAX_MAP_SIDE = 8192
#: Largest thickness a map may hold (µm), as ``painting.document.MAX_THICKNESS_UM``.
MAX_THICKNESS_UM = 10_000.0
#: The two encodings a layer map may use.
ENCODINGS = ("exr-float32", "png16")
_EXR_MAGIC = b"\x76\x2f\x31\x01"
_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


_FD_LOCK = threading.Lock()


@contextlib.contextmanager
def _library_output() -> Iterator[list[str]]:
    """Capture what the OpenEXR library prints on file descriptors 1 and 2 during the block.

    The binding reports some decoding failures only as a printed warning ("Exception raised reading
    pixel data", with partly decoded pixels) and its C core prints ``EXR_ERR_*`` lines: they would
    corrupt ``--json`` output and the one-line messages of ``sheer project validate``, and the
    warning is our only sign that the pixels are not trustworthy. The pipes are non-blocking, so a
    chatty library cannot block; at most the first 64 KiB are kept. The yielded list receives the
    text after the block.
    """
    captured: list[str] = []
    with _FD_LOCK:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        saved: list[tuple[int, int, int]] = []  # (fd, saved copy, pipe read end)
        try:
            for fd in (1, 2):
                read_end, write_end = os.pipe()
                fcntl.fcntl(write_end, fcntl.F_SETFL, fcntl.fcntl(write_end, fcntl.F_GETFL) | os.O_NONBLOCK)
                fcntl.fcntl(read_end, fcntl.F_SETFL, fcntl.fcntl(read_end, fcntl.F_GETFL) | os.O_NONBLOCK)
                saved.append((fd, os.dup(fd), read_end))
                os.dup2(write_end, fd)
                os.close(write_end)
            yield captured
        finally:
            for fd, copy, read_end in saved:
                os.dup2(copy, fd)
                os.close(copy)
                chunks = []
                with contextlib.suppress(BlockingIOError, OSError):
                    while chunk := os.read(read_end, 65536):
                        chunks.append(chunk)
                        if sum(map(len, chunks)) >= 65536:
                            break
                os.close(read_end)
                captured.append(b"".join(chunks).decode("utf-8", "replace"))


def _library_complaint(captured: list[str]) -> str | None:
    text = "\n".join(captured)
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    bad = [line for line in lines if "EXR_ERR" in line or "Exception" in line or "rror" in line]
    return bad[0][:160] if bad else None


def encode_exr(thickness: np.ndarray) -> bytes:
    """EXR bytes of a float32 (H, W) map (µm), one ``Y`` channel, ZIP compression."""
    import OpenEXR

    arr = np.ascontiguousarray(thickness, dtype=np.float32)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    buf = io.BytesIO()
    OpenEXR.File(header, {"Y": arr}).write(buf)
    return buf.getvalue()


def png16_scale(thickness: np.ndarray) -> float:
    """The scale (µm per count) the PNG writer uses: the maximum / 65535 (1.0 for an empty map)."""
    peak = float(np.max(thickness)) if thickness.size else 0.0
    return peak / 65535.0 if peak > 0 else 1.0


def encode_png16(thickness: np.ndarray, scale_um: float) -> bytes:
    """16-bit greyscale PNG bytes: value = round(thickness / scale_um), clipped to [0, 65535]."""
    from PIL import Image

    counts = np.clip(np.rint(np.asarray(thickness, dtype=np.float64) / scale_um), 0, 65535).astype(np.uint16)
    buf = io.BytesIO()
    Image.fromarray(counts).save(buf, format="PNG", compress_level=6)
    return buf.getvalue()


def check_thickness(arr: np.ndarray, where: str, shape: tuple[int, int] | None = None) -> np.ndarray:
    """Check a thickness map (dtype, shape, finite, ≥ 0) and return it as C-contiguous float32."""
    if not isinstance(arr, np.ndarray):
        raise ProjectError(f"{where}: not an array")
    if arr.dtype != np.float32:
        raise ProjectError(f"{where}: dtype {arr.dtype}, float32 expected")
    if arr.ndim != 2:
        raise ProjectError(f"{where}: {arr.ndim}-D array, a 2-D (height, width) map expected")
    if shape is not None and arr.shape != tuple(shape):
        raise ProjectError(f"{where}: size {arr.shape[1]}×{arr.shape[0]} does not match the layer's "
                           f"resolution {shape[1]}×{shape[0]}")
    finite = np.isfinite(arr)
    if not finite.all():
        bad = int(arr.size - np.count_nonzero(finite))
        raise ProjectError(f"{where}: {bad} texel(s) are NaN or infinite")
    if arr.size and float(arr.min()) < 0:
        raise ProjectError(f"{where}: negative thickness ({float(arr.min())} µm)")
    if arr.size and float(arr.max()) > MAX_THICKNESS_UM:
        raise ProjectError(f"{where}: thickness {float(arr.max())} µm over the {MAX_THICKNESS_UM:g} µm limit")
    return np.ascontiguousarray(arr)


def _check_size(where: str, width: int, height: int, shape: tuple[int, int]) -> None:
    if width <= 0 or height <= 0 or width > MAX_MAP_SIDE or height > MAX_MAP_SIDE:
        raise ProjectError(f"{where}: map size {width}×{height} outside 1..{MAX_MAP_SIDE}")
    if (height, width) != tuple(shape):
        raise ProjectError(f"{where}: size {width}×{height} does not match the layer's resolution "
                           f"{shape[1]}×{shape[0]}")


def decode_exr(data: bytes, where: str, shape: tuple[int, int]) -> np.ndarray:
    """Decode an ``exr-float32`` map, checking header, size ``shape`` = (H, W), dtype and values."""
    import OpenEXR

    if not data.startswith(_EXR_MAGIC):
        raise ProjectError(f"{where}: not an OpenEXR file")
    try:
        with _library_output() as out:
            head = OpenEXR.File(io.BytesIO(data), header_only=True)
        complaint = _library_complaint(out)
        if complaint:
            raise ProjectError(f"{where}: damaged EXR header ({complaint})")
        parts = head.parts
        if len(parts) != 1:
            raise ProjectError(f"{where}: {len(parts)} parts in the EXR file, 1 expected")
        header = head.header()
        (x0, y0), (x1, y1) = (np.asarray(v, dtype=np.int64) for v in header["dataWindow"])
        channels = [c.name for c in header["channels"]]
    except ProjectError:
        raise
    except Exception as exc:  # the binding raises RuntimeError, ValueError, KeyError... for bad files
        raise ProjectError(f"{where}: cannot read the EXR header ({exc})") from None
    if channels != ["Y"]:
        raise ProjectError(f"{where}: EXR channels {channels}, exactly ['Y'] expected")
    if (x0, y0) != (0, 0):
        raise ProjectError(f"{where}: EXR data window does not start at (0, 0)")
    _check_size(where, int(x1 - x0 + 1), int(y1 - y0 + 1), shape)
    try:
        with _library_output() as out:
            pixels = OpenEXR.File(io.BytesIO(data), separate_channels=True).channels()["Y"].pixels
    except Exception as exc:
        raise ProjectError(f"{where}: cannot decode the EXR pixels ({exc})") from None
    complaint = _library_complaint(out)
    if complaint:
        raise ProjectError(f"{where}: damaged EXR pixel data ({complaint})")
    if not isinstance(pixels, np.ndarray) or pixels.dtype != np.float32:
        raise ProjectError(f"{where}: EXR channel 'Y' is {getattr(pixels, 'dtype', type(pixels))}, "
                           "32-bit float expected")
    return check_thickness(np.array(pixels, dtype=np.float32, copy=True), where, shape)


def decode_png16(data: bytes, where: str, shape: tuple[int, int], scale_um: float) -> np.ndarray:
    """Decode a ``png16`` map to float32 µm (value × ``scale_um``), checking size and mode first."""
    from PIL import Image

    if not data.startswith(_PNG_MAGIC):
        raise ProjectError(f"{where}: not a PNG file")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(io.BytesIO(data), formats=["PNG"]) as im:
                width, height = im.size
                _check_size(where, width, height, shape)
                if im.mode not in ("I;16", "I;16B", "I;16L"):
                    raise ProjectError(f"{where}: PNG mode {im.mode}, 16-bit greyscale expected")
                im.load()
                counts = np.asarray(im)
    except ProjectError:
        raise
    except Exception as exc:  # Pillow raises OSError, SyntaxError, ValueError... for bad files
        raise ProjectError(f"{where}: cannot decode the PNG ({exc})") from None
    if counts.shape != tuple(shape):
        raise ProjectError(f"{where}: decoded PNG has shape {counts.shape}, {tuple(shape)} expected")
    thickness = (counts.astype(np.float64) * scale_um).astype(np.float32)
    return check_thickness(thickness, where, shape)
