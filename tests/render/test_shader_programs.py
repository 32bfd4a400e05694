"""Every shader program the renderer builds passes a second, strict compiler (glslang) and builds on Mesa.

The programs come from :func:`render.programs.programs`, which calls the builders' own define functions
over the domains the code gives them; :func:`test_the_renderer_builds_nothing_else` checks that the
programs a real renderer builds are among them.

What glslang cannot see: it checks each shader against the GLSL 4.50 core specification (syntax, types,
implicit conversions, built-ins the core profile removed, extensions) but does not unroll loops, so an
index that only a driver that unrolls sees out of range (``vis1[i - 5]`` in the ternary arm not taken
for ``i == 0``: NVIDIA's "error C1068: array index out of bounds") passes it, and Mesa accepts it too.
:func:`test_no_loop_subscript_can_leave_its_array` catches that class in the sources: a subscript that
subtracts from a loop's variable must stay in range from the loop's first value on (lanes of two vec4s
go through ``lane8``, whose subscript is masked). The GPU kit builds the same programs on NVIDIA.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from render.programs import ProgramSpec, StageSources, build_all, locate, programs
from render.shaders import ShaderLibrary, default_shader_dir

if TYPE_CHECKING:
    from pathlib import Path

GLSLANG = "glslangValidator"
_FILE_HEADER = re.compile(r"^(\S+\.(?:vert|frag))$")


def _define_files(specs: list[ProgramSpec]) -> list[str]:
    """Sources that hold every distinct ``#define`` line of the programs (one value of a name per source).

    :func:`glslang_check` checks each shader with the defines its text names; these check the lines of
    the others (a macro never expanded is its ``#define`` line alone: a reserved name would fail there).
    """
    values: dict[str, list[int]] = {}
    for spec in specs:
        for key, value in spec.defines:
            if value not in values.setdefault(key, []):
                values[key].append(value)
    return ["#version 450 core\n" + "".join(f"#define {k} {v[j]}\n" for k, v in values.items() if j < len(v))
            + "void main() {}\n" for j in range(max((len(v) for v in values.values()), default=0))]


def glslang_check(specs: list[ProgramSpec], lib: ShaderLibrary, folder: Path) -> list[str]:
    """``file.glsl:line: message`` for every message glslang gives on the programs' shaders.

    Each distinct shader (a shader with the defines its text names, :meth:`StageSources.used_defines`:
    the others are never expanded, so they change nothing glslang sees but their ``#define`` lines, which
    :func:`_define_files` checks) is written once into ``folder`` and checked in batches (one glslang
    process checks a few hundred files in about a second).
    """
    exe = shutil.which(GLSLANG)
    assert exe, (f"{GLSLANG} not found: install Debian's glslang-tools (README, 'Debian packages'; "
                 ".ci/run installs it)")
    stages = StageSources(lib)
    names: dict[str, str | None] = {}  # file written -> shader name (None: the programs' #define lines)
    written: set[tuple[str, tuple[tuple[str, object], ...]]] = set()

    def write(src: str, stage: str, name: str | None) -> None:
        path = folder / f"{len(names):05d}.{stage}"
        path.write_text(src, encoding="utf-8")
        names[path.name] = name

    for spec in specs:
        for name, stage in ((spec.vertex, "vert"), (spec.fragment, "frag")):
            used = stages.used_defines(name, dict(spec.defines))
            if (name, tuple(used.items())) not in written:
                written.add((name, tuple(used.items())))
                write(stages.source(name, used), stage, name)
    for src in _define_files(specs):
        write(src, "frag", None)
    files = sorted(names)
    messages: list[str] = []
    for i in range(0, len(files), 400):
        run = subprocess.run([exe, *files[i:i + 400]], cwd=folder, capture_output=True, text=True, timeout=300)
        current = ""
        for line in run.stdout.splitlines():
            head = _FILE_HEADER.match(line.strip())
            if head:
                current = head.group(1)
                continue
            if line.startswith(("ERROR:", "WARNING:")) and current:
                shader = names[current]
                order = lib.include_order(shader) if shader else ["the programs' #define lines"]
                for entry in locate(line, order, order) or (f"{shader}: {line}",):
                    if entry not in messages:
                        messages.append(entry)
        assert run.returncode in (0, 2), f"{GLSLANG} failed to run ({run.returncode}): {run.stderr[-500:]}"
    return messages


def test_glslang_accepts_every_program(tmp_path: Path) -> None:
    specs = programs("full")
    assert len(specs) > 1000  # every layer count, light rig family, SSS state and lightweight variant
    errors = glslang_check(specs, ShaderLibrary(), tmp_path)
    assert not errors, "glslang refused shaders:\n" + "\n".join(errors[:40])


def test_glslang_step_fails_on_a_planted_violation(tmp_path: Path) -> None:
    """The check is not vacuous: a core-profile violation planted in frame.frag is named by file and line."""
    shaders = tmp_path / "shaders"
    shutil.copytree(default_shader_dir(), shaders)
    frag = shaders / "frame.frag.glsl"
    lines = frag.read_text(encoding="utf-8").splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("void main()")) + 1
    # texture2D and gl_FragColor were removed from the core profile (Mesa's compiler accepts neither either)
    lines.insert(at, "    gl_FragColor = texture2D(u_albedo, v_uv);")
    frag.write_text("\n".join(lines) + "\n", encoding="utf-8")
    out = tmp_path / "out"
    out.mkdir()
    spec = next(p for p in programs("quick") if p.fragment == "frame.frag")
    errors = glslang_check([spec], ShaderLibrary([shaders]), out)
    assert any(e.startswith(f"frame.frag.glsl:{at + 1}: ") for e in errors), errors


_FOR = re.compile(r"\bfor\s*\(\s*int\s+(\w+)\s*=\s*(\d+)\s*;")


def _matching(text: str, at: int, open_: str, close: str) -> int:
    """The index of the bracket closing the one at ``at``."""
    depth = 0
    for k in range(at, len(text)):
        depth += {open_: 1, close: -1}.get(text[k], 0)
        if depth == 0:
            return k
    return len(text)


def loop_subscript_problems(text: str, name: str) -> list[str]:
    """Subscripts ``[v - c]`` on a loop variable ``v`` that are negative for the loop's first values.

    A driver that unrolls the loop compiles the subscript for every value of ``v`` in every branch, taken
    or not; ``[v - c]`` with ``v`` starting below ``c`` is then a constant out-of-range index.
    """
    problems: list[str] = []
    for m in _FOR.finditer(text):
        var, first = m.group(1), int(m.group(2))
        header_end = _matching(text, text.index("(", m.start()), "(", ")")
        k = header_end + 1
        while k < len(text) and text[k] in " \t\r\n\\":
            k += 1
        end = _matching(text, k, "{", "}") if text[k:k + 1] == "{" else text.find(";", k)
        for sub in re.finditer(rf"\[\s*{var}\s*-\s*(\d+)\s*\]", text[k:end + 1]):
            if first < int(sub.group(1)):
                line = text.count("\n", 0, k + sub.start()) + 1
                problems.append(f"{name}:{line}: [{var} - {sub.group(1)}] with {var} from {first}")
    return problems


def test_no_loop_subscript_can_leave_its_array() -> None:
    folder = default_shader_dir()
    problems = [p for f in sorted(folder.glob("*.glsl"))
                for p in loop_subscript_problems(f.read_text(encoding="utf-8"), f.name)]
    assert not problems, "\n".join(problems)
    # the rule sees the defect NVIDIA refused (frame.frag.glsl:192 before the fix)
    bad = ("for (int i = 0; i < NLIGHTS; ++i) {\n"
           "    float sh = i == 0 ? irr.a : i < 5 ? vis0[i - 1] : vis1[i - 5];\n}\n")
    assert len(loop_subscript_problems(bad, "frame.frag.glsl")) == 2
    ok = "for (int d = 1; d <= RI; ++d)\n    W[d] = Q_[d - 1] + Q_[d + 1];\n"
    assert loop_subscript_problems(ok, "sss_gauss3.frag.glsl") == []


@pytest.mark.gl
def test_mesa_builds_every_program(gl_ctx: object) -> None:
    specs = programs("full")
    tried, failures = build_all(gl_ctx, specs)  # type: ignore[arg-type]
    assert tried == len(specs)
    assert not failures, "\n".join(f"{f.spec.label()}: {'; '.join(f.located) or f.log[:300]}"
                                   for f in failures[:20])


def test_build_failures_are_located() -> None:
    """A driver's log lines (NVIDIA's N(L), Mesa's N:L(C), glslang's N:L) are placed in the .glsl files."""
    order = ["frame.frag.glsl", "common.glsl", "lighting.glsl"]
    nv = "fragment_shader\n0(192) : error C1068: array index out of bounds\n1(7) : warning C7050: x"
    assert locate(nv, ["mesh.vert.glsl"], order) == (
        "frame.frag.glsl:192: error C1068: array index out of bounds", "common.glsl:7: warning C7050: x")
    mesa = "vertex_shader\n0:12(3): error: `foo' undeclared"
    assert locate(mesa, ["mesh.vert.glsl"], order) == ("mesh.vert.glsl:12: error: `foo' undeclared",)
    assert locate("ERROR: 2:40: 'x' : undeclared identifier", [], order) == (
        "lighting.glsl:40: 'x' : undeclared identifier",)


class _Recording(ShaderLibrary):
    """A shader library that notes every program it builds."""

    def __init__(self) -> None:
        super().__init__()
        self.built: list[tuple[str, str, tuple[tuple[str, int], ...]]] = []

    def program(self, ctx: Any, vertex: str, fragment: str, defines: dict[str, Any] | None = None) -> Any:
        key = (vertex, fragment, tuple((k, int(v)) for k, v in (defines or {}).items()))
        if key not in self.built:
            self.built.append(key)
        return super().program(ctx, vertex, fragment, defines)


@pytest.mark.gl
def test_the_renderer_builds_nothing_else(gl_ctx: Any) -> None:
    """Frames in many states (bare and made up, fast and reference at several zooms, a debug view, point
    and shadowed lights, an environment, the lightweight engine): every program they build is enumerated."""
    from painting import Document
    from painting.looks import apply_look
    from render.binding import layer_inputs
    from render.lights import Environment, Light
    from render.lightweight import LightweightRenderer
    from render.renderer import Renderer
    from render.settings import RenderSettings

    enumerated = {(p.vertex, p.fragment, p.defines) for p in programs("full")}
    doc = Document.from_head(resolution=256)
    apply_look(doc, "evening")
    lib = _Recording()
    r = Renderer(gl_ctx, doc.head, shaders=lib, layout=doc.layout)
    fbo = gl_ctx.simple_framebuffer((160, 120))
    try:
        r.set_layers(layer_inputs(doc))
        for settings, lights in [
                (RenderSettings(), None),
                (RenderSettings(mode="reference"), None),
                (RenderSettings(mode="reference", reference_full_resolution=True), None),
                (RenderSettings(mode="fast", taps=25, sss_width=2.0), None),
                (RenderSettings(debug_view="thickness"), None),
                (RenderSettings(makeup=False, lighting_cache=False), None),
                (RenderSettings(), [Light.point((0.0, 2.0, 3.0)), Light.directional(40, 10, shadows=True),
                                    Light.directional(-40, 10, shadows=False)])]:
            r.settings = settings
            if lights is not None:
                r.lights = lights
                r.environment = Environment.from_image(np.ones((16, 32, 3), np.float32), "grey")
            for distance in (1.0, 0.25):  # the default framing and a close-up (other SSS tap counts)
                r.camera.distance *= distance
                r.render(fbo)
                r.camera.distance /= distance
        from capture.face import Face
        from capture.phong import PhongParams

        params = PhongParams(diffuse=np.array([0.6, 0.42, 0.33]), specular=0.2, exponent=24.0,
                             ambient_scale=1.0, flash_rgb=np.ones(3), ambient_rgb=np.full(3, 0.02))
        detail = np.ones((*doc.head.albedo.shape[:2], 3), np.float32)
        lw = LightweightRenderer(gl_ctx, doc.head, Face(params=params, detail=detail, data={}), shaders=lib)
        lw.render_image((160, 120))
        lw.makeup = r.km
        lw.render_image((160, 120))
        lw.release()
    finally:
        r.release()
        fbo.release()
    assert len(lib.built) >= 10
    # a rig is enumerated by its families: the same program up to its two light masks (each light's code
    # depends on its own bits; test_light_rig_families_cover_every_light_state)
    modulo_rig = {_without_rig(k) for k in enumerated}
    missing = [b for b in lib.built if b not in enumerated and _without_rig(b) not in modulo_rig]
    assert not missing, f"built but not enumerated by render.programs: {missing}"
    assert any(b not in enumerated for b in lib.built)  # the odd rig above is met by its families only


def _without_rig(key: tuple[str, str, tuple[tuple[str, int], ...]]) -> tuple[object, ...]:
    return key[0], key[1], tuple(d for d in key[2] if d[0] not in ("SHADOWED", "POINT_LIGHTS"))


def test_light_rig_families_cover_every_light_state() -> None:
    from render.lights import MAX_LIGHTS
    from render.programs import light_rigs

    rigs = light_rigs()
    for n in range(MAX_LIGHTS + 1):
        for i in range(n):
            states = {(sh >> i & 1, pt >> i & 1) for count, sh, pt in rigs if count == n}
            assert states == {(0, 0), (0, 1), (1, 0), (1, 1)}, (n, i, states)
        # frame.frag reads the visibility of lights 1-4 (mask 30) and 5-7 (mask 224) only when one casts shadows
        for mask, first in ((30, 1), (224, 5)):
            read = {bool(sh & mask) for count, sh, _ in rigs if count == n}
            assert read == ({False, True} if n > first else {False}), (n, mask, read)
