"""Small moderngl helpers."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any


def release_all(ctx: Any, objects: Iterable[Any]) -> None:
    """Release GL objects (None entries skipped). If the bound framebuffer is among them, re-bind
    whatever GL binds after the deletion: moderngl re-binds its idea of the current framebuffer after
    creating any framebuffer, and a deleted one would raise GL_INVALID_OPERATION later."""
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
