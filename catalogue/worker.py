"""The worker side: one headless GL context per process and the caches reused across its jobs.

A Dask worker process (one thread) runs :func:`render_chunk` for runs of jobs sharing a head, look and
lighting. The process keeps, in :class:`WorkerState`: one standalone EGL context, the heads it loaded, the
painted documents (the look's thickness maps), one :class:`render.Renderer` per head (mesh upload,
shadow maps and texture-space irradiance, recomputed only when the lighting changes) and which layers it
holds (the KM texture-space evaluation is redone only when the product or look changes). Jobs of one
head, look and lighting therefore cost a frame each.

Every output is written atomically (:mod:`core.atomicio`) under a name that carries its content hash, so a
job re-run after a worker died finds what is already written and skips it. A failing job is reported
(not raised), the GL state is dropped and rebuilt for the next job.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import io
import os
import socket
import time
from collections import OrderedDict
from pathlib import Path
from typing import TYPE_CHECKING, Any

from catalogue.errors import CatalogueError

if TYPE_CHECKING:
    import moderngl
    import numpy as np

    from catalogue.jobs import Job
    from catalogue.spec import LightRig
    from km.library import Library
    from painting import Document
    from painting.head import Head
    from render import Renderer

#: Heads and renderers (one GPU upload each) and documents kept per worker process.
KEEP_HEADS, KEEP_DOCUMENTS = 2, 4

_STATE: WorkerState | None = None


@functools.cache
def worker_version() -> str:
    """The renderer version of the code this process loaded (computed once, on first use)."""
    from catalogue.jobs import renderer_version

    return renderer_version()


def worker_state() -> WorkerState:
    """This process's state (made on first use)."""
    global _STATE
    if _STATE is None:
        _STATE = WorkerState()
    return _STATE


def worker_index(name: Any = None) -> int | None:
    """A Dask worker's index among its cluster's workers, from its name; None when the name has none.

    ``LocalCluster`` names its workers 0, 1, …; ``dask worker --name render --nworkers 4`` names them
    render-0 … render-3. Without ``name``, this process's Dask worker's name (None outside a worker).

    Args:
        name: a worker's name (an int or a str).
    """
    if name is None:
        try:
            from distributed import get_worker

            name = get_worker().name
        except (ImportError, ValueError):
            return None
    if isinstance(name, int) and not isinstance(name, bool):
        return name if name >= 0 else None
    text = str(name)
    tail = text.rsplit("-", 1)[-1]
    return int(tail) if tail.isascii() and tail.isdigit() else None


def render_chunk(jobs: list[Job], out_dir: str, force_before: float | None = None) -> list[dict[str, Any]]:
    """Render ``jobs`` into ``out_dir`` in order (a Dask task); never raises for a job's failure.

    Args:
        jobs: jobs sharing a head, look and lighting (see :func:`catalogue.jobs.chunks`).
        out_dir: the output folder (absolute; the same path on every worker).
        force_before: with ``--force``, the run's start (epoch seconds): files older than that are
            rendered again, newer ones (written by this run, e.g. before a worker died) are kept.

    Returns:
        One result per job: ``key``, ``out``, ``status`` ("rendered", "exists" or "failed"), ``seconds``
        (render and write time, or None), ``error`` (a one-line reason, or None), ``worker``.
    """
    state = worker_state()
    return [state.run(job, Path(out_dir), force_before) for job in jobs]


def encode_png(image: np.ndarray) -> bytes:
    """PNG bytes of a uint8 image, deterministic (no time stamp or other metadata).

    zlib level 1: at 640×640 it encodes in a third of level 6's time for files about 15 % larger.
    """
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG", optimize=False, compress_level=1)
    return buf.getvalue()


class WorkerState:
    """One worker process's GL context and caches (see the module docstring).

    Attributes:
        ctx: the standalone EGL context (GL 4.5 core), made on first use (:meth:`context`).
        index: this worker's index among the cluster's workers (set by the preload, else read from the
            Dask worker's name when the context is made: :func:`worker_index`), or None.
        device: the EGL device the context was made on (None: EGL's default).
        counters: how often each cache missed ("heads", "documents", "renderers", "layers", "lights")
            and how many jobs ran ("jobs"): for tests and benchmarks.
    """

    def __init__(self) -> None:
        self.ctx: moderngl.Context | None = None
        self.index: int | None = None
        self.device: int | None = None
        self.identity = f"{socket.gethostname()}:{os.getpid()}"
        self.counters = dict.fromkeys(("jobs", "heads", "documents", "renderers", "layers", "lights"), 0)
        self._heads: OrderedDict[str, Head] = OrderedDict()
        self._docs: OrderedDict[tuple[str, str, int], Document] = OrderedDict()
        self._renderers: OrderedDict[str, Renderer] = OrderedDict()
        self._held: dict[str, tuple[str, ...]] = {}  # per head: the layers key, the lights key
        self._libraries: dict[str, Library] = {}
        self._lightweight: dict[str, Any] = {}

    def context(self) -> moderngl.Context:
        """This process's GL context, made on first use on the worker's own EGL device.

        Worker ``index`` takes device ``index`` mod the devices present when there are several
        (:func:`render.context.round_robin_device`; ``SHEER_EGL_DEVICE`` pins one). If the round robin's
        device cannot make a context, EGL's default device does (with a warning).

        Raises:
            render.errors.RenderError: ``SHEER_EGL_DEVICE`` is bad (one line, naming it).
        """
        if self.ctx is not None:
            return self.ctx
        from render.context import pinned_device, round_robin_device, standalone_context

        if self.index is None:
            self.index = worker_index()
        device = round_robin_device(self.index)
        try:
            self.ctx = standalone_context(device)
        except Exception as exc:
            if device is None or pinned_device() is not None:
                raise
            import logging

            logging.getLogger(__name__).warning("EGL device %d failed (%s); using the default device", device,
                                                exc)
            device = None
            self.ctx = standalone_context(None)
        self.device = device
        return self.ctx

    # -- one job ----------------------------------------------------------------------------------
    def run(self, job: Job, out_dir: Path, force_before: float | None = None) -> dict[str, Any]:
        """Render and write one job unless its output exists (see :func:`render_chunk`)."""
        target = out_dir / job.out
        result: dict[str, Any] = {"key": job.key, "out": job.out, "status": "exists", "seconds": None,
                                  "error": None, "worker": self.identity}
        try:
            if target.exists() and (force_before is None or target.stat().st_mtime >= force_before):
                return result
        except OSError:
            pass
        t0 = time.perf_counter()
        try:
            data = self.render(job)
            from core.atomicio import atomic_write_bytes

            target.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_bytes(target, data)
        except Exception as exc:  # isolate the job: report it, rebuild the GL state for the next one
            from core.errors import SheerError

            self.reset()
            reason = str(exc) if isinstance(exc, (SheerError, OSError)) else f"{type(exc).__name__}: {exc}"
            result.update(status="failed", error=reason.splitlines()[0] if reason else type(exc).__name__)
            return result
        result.update(status="rendered", seconds=round(time.perf_counter() - t0, 4))
        return result

    def render(self, job: Job) -> bytes:
        """The bytes of ``job``'s output (a PNG, or a GLB).

        Raises:
            CatalogueError: the job comes from a Sheer with another renderer version.
        """
        if job.version != worker_version():
            raise CatalogueError(f"this worker ({self.identity}) runs another Sheer: renderer version "
                                 f"{worker_version()[:12]}, the driver's {job.version[:12]}")
        self.counters["jobs"] += 1
        self.context()
        head = self._head(job)
        doc = self._document(job, head)
        library = self._library(job)
        inputs = self._inputs(job, doc, library)
        if job.kind == "glb":
            from catalogue.glb import baked_albedo, gltf_export

            data = gltf_export(doc.head, baked_albedo(doc, library, self.ctx, inputs), ".glb")
            assert isinstance(data, bytes)
            return data
        return encode_png(self._image(job, doc, inputs))

    # -- caches -----------------------------------------------------------------------------------
    def _head(self, job: Job) -> Head:
        if job.look.project is not None:
            return self._document(job, None).head
        head = self._heads.get(job.head_hash)
        if head is None:
            from catalogue.jobs import load_source_head

            self.counters["heads"] += 1
            head = load_source_head(job.head)
            _keep(self._heads, job.head_hash, head, KEEP_HEADS)
        return head

    def _document(self, job: Job, head: Head | None) -> Document:
        key = (job.head_hash, job.look_hash, job.resolution)
        doc = self._docs.get(key)
        if doc is None:
            self.counters["documents"] += 1
            if job.look.project is not None:
                from project.document import document_from_project
                from project.io import open_project

                doc = document_from_project(open_project(job.look.project))
            else:
                from painting import Document
                from painting.looks import apply_look, load_look

                doc = Document(head, resolution=job.resolution, library=self._library(job))
                apply_look(doc, load_look(str(job.look.look)))
            _keep(self._docs, key, doc, KEEP_DOCUMENTS)
        return doc

    def _library(self, job: Job) -> Library:
        import km

        key = hashlib.sha256(repr(job.materials).encode()).hexdigest()
        lib = self._libraries.get(key)
        if lib is None:
            import json

            lib = km.Library([km.Material.from_json(json.loads(text), where=name) for name, text in job.materials],
                             name="catalogue job materials")
            self._libraries = {key: lib}  # jobs of a run share few material sets; keep the last
        return lib

    def _inputs(self, job: Job, doc: Document, library: Library) -> list[Any]:
        from render.binding import layer_inputs

        inputs = layer_inputs(doc, library)
        for k in job.swap:
            inputs[k] = dataclasses.replace(inputs[k], material=library.get(str(job.product)))
        return inputs

    def _renderer(self, job: Job, doc: Document) -> Renderer:
        r = self._renderers.get(job.head_hash)
        if r is None:
            from render import Renderer

            self.counters["renderers"] += 1
            assert self.ctx is not None
            r = Renderer(self.ctx, doc.head, layout=doc.layout)
            old = _keep(self._renderers, job.head_hash, r, KEEP_HEADS)
            if old is not None:
                old[1].release()
                self._held.pop(old[0], None)
        return r

    # -- the image --------------------------------------------------------------------------------
    def _image(self, job: Job, doc: Document, inputs: list[Any]) -> np.ndarray:
        assert job.light is not None and job.view is not None
        r = self._renderer(job, doc)
        held = self._held.get(job.head_hash, ("", ""))
        layers_key = f"{job.look_hash}:{job.resolution}:{job.product}:{hash(job.materials)}"
        if held[0] != layers_key:
            self.counters["layers"] += 1
            r.set_layers(inputs)
        light_key = repr(job.light)
        if held[1] != light_key:
            self.counters["lights"] += 1
            r.lights = rig_lights(job.light)
            r.environment = _environment(job.light)
        self._held[job.head_hash] = (layers_key, light_key)
        # the direct path, always: the texture-space lighting cache is skipped on the frame right after a
        # lighting change, so with it a frame's pixels would depend on the jobs this worker ran before
        r.settings.lighting_cache = False
        r.settings.exposure = job.exposure
        r.camera.yaw, r.camera.pitch = job.view.yaw, job.view.pitch
        if job.mode != "lightweight":
            r.settings.mode = job.mode
            return r.render_image(job.size)
        return self._lightweight_image(job, r)

    def _lightweight_image(self, job: Job, r: Renderer) -> np.ndarray:
        """The captured face by the lightweight engine, with ``r``'s camera, lights and KM maps as the makeup."""
        lw = self._lightweight.get(job.head_hash)
        if lw is None:
            from capture.face import load_face
            from render.lightweight import LightweightRenderer

            assert self.ctx is not None and job.head.face is not None
            lw = LightweightRenderer(self.ctx, r.head, load_face(job.head.face))
            for old in self._lightweight.values():
                old.release()
            self._lightweight = {job.head_hash: lw}
        lw.camera, lw.lights, lw.environment = r.camera, list(r.lights), r.environment
        lw.exposure = job.exposure
        lw.makeup = r.km if r.km.active else None
        return lw.render_image(job.size)

    def reset(self) -> None:
        """Drop every GL object and the context (after a failure); the caches on the CPU side stay."""
        with contextlib.suppress(Exception):  # the context may be what failed: drop it whatever objects say
            for lw in self._lightweight.values():
                lw.release()
            for r in self._renderers.values():
                r.release()
        self._lightweight, self._renderers, self._held = {}, OrderedDict(), {}
        if self.ctx is not None:
            with contextlib.suppress(Exception):
                self.ctx.release()
            self.ctx = None


def _keep(cache: OrderedDict[Any, Any], key: Any, value: Any, limit: int) -> tuple[Any, Any] | None:
    """Put ``value`` in an LRU ``cache``; returns the (key, value) evicted, if any."""
    cache[key] = value
    cache.move_to_end(key)
    return cache.popitem(last=False) if len(cache) > limit else None


def rig_lights(rig: LightRig) -> list[Any]:
    """The ``render.Light`` list of a lighting (a preset, or its directional lights)."""
    from catalogue.spec import LIGHT_PRESETS
    from render.lights import Light, default_lights

    if rig.directional:
        return [Light.directional(az, el, inten) for az, el, inten in rig.directional]
    preset = LIGHT_PRESETS[str(rig.preset)]
    if preset is None:
        return default_lights()
    return [Light.directional(az, el, inten, colour, shadows=shadows) for az, el, inten, colour, shadows in preset]


_ENVIRONMENTS: dict[tuple[str, float], Any] = {}


def _environment(rig: LightRig) -> Any:
    """The rig's ``render.Environment`` (read once per process), or None."""
    if rig.environment is None:
        return None
    key = (rig.environment, rig.environment_intensity)
    if key not in _ENVIRONMENTS:
        from render.lights import Environment

        _ENVIRONMENTS[key] = Environment.load(rig.environment, rig.environment_intensity)
    return _ENVIRONMENTS[key]
