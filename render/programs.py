"""Every shader program the renderer builds, enumerated from the code that builds it; and building them.

Each module that builds a specialised program computes its defines with a function of its own
(:func:`render.lit_pass.frame_defines`, :func:`render.irradiance.irradiance_defines`,
:func:`render.km_pass.km_defines`, :func:`render.lightweight.face_defines`,
:func:`render.sss_passes.gauss3_defines`, ...); :func:`programs` calls those same functions over the
domains the code gives their arguments (:data:`render.km_pass.MAX_LAYERS`, :data:`render.lights.MAX_LIGHTS`,
:data:`render.km_pass.KM_DTYPES`, :data:`render.settings.FAST_TAPS`, and every step of the SSS tap
functions over all frame scales and widths: :func:`sss_scales`), so a define added to a builder is enumerated here without a second list.

Light rigs are bit masks over up to eight lights (which cast shadows, which are point lights): 4⁸ rigs of
eight lights alone. The loops over lights unroll, and the code of light i depends on its own two bits
only (and on whether any of lights 1-4 or 5-7 is shadowed, which selects the visibility maps read), so
the rigs are covered by families (:func:`light_rigs`) in which every light index of every light count
takes each of its four (shadowed, point) states. Every other define is enumerated over its whole domain,
crossed with the defines it shares a loop with. ``quick`` keeps the extremes of each range (what
``sheer doctor`` builds).

:func:`build_all` builds a list through a GL context as the renderer does
(:meth:`render.shaders.ShaderLibrary.program`) and locates the driver's messages in the ``.glsl`` files
(``file.glsl:line: message``; NVIDIA's ``N(L)`` and Mesa's ``N:L(C)`` forms).
"""

from __future__ import annotations

import itertools
import math
import re
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

from render.errors import RenderError
from render.irradiance import irradiance_defines
from render.km_pass import KM_DTYPES, MAX_LAYERS, default_wavelengths, km_defines
from render.lights import MAX_LIGHTS, Light, rig_shape
from render.lightweight import face_defines
from render.lit_cache import lit_cache_defines
from render.lit_pass import frame_defines
from render.settings import FAST_TAPS
from render.shaders import ShaderLibrary
from render.sss import fast_kernel
from render.sss_passes import fast_taps, gauss3_defines, split_gaussians

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable

    import moderngl

#: the brute-force sub-texel tap count (``SSSPasses.subtexel_taps``) the reference-quality benches use
BRUTE_FORCE_TAPS = 201


@dataclass(frozen=True)
class ProgramSpec:
    """One program: its two shaders, the defines injected after ``#version``, and who builds it.

    Attributes:
        vertex: the vertex shader's name (``"mesh.vert"``).
        fragment: the fragment shader's name (``"frame.frag"``).
        defines: (name, value) pairs in the builder's order.
        engine: ``"physical"`` (the studio's renderer), ``"lightweight"``, ``"mirror"`` (a captured face on
            its photograph) or ``"tools"`` (overlays, copies).
        where: the module that builds it.
    """

    vertex: str
    fragment: str
    defines: tuple[tuple[str, int], ...]
    engine: str
    where: str

    def label(self) -> str:
        """``"mesh.vert + frame.frag {NL=4, NLIGHTS=3, ...}"``."""
        d = ", ".join(f"{k}={v}" for k, v in self.defines)
        return f"{self.vertex} + {self.fragment}" + (f" {{{d}}}" if d else "")


@dataclass(frozen=True)
class BuildFailure:
    """A program the driver refused.

    Attributes:
        spec: the program.
        log: the driver's info log (with Sheer's own first line).
        located: ``file.glsl:line: message`` for each message the log places in a file.
    """

    spec: ProgramSpec
    log: str
    located: tuple[str, ...]


def _spec(vertex: str, fragment: str, defines: dict[str, int], engine: str, where: str) -> ProgramSpec:
    return ProgramSpec(vertex, fragment, tuple((k, int(v)) for k, v in defines.items()), engine, where)


def _bits(n: int, family: str) -> int:
    """A mask over ``n`` lights: ``none``, ``all``, ``first``, ``even`` (0, 2, ...) or ``odd`` lights."""
    every = (1 << n) - 1
    return {"none": 0, "all": every, "first": min(1, every), "even": 0x55 & every, "odd": 0xAA & every}[family]


def light_rigs(quick: bool = False) -> list[tuple[int, int, int]]:
    """Rig shapes (:func:`render.lights.rig_shape`) of real :class:`render.lights.Light` rigs.

    For every light count 0..MAX_LIGHTS: no light special, every light shadowed and a point light, even
    lights shadowed and odd ones points, the reverse (so each light index appears in all four of its
    (shadowed, point) states), and only the first light shadowed (the studio's rig: E alone).
    """
    pairs = [("none", "none"), ("all", "all"), ("even", "odd"), ("odd", "even"), ("first", "none")]
    counts: Iterable[int] = (0, 1, 3, MAX_LIGHTS) if quick else range(MAX_LIGHTS + 1)
    out: list[tuple[int, int, int]] = []
    for n in counts:
        for sh_family, pt_family in (pairs[:2] if quick else pairs):
            sh, pt = _bits(n, sh_family), _bits(n, pt_family)
            rig = [Light("point" if pt >> i & 1 else "directional", shadows=bool(sh >> i & 1)) for i in range(n)]
            shape = rig_shape(rig)
            if shape not in out:
                out.append(shape)
    return out


def _frame_programs(quick: bool) -> list[ProgramSpec]:
    """The lit pass (render/lit_pass.py): every layer state with every rig family; the maps with the studio's."""
    from render.lights import default_lights

    # (n, makeup, debug, cached): makeup needs layers; the cache needs makeup and no debug view
    # (render/renderer.py)
    states = [(n, m, d, c) for n in range(MAX_LAYERS + 1) for m in (0, 1) for d in (0, 1) for c in (0, 1)
              if (not m or n > 0) and (not c or (m and not d))]
    if quick:
        states = [s for s in states if s[0] in (0, 1, MAX_LAYERS)]
    out: list[ProgramSpec] = []
    seen: set[tuple[tuple[str, int], ...]] = set()

    def add(state: tuple[int, int, int, int], rig: tuple[int, int, int], mp: tuple[int, ...]) -> None:
        spec = _spec("mesh.vert", "frame.frag", frame_defines(state[0], rig, bool(state[1]), bool(state[2]),
                                                                bool(state[3]), *map(bool, mp)),
                     "physical", "render/lit_pass.py")
        if spec.defines not in seen:
            seen.add(spec.defines)
            out.append(spec)

    # the light loop holds the layers' lobes (NL, MAKEUP, CACHED): states and rigs are crossed; the head's
    # maps are read outside it, so they are crossed with the states under the studio's rig alone
    for state in states:
        for rig in light_rigs(quick):
            add(state, rig, (1, 1, 1))
        for mp in itertools.product((0, 1), repeat=3):
            add(state, rig_shape(default_lights()), mp)
    return out


def step_points(f: Callable[[float], object], lo: float, hi: float) -> list[float]:
    """Where a monotone step function ``f`` of σ changes on [``lo``, ``hi``] (each to 1e-9 relative).

    Monotone: equal values at an interval's ends mean no change inside, so bisecting the intervals whose
    ends differ finds every step (:func:`render.sss.reference_taps`, :func:`render.sss.integer_radius` with
    None as infinity, a threshold).
    """
    out: list[float] = []

    def bisect(a: float, fa: object, b: float, fb: object) -> None:
        if fa == fb:
            return
        if b - a <= 1e-9 * b:
            out.append(b)
            return
        m = 0.5 * (a + b)
        fm = f(m)
        bisect(a, fa, m, fm)
        bisect(m, fm, b, fb)

    grid = [lo * (hi / lo) ** (i / 256) for i in range(257)]
    values = [f(x) for x in grid]
    for i in range(256):
        bisect(grid[i], values[i], grid[i + 1], values[i + 1])
    return out


def sss_scales() -> list[float]:
    """Every distinct SSS state: values of t = SSS width / (mm per full-resolution pixel).

    The passes' defines depend on the frame's scale and the width setting only through t (each Gaussian
    is σ_i = c_i·t pixels). They change where a Gaussian (at full or at half resolution) crosses a step
    of :func:`render.sss.reference_taps`, :func:`render.sss.integer_radius`, the half-resolution split
    (:func:`render.sss_passes.split_gaussians`) or :func:`render.sss_passes.fast_taps`' range: each such
    t, and a t between each two, is returned, from t → 0 to past the last step.
    """
    from render.sss import SKIN_GAUSSIANS, integer_radius, reference_taps
    from render.sss_passes import FEW_TAPS_MAX_RANGE_PX

    sigma_steps: list[float] = [3.0]  # the half-resolution split: σ ≥ 3 pixels
    sigma_steps += step_points(reference_taps, 1e-3, 1e3)
    sigma_steps += step_points(lambda s: integer_radius(s) or 10 ** 9, 1e-3, 1e3)
    coefficients = [math.sqrt(var) for var, *_ in SKIN_GAUSSIANS]
    ts: set[float] = set()
    for c in coefficients:
        for sigma in sigma_steps:
            for scale in (1.0, 0.5):  # a half-resolution pass sees σ / 2
                ts.add(sigma / (c * scale))
    ts.add(FEW_TAPS_MAX_RANGE_PX / (3.0 * max(coefficients)))
    edges = sorted(ts)
    mids = [math.sqrt(a * b) for a, b in itertools.pairwise(edges)]
    return sorted({edges[0] / 2, *edges, *mids, edges[-1] * 2})


def _sss_programs(quick: bool) -> list[ProgramSpec]:
    """The SSS passes (render/sss_passes.py) in every state :func:`sss_scales` finds."""
    from render.sss import reference_taps

    fast: set[int] = set()
    gauss: set[int] = set()
    gauss3: list[dict[str, int]] = []
    for t in sss_scales():
        mm_per_px = 1.0 / t  # at width 1
        for taps in FAST_TAPS:
            fast.add(len(fast_kernel(fast_taps(taps, 1.0, mm_per_px), 1.0, core_mm=1.5 * mm_per_px)))
        for full_res, integer_taps, subtexel in itertools.product((False, True), (True, False),
                                                                  (None, BRUTE_FORCE_TAPS)):
            if subtexel and integer_taps:
                continue
            half, full = split_gaussians(1.0, mm_per_px, full_res)
            for sigma, _ in half:  # the horizontal pass at full, the vertical at half resolution
                gauss.add(reference_taps(sigma / mm_per_px))
                gauss.add(reference_taps(sigma / mm_per_px * 0.5))
            for i in range(0, len(full), 3):  # SSSPasses.full_per_pass
                d = gauss3_defines([sigma / mm_per_px for sigma, _ in full[i:i + 3]], integer_taps, subtexel)
                if d not in gauss3:
                    gauss3.append(d)
    if quick:  # the extremes: fewest and most taps of each group size
        keep: list[dict[str, int]] = []
        for ng in (1, 2, 3):
            same = [d for d in gauss3 if d["NG"] == ng]
            keep += [d for d in (same[:1] + same[-1:]) if d not in keep]
        gauss3 = keep
        fast = {min(fast), max(fast)}
        gauss = {min(gauss), max(gauss)}
    where = "render/sss_passes.py"
    return ([_spec("fullscreen_z.vert", "sss_fast.frag", {"NTAPS": t}, "physical", where) for t in sorted(fast)]
            + [_spec("fullscreen_z.vert", "sss_gauss.frag", {"NTAPS": t}, "physical", where) for t in sorted(gauss)]
            + [_spec("fullscreen_z.vert", "sss_gauss3.frag", {**d, "VERT": v}, "physical", where)
               for d in gauss3 for v in (0, 1)])


def programs(level: str = "full") -> list[ProgramSpec]:
    """Every program the renderer builds (``level`` ``"full"``), or the extremes of each range (``"quick"``).

    Raises:
        RenderError: an unknown level.
    """
    if level not in ("full", "quick"):
        raise RenderError(f"shader check level must be 'full' or 'quick', got {level!r}")
    quick = level == "quick"
    out: list[ProgramSpec] = []
    fixed = [("km_tiles.vert", "km_copy.frag", "physical", "render/km_pass.py"),
             ("mesh.vert", "baseline.frag", "physical", "render/renderer.py"),
             ("fullscreen_z.vert", "sss_mask.frag", "physical", "render/sss_passes.py"),
             ("shadow.vert", "shadow.frag", "physical", "render/lights.py, render/lightweight.py"),
             ("lightweight_eye.vert", "lightweight_eye.frag", "lightweight", "render/lightweight.py"),
             ("mirror_face.vert", "depth_only.frag", "mirror", "render/mirror.py"),
             ("fullscreen.vert", "mirror_photo.frag", "mirror", "render/mirror.py"),
             ("mesh.vert", "depth_only.frag", "tools", "render/region_overlay.py, render/ring.py"),
             ("mesh.vert", "region_outline.frag", "tools", "render/region_overlay.py"),
             ("mesh.vert", "brush_ring.frag", "tools", "render/ring.py"),
             ("frame_copy.vert", "frame_copy.frag", "tools", "render/view.py")]
    out += [_spec(v, f, {}, engine, where) for v, f, engine, where in fixed]
    nw = len(default_wavelengths())
    layers = (0, 1, MAX_LAYERS) if quick else range(MAX_LAYERS + 1)
    out += [_spec("km_tiles.vert", "km.frag", km_defines(n, nw, dtype), "physical", "render/km_pass.py")
            for n in layers for dtype in KM_DTYPES]
    # the lighting cache: layers 4-7's specular weights with more than four layers (render/lit_cache.py)
    out += [_spec("km_tiles.vert", "lit_cache.frag", lit_cache_defines(n), "physical", "render/lit_cache.py")
            for n in (4, 5)]
    # the composite: SSS off (0), reference (1) or fast (2), with or without the debug views
    out += [_spec("composite.vert", "composite.frag", {"MODE": m, "DEBUG": d}, "physical", "render/renderer.py")
            for m in (0, 1, 2) for d in (0, 1)]
    out += _frame_programs(quick)
    # the texture-space irradiance: E alone when no light but the first casts shadows
    irr: list[ProgramSpec] = []
    for rig, env, only in itertools.product(light_rigs(quick), (False, True), (False, True)):
        if only and rig[1] & ~1:
            continue
        spec = _spec("uvspace.vert", "irradiance.frag", irradiance_defines(rig, env, only), "physical",
                     "render/irradiance.py")
        if spec not in irr:
            irr.append(spec)
    out += irr
    out += [_spec("fullscreen.vert", "pad_gather.frag", {"IRR_ONLY": i}, "physical", "render/irradiance.py")
            for i in (0, 1)]
    out += _sss_programs(quick)
    # the lightweight engine: every light count, shadow mode, environment, and the layers' lobes
    lw: list[ProgramSpec] = []
    counts = (0, 1, MAX_LIGHTS) if quick else range(MAX_LIGHTS + 1)
    lobes = (0, MAX_LAYERS) if quick else range(MAX_LAYERS + 1)
    for n, shadows, env, makeup in itertools.product(counts, (0, 1, 2), (False, True), (False, True)):
        for nl in (lobes if makeup else (0,)):
            if quick and env != makeup:
                continue
            lw.append(_spec("lightweight_face.vert", "lightweight_face.frag",
                            face_defines(n, shadows, env, makeup, nl), "lightweight", "render/lightweight.py"))
    out += lw
    # a captured face on its photograph, 0..MAX_LAYERS layers (render/mirror.py)
    out += [_spec("mirror_face.vert", "mirror_face.frag", {"MV_NL": n}, "mirror", "render/mirror.py")
            for n in ((0, 1, MAX_LAYERS) if quick else range(MAX_LAYERS + 1))]
    return out


_NV = re.compile(r"^\s*(\d+)\((\d+)\)\s*:\s*(.*)$")
_MESA = re.compile(r"^\s*(\d+):(\d+)\((\d+)\):\s*(.*)$")
_GLSLANG = re.compile(r"^\s*(?:ERROR|WARNING):\s*(\d+):(\d+):\s*(.*)$")
_STAGE = re.compile(r"(vertex|fragment)", re.IGNORECASE)


def locate(log: str, vertex_files: list[str], fragment_files: list[str]) -> tuple[str, ...]:
    """``file.glsl:line: message`` for each line of a compiler or linker log that names a place.

    ``vertex_files``/``fragment_files``: each stage's files in include order (the ``N`` of ``#line L N``,
    :meth:`render.shaders.ShaderLibrary.include_order`). A log's stage is read from its section headers
    (moderngl's ``vertex_shader``/``fragment_shader``, NVIDIA's ``Vertex info``/``Fragment info``).
    """
    files = fragment_files
    out: list[str] = []
    for line in log.splitlines():
        m = _NV.match(line) or _MESA.match(line) or _GLSLANG.match(line)
        if not m:
            stage = _STAGE.search(line) if len(line) < 40 else None
            if stage:
                files = vertex_files if stage.group(1).lower() == "vertex" else fragment_files
            continue
        idx, lineno, msg = int(m.group(1)), int(m.group(2)), m.groups()[-1]
        where = files[idx] if idx < len(files) else f"file {idx}"
        entry = f"{where}:{lineno}: {msg.strip()}"
        if entry not in out:
            out.append(entry)
    return tuple(out)


_DEFINE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class StageSources:
    """The stages' sources as :meth:`render.shaders.ShaderLibrary.source` gives them, each shader read once.

    A program's stage is its shader's expanded text (includes resolved) with the program's defines after
    the ``#version`` line; the expansion is the same for every program, so it is done once per shader
    (and checked against ``source`` on first use: a shader whose text this cannot rebuild exactly is
    asked of the library each time).
    """

    def __init__(self, lib: ShaderLibrary) -> None:
        self.lib = lib
        self._parts: dict[str, tuple[str, str] | None] = {}  # name -> (#version line, the rest)
        self._names: dict[str, frozenset[str]] = {}

    def source(self, name: str, defines: dict[str, object]) -> str:
        """``ShaderLibrary.source(name, defines)``."""
        if name not in self._parts:
            plain = self.lib.source(name, {})
            version, _, rest = plain.partition("\n")
            self._parts[name] = (version, rest)
            if self._join(name, defines) != self.lib.source(name, dict(defines)):
                self._parts[name] = None
        if self._parts[name] is None or not all(_DEFINE_NAME.fullmatch(k) for k in defines):
            return self.lib.source(name, dict(defines))  # the library's own text (or its error)
        return self._join(name, defines)

    def _join(self, name: str, defines: dict[str, object]) -> str:
        parts = self._parts[name]
        assert parts is not None
        return "".join([parts[0], "\n", *(f"#define {k} {v}\n" for k, v in defines.items()), parts[1]])

    def used_defines(self, name: str, defines: dict[str, object]) -> dict[str, object]:
        """The ``defines`` shader ``name`` can see (a compiler sees nothing else of the others).

        Those whose name its text (includes resolved) contains as a word, those the values of these
        contain, and so on; of the others a compiler sees only their own ``#define`` lines (macros never
        expanded).
        """
        if name not in self._names:
            self._names[name] = frozenset(_DEFINE_NAME.findall(self.lib.source(name, {})))
        words = self._names[name]
        used: set[str] = set()
        todo = [k for k in defines if k in words]
        while todo:
            k = todo.pop()
            if k not in used:
                used.add(k)
                todo += [w for w in _DEFINE_NAME.findall(str(defines[k])) if w in defines]
        return {k: v for k, v in defines.items() if k in used}


def build_all(ctx: moderngl.Context, specs: list[ProgramSpec], shaders: ShaderLibrary | None = None,
              deadline_s: float | None = None) -> tuple[int, list[BuildFailure]]:
    """Build (and release) each program on ``ctx``; returns (programs tried, the failures among them).

    ``deadline_s``: start no program after this many seconds (the count says how many were tried).
    The sources are :meth:`render.shaders.ShaderLibrary.source`'s (through :class:`StageSources`: each
    shader expanded once) and a refused program's log reads as :meth:`ShaderLibrary.program`'s.
    """
    lib = shaders or ShaderLibrary()
    sources = StageSources(lib)
    t0 = time.perf_counter()
    tried = 0
    failures: list[BuildFailure] = []
    for spec in specs:
        if deadline_s is not None and time.perf_counter() - t0 > deadline_s:
            break
        try:
            defines = dict(spec.defines)
            vs, fs = sources.source(spec.vertex, defines), sources.source(spec.fragment, defines)
            try:
                ctx.program(vertex_shader=vs, fragment_shader=fs).release()
            except Exception as exc:  # moderngl raises its own Error with the compiler log
                raise RenderError(f"shader program {spec.vertex} + {spec.fragment} failed to build: {exc}") from None
        except RenderError as exc:
            log = str(exc)
            failures.append(BuildFailure(spec, log, locate(log, lib.include_order(spec.vertex),
                                                           lib.include_order(spec.fragment))))
        tried += 1
    return tried, failures
