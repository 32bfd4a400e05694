"""Sheer's standalone (headless) OpenGL context, made in one place, on the EGL device asked for.

Everything that renders without a window (the catalogue's workers, ``sheer render``, the studio's image
and glTF export, the kiosk's try-on views, the benches) makes its context with :func:`standalone_context`:
an EGL context (no display server needed), OpenGL 4.5 core by default.

Which EGL device (GPU) it is made on:

- ``SHEER_EGL_DEVICE`` set in the environment pins it: an integer index into the EGL devices of this
  machine, in the order EGL lists them (``eglQueryDevicesEXT``; moderngl's EGL backend takes the same
  index as ``device_index``). A value that is not an integer, or not the index of a device present, is a
  :class:`render.errors.RenderError` whose one line names the variable.
- else the ``device`` the caller asks for (the catalogue gives each Dask worker its own one, round robin:
  :func:`round_robin_device`);
- else EGL's first device, as moderngl's default.

:func:`egl_devices` lists the devices without making a context (a few milliseconds through ``ctypes``).
Mesa lists a software rasteriser (llvmpipe) as a device of its own beside the GPUs: the round robin
skips it when there is a GPU, so that one GPU and Mesa is one device to share, not two.
"""

from __future__ import annotations

import functools
import os
from typing import TYPE_CHECKING, Any

from render.errors import RenderError

if TYPE_CHECKING:
    from collections.abc import Sequence

    import moderngl

#: The environment variable that pins the EGL device (an index, as :func:`egl_devices` lists them).
ENV_DEVICE = "SHEER_EGL_DEVICE"
#: The OpenGL version the renderer needs (4.5 core), as moderngl's ``require`` takes it.
GL_REQUIRE = 450
#: What a software EGL device (Mesa's llvmpipe) carries in its extension string.
SOFTWARE_EXTENSION = "EGL_MESA_device_software"
_EGL_EXTENSIONS = 0x3055


@functools.cache
def egl_devices() -> tuple[str, ...]:
    """The EGL devices of this machine: each one's extension string, in EGL's (and moderngl's) order.

    Empty when EGL or its device enumeration (``EGL_EXT_device_enumeration``) is missing; then nothing can
    be checked and the context is made on EGL's default device.
    """
    import ctypes
    from ctypes.util import find_library

    name = find_library("EGL")
    if name is None:
        return ()
    try:
        egl = ctypes.CDLL(name)
        egl.eglGetProcAddress.restype = ctypes.c_void_p
        egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        query_addr = egl.eglGetProcAddress(b"eglQueryDevicesEXT")
        string_addr = egl.eglGetProcAddress(b"eglQueryDeviceStringEXT")
    except (OSError, AttributeError):
        return ()
    if not query_addr:
        return ()
    query = ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_void_p),
                             ctypes.POINTER(ctypes.c_int))(query_addr)
    count = ctypes.c_int(0)
    if not query(0, None, ctypes.byref(count)) or count.value <= 0:
        return ()
    handles = (ctypes.c_void_p * count.value)()
    if not query(count.value, handles, ctypes.byref(count)):
        return ()
    describe = (ctypes.CFUNCTYPE(ctypes.c_char_p, ctypes.c_void_p, ctypes.c_int)(string_addr)
                if string_addr else None)
    out = []
    for handle in handles[:count.value]:
        text = describe(handle, _EGL_EXTENSIONS) if describe is not None else None
        out.append((text or b"").decode("ascii", "replace"))
    return tuple(out)


def render_devices(devices: Sequence[str] | None = None) -> list[int]:
    """The indices of the devices to share work between: the GPUs, or every device if there is none.

    Args:
        devices: extension strings as :func:`egl_devices` gives them (default: this machine's).
    """
    devices = egl_devices() if devices is None else devices
    hardware = [i for i, ext in enumerate(devices) if SOFTWARE_EXTENSION not in ext.split()]
    return hardware or list(range(len(devices)))


def pinned_device(devices: Sequence[str] | None = None) -> int | None:
    """The device ``SHEER_EGL_DEVICE`` pins, or None when it is unset (or empty).

    Args:
        devices: extension strings as :func:`egl_devices` gives them (default: this machine's).

    Raises:
        RenderError: the value is not an integer, or no device has that index (one line, naming the
            variable and the devices there are).
    """
    raw = os.environ.get(ENV_DEVICE, "").strip()
    if not raw:
        return None
    devices = egl_devices() if devices is None else devices
    n = len(devices)
    there = ("EGL lists no devices here" if not n else "this machine has 1 EGL device (index 0)" if n == 1
             else f"this machine has {n} EGL devices (0..{n - 1})")
    try:
        index = int(raw)
    except ValueError:
        raise RenderError(f"{ENV_DEVICE}={raw!r} is not an integer: set it to an EGL device index "
                          f"({there}) or unset it") from None
    if index < 0 or (devices and index >= len(devices)):
        raise RenderError(f"{ENV_DEVICE}={index} is out of range: {there}")
    return index


def round_robin_device(worker_index: int | None, devices: Sequence[str] | None = None) -> int | None:
    """The device for the ``worker_index``-th of several worker processes: one each, round robin.

    ``SHEER_EGL_DEVICE`` wins when set. With one device to share (or no index) it is None: EGL's
    default device, as before.

    Args:
        worker_index: the worker's index (0, 1, …), or None when it has none.
        devices: extension strings as :func:`egl_devices` gives them (default: this machine's).

    Returns:
        An index for :func:`standalone_context`'s ``device``, or None.

    Raises:
        RenderError: ``SHEER_EGL_DEVICE`` is bad (see :func:`pinned_device`).
    """
    devices = egl_devices() if devices is None else devices
    pinned = pinned_device(devices)
    if pinned is not None:
        return pinned
    shared = render_devices(devices)
    if worker_index is None or len(shared) <= 1:
        return None
    return shared[worker_index % len(shared)]


def standalone_context(device: int | None = None, require: int = GL_REQUIRE) -> moderngl.Context:
    """A new standalone EGL context, current in the calling thread (release it with ``ctx.release()``).

    Args:
        device: the EGL device index (see :func:`egl_devices`), or None for EGL's default device;
            ``SHEER_EGL_DEVICE`` overrides it.
        require: the lowest OpenGL version accepted, e.g. 450 for 4.5 (moderngl's ``require``).

    Raises:
        RenderError: ``SHEER_EGL_DEVICE`` is bad (see :func:`pinned_device`).
        Exception: whatever moderngl raises when no such context can be made.
    """
    import moderngl

    pinned = pinned_device()
    index = pinned if pinned is not None else device
    settings: dict[str, Any] = {"backend": "egl"}
    if index is not None:
        settings["device_index"] = int(index)
    return moderngl.create_context(require=require, standalone=True, **settings)
