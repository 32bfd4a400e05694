"""Thickness maps and masks in and out: 16-bit PNG (scale in a text chunk) and 32-bit float EXR.

- PNG: greyscale 16-bit; a texel stores ``round(thickness / scale_um · 65535)``; the text chunk
  ``sheer:scale_um`` holds ``scale_um`` (the thickness of value 65535, µm), ``sheer:unit`` = ``um``.
- EXR: one float32 channel ``Y`` in µm (ZIP compression); header ``sheer:unit`` = ``um``.
- Masks: PNG 8/16-bit greyscale or EXR ``Y``, values in [0, 1] (PNG white = 1).

Images are top row first (see :mod:`painting.head`). Files are written atomically (:mod:`core.atomicio`).
Sizes are checked against the layer's (``expected_shape``).
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np

from core.atomicio import atomic_writer
from core.errors import SheerError

SCALE_KEY = "sheer:scale_um"
UNIT_KEY = "sheer:unit"
MAX_SIDE = 16384


class MapError(SheerError, ValueError):
    """A map file that cannot be written or read (format, size, values); the message names the file."""


def _suffix(path: Path) -> str:
    s = path.suffix.lower()
    if s not in (".png", ".exr"):
        raise MapError(f"{path}: unsupported map format {path.suffix!r} (use .png or .exr)")
    return s


def _check_values(values: np.ndarray, path: Path, what: str) -> np.ndarray:
    arr = np.asarray(values)
    if arr.ndim != 2 or arr.shape[0] == 0 or arr.shape[1] == 0:
        raise MapError(f"{path}: {what} must be a 2D array, got shape {arr.shape}")
    arr = arr.astype(np.float32)
    if not np.all(np.isfinite(arr)) or arr.min() < 0:
        raise MapError(f"{path}: {what} must be finite and ≥ 0")
    return arr


def write_thickness(path: str | Path, thickness: np.ndarray, scale_um: float | None = None,
                    credit: str = "") -> float:
    """Write a thickness map (µm). PNG: ``scale_um`` defaults to the map's maximum (1 µm if empty);
    values above it are an error. Returns the scale used (1.0 for EXR).
    """
    p = Path(path)
    kind = _suffix(p)
    arr = _check_values(thickness, p, "thickness")
    if kind == ".exr":
        _write_exr(p, arr, {UNIT_KEY: "um", **({"sheer:credit": credit} if credit else {})})
        return 1.0
    top = float(arr.max())
    scale = float(scale_um) if scale_um is not None else (top if top > 0 else 1.0)
    if not np.isfinite(scale) or scale <= 0:
        raise MapError(f"{p}: scale_um must be a positive number, got {scale_um!r}")
    if top > scale * (1 + 1e-6):
        raise MapError(f"{p}: thickness up to {top:g} µm does not fit the scale {scale:g} µm")
    q = np.round(np.clip(arr / scale, 0.0, 1.0) * 65535.0).astype(np.uint16)
    _write_png16(p, q, {SCALE_KEY: repr(scale), UNIT_KEY: "um", **({"Copyright": credit} if credit else {})})
    return scale


def read_thickness(path: str | Path, expected_shape: tuple[int, int] | None = None,
                   scale_um: float | None = None) -> np.ndarray:
    """Read a thickness map (float32 µm). A PNG needs its ``sheer:scale_um`` chunk or ``scale_um``."""
    p = Path(path)
    kind = _suffix(p)
    if kind == ".exr":
        arr = _read_exr(p)
    else:
        raw, info = _read_png(p)
        scale = scale_um
        if scale is None:
            text = info.get(SCALE_KEY)
            if text is None:
                raise MapError(f"{p}: PNG has no '{SCALE_KEY}' metadata; pass scale_um")
            try:
                scale = float(text)
            except ValueError:
                raise MapError(f"{p}: bad '{SCALE_KEY}' metadata {text!r}") from None
        if not np.isfinite(scale) or scale <= 0:
            raise MapError(f"{p}: scale must be a positive number, got {scale!r}")
        peak = 65535.0 if raw.dtype == np.uint16 else 255.0
        arr = (raw.astype(np.float64) / peak * scale).astype(np.float32)
    _check_shape(p, arr, expected_shape)
    return _check_values(arr, p, "thickness")


def write_mask(path: str | Path, mask: np.ndarray) -> None:
    """Write a mask (bool or [0, 1] floats): PNG 16-bit greyscale or EXR ``Y``."""
    p = Path(path)
    kind = _suffix(p)
    arr = _check_values(np.asarray(mask, dtype=np.float32), p, "mask")
    if arr.max(initial=0.0) > 1.0:
        raise MapError(f"{p}: mask values must be in [0, 1]")
    if kind == ".exr":
        _write_exr(p, arr, {"sheer:kind": "mask"})
    else:
        _write_png16(p, np.round(arr * 65535.0).astype(np.uint16), {"sheer:kind": "mask"})


def read_mask(path: str | Path, expected_shape: tuple[int, int] | None = None) -> np.ndarray:
    """Read a mask as float32 in [0, 1] (PNG: 8 or 16-bit, white = 1)."""
    p = Path(path)
    if _suffix(p) == ".exr":
        arr = _read_exr(p)
    else:
        raw, _ = _read_png(p)
        arr = (raw.astype(np.float64) / (65535.0 if raw.dtype == np.uint16 else 255.0)).astype(np.float32)
    _check_shape(p, arr, expected_shape)
    arr = _check_values(arr, p, "mask")
    if arr.max(initial=0.0) > 1.0:
        raise MapError(f"{p}: mask values must be in [0, 1]")
    return arr


def _check_shape(p: Path, arr: np.ndarray, expected: tuple[int, int] | None) -> None:
    if expected is not None and tuple(arr.shape) != tuple(expected):
        raise MapError(f"{p}: map is {arr.shape[1]}×{arr.shape[0]} texels, expected "
                       f"{expected[1]}×{expected[0]}")


def _write_png16(p: Path, q: np.ndarray, text: dict[str, str]) -> None:
    from PIL import Image
    from PIL.PngImagePlugin import PngInfo

    info = PngInfo()
    for k, v in text.items():
        info.add_text(k, v)
    img = Image.fromarray(np.ascontiguousarray(q.astype("<u2")))  # uint16 -> mode "I;16"
    try:
        with atomic_writer(p) as fh:
            img.save(fh, format="PNG", pnginfo=info)
    except OSError as exc:
        raise MapError(f"{p}: cannot write: {exc}") from None


def _read_png(p: Path) -> tuple[np.ndarray, dict[str, Any]]:
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(p) as im:
            if max(im.size) > MAX_SIDE:
                raise MapError(f"{p}: image is {im.size[0]}×{im.size[1]}, over the {MAX_SIDE} limit")
            info = dict(getattr(im, "text", {}) or {})
            mode = im.mode
            if mode in ("I;16", "I;16B", "I;16L", "I"):
                raw = np.asarray(im, dtype=np.int64).astype(np.uint16) if mode == "I" else \
                    np.asarray(im).astype(np.uint16)
            elif mode in ("L", "P", "1"):
                raw = np.asarray(im.convert("L"), dtype=np.uint8)
            else:
                raise MapError(f"{p}: expected a greyscale PNG, got mode {mode}")
    except FileNotFoundError:
        raise MapError(f"{p}: file not found") from None
    except Image.DecompressionBombError as exc:
        raise MapError(f"{p}: image too large to decode safely: {exc}") from None
    except (UnidentifiedImageError, OSError) as exc:
        raise MapError(f"{p}: cannot read PNG: {exc}") from None
    return raw, info


def _write_exr(p: Path, arr: np.ndarray, header_text: dict[str, str]) -> None:
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **header_text}
    try:
        buf = io.BytesIO()
        OpenEXR.File(header, {"Y": np.ascontiguousarray(arr, dtype=np.float32)}).write(buf)
        with atomic_writer(p) as fh:
            fh.write(buf.getvalue())
    except (OSError, RuntimeError) as exc:
        raise MapError(f"{p}: cannot write EXR: {exc}") from None


def exr_size(p: Path, max_side: int = MAX_SIDE) -> tuple[int, int]:
    """(width, height) in pixels of the EXR at ``p`` from its header alone, so that a huge image is
    refused before it is decompressed. :class:`MapError` if the file is missing, unreadable or has a
    side over ``max_side`` pixels.
    """
    import OpenEXR

    if not p.is_file():
        raise MapError(f"{p}: file not found")
    try:
        (x0, y0), (x1, y1) = OpenEXR.File(str(p), header_only=True).header()["dataWindow"]
        width, height = int(x1) - int(x0) + 1, int(y1) - int(y0) + 1
    except Exception as exc:
        raise MapError(f"{p}: cannot read EXR header: {exc}") from None
    if width <= 0 or height <= 0:
        raise MapError(f"{p}: image is {width}×{height}, which is empty")
    if max(width, height) > max_side:
        raise MapError(f"{p}: image is {width}×{height}, over the {max_side} limit")
    return width, height


def _read_exr(p: Path) -> np.ndarray:
    import OpenEXR

    exr_size(p)
    try:
        f = OpenEXR.File(str(p), separate_channels=True)
        channels = f.channels()
    except Exception as exc:  # OpenEXR raises RuntimeError/ValueError on bad files
        raise MapError(f"{p}: cannot read EXR: {exc}") from None
    name = "Y" if "Y" in channels else ("R" if "R" in channels else next(iter(channels), None))
    if name is None:
        raise MapError(f"{p}: EXR has no channels")
    arr = np.asarray(channels[name].pixels)
    if arr.ndim != 2:
        raise MapError(f"{p}: EXR channel {name!r} is not a 2D image")
    if max(arr.shape) > MAX_SIDE:
        raise MapError(f"{p}: image is {arr.shape[1]}×{arr.shape[0]}, over the {MAX_SIDE} limit")
    return arr.astype(np.float32)
