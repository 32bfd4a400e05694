"""Small moderngl helpers: uniforms that may have been compiled out, depth read-back, releasing objects."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Iterable

    import moderngl


def set_uniform(program: moderngl.Program, name: str, value: Any) -> None:
    """Set a uniform if the program has it (the compiler drops unused ones)."""
    if name in program:
        program[name].value = value


def write_uniform(program: moderngl.Program, name: str, data: Any) -> None:
    """Write float32 rows to a uniform array or matrix if the program has it.

    Rows beyond the uniform's array length are cut (the compiler may shorten an array that is indexed
    only up to N); arrays of more than two dimensions are flattened to rows.
    """
    if name in program:
        u = program[name]
        arr = np.asarray(data, dtype=np.float32)
        arr = arr.reshape(-1, *arr.shape[2:]) if arr.ndim > 2 else arr
        u.write(np.ascontiguousarray(arr[:max(u.array_length, 1)]).tobytes())


def rect_vertices(rects: list[tuple[int, int, int, int]] | None, size: tuple[int, int]) -> np.ndarray:
    """NDC vertices (float32 (n, 2)) of two triangles per rectangle of a ``size`` (w, h) target.

    ``rects`` are (x, y, width, height) in pixels; None = one triangle covering the whole target.
    """
    if rects is None:
        return np.array([[-1.0, -1.0], [3.0, -1.0], [-1.0, 3.0]], np.float32)
    w, h = size
    r = np.asarray(rects, np.float64).reshape(-1, 4)
    x0, y0 = r[:, 0] / w * 2.0 - 1.0, r[:, 1] / h * 2.0 - 1.0
    x1, y1 = (r[:, 0] + r[:, 2]) / w * 2.0 - 1.0, (r[:, 1] + r[:, 3]) / h * 2.0 - 1.0
    return np.stack([np.stack([x0, y0], 1), np.stack([x1, y0], 1), np.stack([x1, y1], 1),
                     np.stack([x0, y0], 1), np.stack([x1, y1], 1), np.stack([x0, y1], 1)],
                    axis=1).reshape(-1, 2).astype(np.float32)


def read_depth(fbo: moderngl.Framebuffer, x: int, y: int) -> float | None:
    """The window depth in [0, 1) at pixel (x, y) of ``fbo``'s depth attachment (origin top-left).

    None for the far plane (depth 1: background) or a pixel outside ``fbo``.
    """
    w, h = fbo.size
    if not (0 <= x < w and 0 <= y < h):
        return None
    raw = fbo.read(viewport=(int(x), int(h - 1 - y), 1, 1), attachment=-1, dtype="f4")
    z = float(np.frombuffer(raw, np.float32)[0])
    return None if z >= 1.0 else z


def release_all(ctx: moderngl.Context, objects: Iterable[Any]) -> None:
    """Release GL objects (None entries skipped).

    If the bound framebuffer is among them, re-bind whatever GL binds after the deletion: moderngl
    re-binds its idea of the current framebuffer after creating any framebuffer, and a deleted one would
    raise GL_INVALID_OPERATION later.
    """
    objs = [o for o in objects if o is not None]
    current = getattr(ctx, "fbo", None)
    bound_released = current is not None and any(o is current for o in objs)
    for obj in objs:
        obj.release()
    if bound_released:
        # what moderngl itself does after creating a context: adopt the framebuffer GL has bound now
        # (binding it with .use() would call glDrawBuffers, an error on a surfaceless framebuffer 0)
        ctx.fbo = ctx.detect_framebuffer()
        if hasattr(ctx, "mglo"):
            ctx.mglo.fbo = ctx.fbo.mglo
