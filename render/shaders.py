"""GLSL sources: ``.glsl`` files under ``resources/shaders/`` loaded by name, ``#include`` resolved.

Works without a GPU (``ShaderLibrary.source``); :meth:`ShaderLibrary.program` compiles with moderngl.
An include is a line ``#include "name.glsl"``; each file is included at most once per source (include
guards are implicit) and cycles are errors. ``#define``s can be injected after the ``#version`` line.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

from render.errors import RenderError

if TYPE_CHECKING:
    import moderngl

_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')
_VERSION = "#version 450 core"


def default_shader_dir() -> Path:
    """``resources/shaders`` of this checkout."""
    from core.assets import resource_path

    return resource_path("shaders")


class ShaderLibrary:
    """Loads shader sources by name from one or more folders (first match wins)."""

    def __init__(self, folders: list[Path] | None = None) -> None:
        self.folders = [Path(f) for f in (folders or [default_shader_dir()])]

    def path(self, name: str) -> Path:
        """The file of shader ``name`` (e.g. ``"frame.frag"`` or ``"frame.frag.glsl"``)."""
        candidates = [name] if name.endswith(".glsl") else [f"{name}.glsl", name]
        for folder in self.folders:
            for c in candidates:
                p = folder / c
                if p.is_file():
                    return p
        raise RenderError(f"shader '{name}' not found in {', '.join(str(f) for f in self.folders)}")

    def source(self, name: str, defines: dict[str, Any] | None = None) -> str:
        """The full source of ``name`` with includes resolved and ``defines`` injected.

        A ``#version`` line is added if the file has none. ``#line`` directives keep compiler messages
        pointing at the right file line (file index = order of first inclusion).
        """
        for key in defines or {}:
            if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", key):
                raise RenderError(f"bad shader define name {key!r}")
        seen: list[str] = []
        body = self._expand(name, seen, stack=[])
        lines = body.splitlines()
        version = _VERSION
        if lines and lines[0].lstrip().startswith("#version"):
            version, lines = lines[0], lines[1:]
        header = [version]
        for key, value in (defines or {}).items():
            header.append(f"#define {key} {value}")
        return "\n".join(header + lines) + "\n"

    def _expand(self, name: str, seen: list[str], stack: list[str]) -> str:
        path = self.path(name)
        key = path.name
        if key in stack:
            raise RenderError(f"shader include cycle: {' -> '.join([*stack, key])}")
        if key in seen:
            return ""
        seen.append(key)
        out: list[str] = [f"#line 1 {seen.index(key)}"] if stack else []
        for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            m = _INCLUDE.match(line)
            if m:
                try:
                    out.append(self._expand(m.group(1), seen, [*stack, key]))
                except RenderError as exc:
                    raise RenderError(f"{path.name}:{lineno}: {exc}") from None
                out.append(f"#line {lineno + 1} {seen.index(key)}")
            else:
                out.append(line)
        return "\n".join(out)

    def include_order(self, name: str) -> list[str]:
        """The files of shader ``name`` in the order :meth:`source` numbers them (the N of ``#line L N``)."""
        seen: list[str] = []
        self._expand(name, seen, stack=[])
        return seen

    def program(self, ctx: moderngl.Context, vertex: str, fragment: str,
                defines: dict[str, Any] | None = None) -> moderngl.Program:
        """Compile and link a ``moderngl.Program`` from two shader names (see :meth:`source`).

        Raises:
            RenderError: a shader is missing, or the compiler or linker refused them (its log included).
        """
        vs = self.source(vertex, defines)
        fs = self.source(fragment, defines)
        try:
            return ctx.program(vertex_shader=vs, fragment_shader=fs)
        except Exception as exc:  # moderngl raises its own Error with the compiler log
            raise RenderError(f"shader program {vertex} + {fragment} failed to build: {exc}") from None
