"""The one thickness-map codec: 32-bit float EXR and 16-bit PNG, in memory and in files; masks too.

Used by painting for layer import and export (``Document.import_layer`` / ``export_layer``, the
studio's map export) and by the ``.sheer`` format for its ``layers/NNN.exr|png`` entries
(:mod:`project.io`, which turns a :class:`MapError` into a ``ProjectError``).

A thickness map is float32 (H, W) in micrometres, finite, in [0, :data:`MAX_THICKNESS_UM`], top row
first: texel row ``i`` covers ``v ∈ [i/H, (i+1)/H)`` (see :mod:`painting.head`). A mask is float32
(H, W) in [0, 1].

- EXR: exactly one channel ``Y`` of 32-bit floats, OpenEXR's ZIP compression; bit-exact. Files carry
  the header attribute ``sheer:unit`` = ``um`` (thickness) or ``sheer:kind`` = ``mask``.
- PNG: 16-bit greyscale counts; thickness (µm) = count × ``um_per_count``, the writer's choice being
  the map's maximum / 65535 (:func:`png16_um_per_count`). A file stores ``scale_um`` = 65535 ×
  ``um_per_count`` (the thickness of count 65535) in the text chunk ``sheer:scale_um`` beside
  ``sheer:unit`` = ``um``; a project stores ``um_per_count`` in its ``project.json``. Files may also be
  8-bit greyscale when read (count × ``scale_um`` / 255; white = 1 for masks).

Decoding trusts nothing: the magic bytes, then the header, are checked first, and a map wider or taller
than :data:`MAX_SIDE` texels, or not of the expected size, is refused before any pixel is decompressed.
Every failure is a :class:`MapError` whose message starts with ``where`` (the file; for a project, the
project file and its entry). Files are written atomically (:mod:`core.atomicio`) and read only when
at most :data:`MAX_FILE_BYTES` long. Encoding and decoding go through in-memory streams: reading a map
writes nothing anywhere.
"""

from __future__ import annotations

import io
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from core.atomicio import atomic_write_bytes
from core.errors import SheerError
from core.files import read_bounded
from core.native_output import captured_output

if TYPE_CHECKING:
    from collections.abc import Mapping

#: PNG text chunk holding the thickness (µm) of count 65535 (of 255 in an 8-bit file).
SCALE_KEY = "sheer:scale_um"
#: PNG text chunk and EXR header attribute naming the unit of a thickness map (``um``).
UNIT_KEY = "sheer:unit"
#: Largest side of a map (texels): the largest layer resolution (``painting.atlas.MAX_RESOLUTION``).
MAX_SIDE = 8192
#: Largest thickness a map or a layer may hold (µm); the document checks its edits against it too.
MAX_THICKNESS_UM = 10_000.0
#: A map file longer than this (bytes) is refused before it is read: an 8192² float32 map is 256 MiB
#: uncompressed, the same cap as one entry of a project container.
MAX_FILE_BYTES = 512 * 1024**2
#: Largest count of a 16-bit PNG.
PNG16_MAX = 65535
_EXR_MAGIC = b"\x76\x2f\x31\x01"
_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
_PNG16_MODES = ("I;16", "I;16B", "I;16L")
_PNG8_MODES = ("L", "P", "1")


class MapError(SheerError, ValueError):
    """A map that cannot be written or read (format, size, values); the message names the file (and entry)."""


# ---------------------------------------------------------------------------------------------- checks


def check_thickness(arr: np.ndarray, where: str, shape: tuple[int, int] | None = None) -> np.ndarray:
    """Check a thickness map and return it as C-contiguous float32.

    Args:
        arr: the map, float32 (H, W) in µm.
        where: names the map in messages (a file, or a project file and entry).
        shape: the expected (H, W) in texels, or None for any non-empty size.

    Raises:
        MapError: not a float32 2-D array, empty, of another size, or a texel NaN, infinite, < 0 or
            > :data:`MAX_THICKNESS_UM`.
    """
    arr = _check_grid(arr, where, shape)
    if float(arr.min()) < 0:
        raise MapError(f"{where}: negative thickness ({float(arr.min())} µm)")
    if float(arr.max()) > MAX_THICKNESS_UM:
        raise MapError(f"{where}: thickness {float(arr.max())} µm over the {MAX_THICKNESS_UM:g} µm limit")
    return arr


def check_mask(arr: np.ndarray, where: str, shape: tuple[int, int] | None = None) -> np.ndarray:
    """Check a mask (float32 (H, W), every value in [0, 1]) and return it as C-contiguous float32."""
    arr = _check_grid(arr, where, shape)
    if float(arr.min()) < 0 or float(arr.max()) > 1.0:
        raise MapError(f"{where}: mask values must be in [0, 1] (found {float(arr.min())}..{float(arr.max())})")
    return arr


def _check_grid(arr: np.ndarray, where: str, shape: tuple[int, int] | None) -> np.ndarray:
    """What thickness maps and masks share: a non-empty float32 2-D array of ``shape``, every value finite."""
    if not isinstance(arr, np.ndarray):
        raise MapError(f"{where}: not an array")
    if arr.dtype != np.float32:
        raise MapError(f"{where}: dtype {arr.dtype}, float32 expected")
    if arr.ndim != 2 or arr.size == 0:
        raise MapError(f"{where}: array of shape {arr.shape}, a non-empty 2-D (height, width) map expected")
    _check_size(where, arr.shape[1], arr.shape[0], shape)
    finite = np.isfinite(arr)
    if not finite.all():
        bad = int(arr.size - np.count_nonzero(finite))
        raise MapError(f"{where}: {bad} texel(s) are NaN or infinite")
    return np.ascontiguousarray(arr)


def _check_size(where: str, width: int, height: int, shape: tuple[int, int] | None) -> None:
    """Refuse a map outside 1..:data:`MAX_SIDE` texels a side, or not (H, W) = ``shape``."""
    if width <= 0 or height <= 0 or width > MAX_SIDE or height > MAX_SIDE:
        raise MapError(f"{where}: map size {width}×{height} outside 1..{MAX_SIDE} (the limit of a layer's "
                       "resolution)")
    if shape is not None and (height, width) != tuple(shape):
        raise MapError(f"{where}: size {width}×{height} does not match the layer's resolution "
                       f"{shape[1]}×{shape[0]}; expected {shape[1]}×{shape[0]} texels")


# ---------------------------------------------------------------------------------------------- EXR


def _library_complaint(captured: list[str]) -> str | None:
    """The first error line the library printed (at most 160 characters), or None."""
    lines = [line.strip() for line in "\n".join(captured).splitlines() if line.strip()]
    bad = [line for line in lines if "EXR_ERR" in line or "Exception" in line or "rror" in line]
    return bad[0][:160] if bad else None


def encode_exr(values: np.ndarray, attributes: Mapping[str, str] | None = None) -> bytes:
    """EXR bytes of a float32 (H, W) map: one ``Y`` channel, ZIP compression, plus header ``attributes``.

    The values are written as they are (check them first: :func:`check_thickness`, :func:`check_mask`).
    """
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **(attributes or {})}
    buf = io.BytesIO()
    OpenEXR.File(header, {"Y": np.ascontiguousarray(values, dtype=np.float32)}).write(buf)
    return buf.getvalue()


def _exr_header(source: str | io.BytesIO, where: str) -> tuple[int, int, int, list[str]]:
    """(width, height, parts, channel names) from an EXR header; the pixels are not read.

    Raises:
        MapError: the library cannot read the header or complains while doing so, or the data window
            does not start at (0, 0).
    """
    import OpenEXR

    try:
        with captured_output() as out:
            head = OpenEXR.File(source, header_only=True)
        complaint = _library_complaint(out)
        if complaint:
            raise MapError(f"{where}: damaged EXR header ({complaint})")
        header = head.header()
        (x0, y0), (x1, y1) = (np.asarray(v, dtype=np.int64) for v in header["dataWindow"])
        channels = [c.name for c in header["channels"]]
        parts = len(head.parts)
    except MapError:
        raise
    except Exception as exc:  # the binding raises RuntimeError, ValueError, KeyError... for bad files
        raise MapError(f"{where}: cannot read the EXR header ({exc})") from None
    if (x0, y0) != (0, 0):
        raise MapError(f"{where}: EXR data window does not start at (0, 0)")
    return int(x1 - x0 + 1), int(y1 - y0 + 1), parts, channels


def exr_size(p: Path, max_side: int = MAX_SIDE) -> tuple[int, int]:
    """(width, height) in pixels of the EXR file at ``p``, from its header alone.

    Used before decoding any EXR (here and for the renderer's environment maps), so a huge image is
    refused before it is decompressed.

    Raises:
        MapError: the file is missing, unreadable, empty, or has a side over ``max_side`` pixels.
    """
    if not p.is_file():
        raise MapError(f"{p}: file not found")
    width, height, _parts, _channels = _exr_header(str(p), str(p))
    if width <= 0 or height <= 0:
        raise MapError(f"{p}: image is {width}×{height}, which is empty")
    if max(width, height) > max_side:
        raise MapError(f"{p}: image is {width}×{height}, over the {max_side} limit")
    return width, height


def read_exr_channels(path: str | Path, max_side: int = MAX_SIDE) -> dict[str, np.ndarray]:
    """Every channel of an EXR file, as the binding groups them (``RGB`` (H, W, 3) when R, G and B are there).

    The size is checked from the header first (:func:`exr_size`); what the library prints while decoding
    is captured (:func:`core.native_output.captured_output`), so a damaged file is one message, not two
    lines of the library's output before it.

    Raises:
        MapError: naming the file: missing, unreadable, over ``max_side`` pixels a side, or damaged (the
            library's complaint).
    """
    import OpenEXR

    p = Path(path)
    exr_size(p, max_side)
    try:
        with captured_output() as out, OpenEXR.File(str(p)) as f:
            channels = {name: np.array(c.pixels, copy=True) for name, c in f.channels().items()}
    except Exception as exc:  # the binding raises RuntimeError, ValueError, KeyError... for bad files
        said = _library_complaint(out) or str(exc)
        raise MapError(f"{p}: damaged or truncated EXR file: {said.removeprefix('Warning: ')}") from None
    complaint = _library_complaint(out)
    if complaint:
        raise MapError(f"{p}: damaged or truncated EXR file: {complaint.removeprefix('Warning: ')}")
    return channels


def decode_exr(data: bytes, where: str, shape: tuple[int, int] | None = None) -> np.ndarray:
    """Decode EXR bytes holding one ``Y`` channel of 32-bit floats; the values are not checked.

    Args:
        data: the file's bytes.
        where: names the map in messages.
        shape: the expected (H, W) in texels, checked from the header; None: any size up to
            :data:`MAX_SIDE`.

    Returns:
        float32 (H, W), a copy owned by the caller.

    Raises:
        MapError: not an EXR, several parts, channels other than exactly ``Y``, a size outside
            1..:data:`MAX_SIDE` or not ``shape``, pixels not 32-bit float, or a decode the library
            reports only by printing.
    """
    import OpenEXR

    if not data.startswith(_EXR_MAGIC):
        raise MapError(f"{where}: not an OpenEXR file")
    width, height, parts, channels = _exr_header(io.BytesIO(data), where)
    if parts != 1:
        raise MapError(f"{where}: {parts} parts in the EXR file, 1 expected")
    if channels != ["Y"]:
        raise MapError(f"{where}: EXR channels {channels}, exactly ['Y'] expected")
    _check_size(where, width, height, shape)
    try:
        with captured_output() as out:
            pixels = OpenEXR.File(io.BytesIO(data), separate_channels=True).channels()["Y"].pixels
    except Exception as exc:
        raise MapError(f"{where}: cannot decode the EXR pixels ({exc})") from None
    complaint = _library_complaint(out)
    if complaint:
        raise MapError(f"{where}: damaged EXR pixel data ({complaint})")
    if not isinstance(pixels, np.ndarray) or pixels.dtype != np.float32:
        raise MapError(f"{where}: EXR channel 'Y' is {getattr(pixels, 'dtype', type(pixels))}, "
                       "32-bit float expected")
    if pixels.shape != (height, width):
        raise MapError(f"{where}: decoded EXR has shape {pixels.shape}, {(height, width)} expected")
    return np.array(pixels, dtype=np.float32, copy=True)


# ---------------------------------------------------------------------------------------------- PNG


def png16_um_per_count(thickness: np.ndarray) -> float:
    """µm per count the PNG writer uses for ``thickness`` (µm): its maximum / 65535, or 1.0 when empty."""
    peak = float(np.max(thickness)) if thickness.size else 0.0
    return peak / PNG16_MAX if peak > 0 else 1.0


def quantise(values: np.ndarray, unit: float) -> np.ndarray:
    """uint16 counts ``round(values / unit)`` (half to even), clipped to [0, 65535]; ``unit`` > 0."""
    return np.clip(np.rint(np.asarray(values, dtype=np.float64) / unit), 0, PNG16_MAX).astype(np.uint16)


def encode_png16(counts: np.ndarray, text: Mapping[str, str] | None = None) -> bytes:
    """16-bit greyscale PNG bytes of uint16 (H, W) ``counts`` with ``text`` chunks (zlib level 6)."""
    from PIL import Image
    from PIL.PngImagePlugin import PngInfo

    info = PngInfo()
    for key, value in (text or {}).items():
        info.add_text(key, value)
    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(counts, dtype="<u2")).save(buf, format="PNG", compress_level=6,
                                                                     pnginfo=info)
    return buf.getvalue()


def decode_png(data: bytes, where: str, shape: tuple[int, int] | None = None,
               eight_bit: bool = False) -> tuple[np.ndarray, dict[str, str]]:
    """Decode greyscale PNG bytes to counts, checking the size and mode before the pixels.

    Args:
        data: the file's bytes.
        where: names the map in messages.
        shape: the expected (H, W) in texels, or None: any size up to :data:`MAX_SIDE`.
        eight_bit: also accept 8-bit greyscale (or palette, or 1-bit) images, as uint8 counts; a
            project's entries must be 16-bit.

    Returns:
        (counts: uint16 (H, W), or uint8 for an 8-bit image; the PNG's text chunks).

    Raises:
        MapError: not a PNG, a size outside 1..:data:`MAX_SIDE` or not ``shape``, another mode, a
            decompression bomb, or damaged data.
    """
    from PIL import Image

    if not data.startswith(_PNG_MAGIC):
        raise MapError(f"{where}: not a PNG file")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(io.BytesIO(data), formats=["PNG"]) as im:
                width, height = im.size
                _check_size(where, width, height, shape)
                if im.mode in _PNG16_MODES:
                    im.load()
                    counts = np.asarray(im).astype(np.uint16)
                elif eight_bit and im.mode in _PNG8_MODES:
                    counts = np.asarray(im.convert("L"), dtype=np.uint8)
                else:
                    wanted = "8 or 16-bit" if eight_bit else "16-bit"
                    raise MapError(f"{where}: PNG mode {im.mode}, {wanted} greyscale expected")
                text = {str(k): str(v) for k, v in (getattr(im, "text", None) or {}).items()}
    except MapError:
        raise
    except Exception as exc:  # Pillow raises OSError, SyntaxError, ValueError, DecompressionBomb*...
        raise MapError(f"{where}: cannot decode the PNG ({exc})") from None
    if counts.shape != (height, width):
        raise MapError(f"{where}: decoded PNG has shape {counts.shape}, {(height, width)} expected")
    return counts, text


def from_counts(counts: np.ndarray, unit: float) -> np.ndarray:
    """float32 values = ``counts × unit`` (computed in float64); ``unit`` is µm per count for thickness."""
    return (counts.astype(np.float64) * unit).astype(np.float32)


# ---------------------------------------------------------------------------------------------- files


def _suffix(path: Path) -> str:
    s = path.suffix.lower()
    if s not in (".png", ".exr"):
        raise MapError(f"{path}: unsupported map format {path.suffix!r} (use .png or .exr)")
    return s


def _write_file(path: Path, data: bytes) -> None:
    try:
        atomic_write_bytes(path, data)
    except OSError as exc:
        raise MapError(f"{path}: cannot write: {exc.strerror or exc}") from None


def write_thickness(path: str | Path, thickness: np.ndarray, scale_um: float | None = None,
                    credit: str = "") -> float:
    """Write a thickness map (float32 (H, W), µm) to a ``.exr`` or 16-bit ``.png`` file, atomically.

    Args:
        path: the file; its suffix picks the encoding.
        thickness: the map (see :func:`check_thickness`).
        scale_um: PNG only: the thickness (µm) of count 65535; default the map's maximum (1 µm when
            empty). A value above it is an error.
        credit: a credit line stored in the file (the head's).

    Returns:
        The scale used (µm at count 65535; 1.0 for EXR).
    """
    p = Path(path)
    kind = _suffix(p)
    arr = check_thickness(thickness, str(p))
    if kind == ".exr":
        _write_file(p, encode_exr(arr, {UNIT_KEY: "um", **({"sheer:credit": credit} if credit else {})}))
        return 1.0
    top = float(arr.max())
    scale = float(scale_um) if scale_um is not None else (top if top > 0 else 1.0)
    if not np.isfinite(scale) or scale <= 0:
        raise MapError(f"{p}: scale_um must be a positive number, got {scale_um!r}")
    if top > scale * (1 + 1e-6):
        raise MapError(f"{p}: thickness up to {top:g} µm does not fit the scale {scale:g} µm")
    text = {SCALE_KEY: repr(scale), UNIT_KEY: "um", **({"Copyright": credit} if credit else {})}
    _write_file(p, encode_png16(quantise(arr, scale / PNG16_MAX), text))
    return scale


def read_thickness(path: str | Path, expected_shape: tuple[int, int] | None = None,
                   scale_um: float | None = None) -> np.ndarray:
    """Read a thickness map file (float32 (H, W), µm), checked as :func:`check_thickness` does.

    Args:
        path: a ``.exr`` (one ``Y`` float32 channel) or ``.png`` (8 or 16-bit greyscale) file.
        expected_shape: the layer's (H, W) in texels, or None.
        scale_um: PNG only: the thickness (µm) of the largest count; default the file's
            ``sheer:scale_um`` text chunk.
    """
    p = Path(path)
    kind = _suffix(p)
    data = read_bounded(p, MAX_FILE_BYTES, "map file", MapError)
    if kind == ".exr":
        return check_thickness(decode_exr(data, str(p), expected_shape), str(p), expected_shape)
    counts, text = decode_png(data, str(p), expected_shape, eight_bit=True)
    scale = scale_um
    if scale is None:
        recorded = text.get(SCALE_KEY)
        if recorded is None:
            raise MapError(f"{p}: PNG has no '{SCALE_KEY}' metadata; pass scale_um")
        try:
            scale = float(recorded)
        except ValueError:
            raise MapError(f"{p}: bad '{SCALE_KEY}' metadata {recorded!r}") from None
    if not np.isfinite(scale) or scale <= 0:
        raise MapError(f"{p}: scale must be a positive number, got {scale!r}")
    peak = PNG16_MAX if counts.dtype == np.uint16 else 255
    return check_thickness(from_counts(counts, scale / peak), str(p), expected_shape)


def write_mask(path: str | Path, mask: np.ndarray) -> None:
    """Write a mask (bool, or floats in [0, 1]) to a ``.exr`` (``Y``) or 16-bit ``.png`` file, atomically."""
    p = Path(path)
    kind = _suffix(p)
    arr = check_mask(np.asarray(mask, dtype=np.float32), str(p))
    if kind == ".exr":
        _write_file(p, encode_exr(arr, {"sheer:kind": "mask"}))
    else:
        _write_file(p, encode_png16(quantise(arr, 1.0 / PNG16_MAX), {"sheer:kind": "mask"}))


def read_mask(path: str | Path, expected_shape: tuple[int, int] | None = None) -> np.ndarray:
    """Read a mask file as float32 (H, W) in [0, 1] (PNG 8 or 16-bit, white = 1; EXR ``Y``)."""
    p = Path(path)
    data = read_bounded(p, MAX_FILE_BYTES, "map file", MapError)
    if _suffix(p) == ".exr":
        arr = decode_exr(data, str(p), expected_shape)
    else:
        counts, _ = decode_png(data, str(p), expected_shape, eight_bit=True)
        arr = from_counts(counts, 1.0 / (PNG16_MAX if counts.dtype == np.uint16 else 255))
    return check_mask(arr, str(p), expected_shape)
