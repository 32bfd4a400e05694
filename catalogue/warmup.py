"""Warm a catalogue worker while it starts: a Dask worker *preload* (``dask worker --preload catalogue.warmup``).

A cold worker's first job costs about a second more than the next ones (measured on the 2-core llvmpipe
machine: 1.0 s against 0.1 s): the EGL context, the renderer's and the look code's imports, Mesa compiling
the shader programs, PIL's PNG encoder. :func:`dask_setup` is Dask's preload hook: it queues
:func:`warm_up` on the worker's own task thread (the thread that later owns the job's GL context — an EGL
context is current in one thread only), so the warm-up runs while the rest of the cluster starts and the
driver expands the spec, instead of inside the first job. Jobs submitted meanwhile wait behind it in that
thread's queue — behind this worker's own warm-up only: the driver gives every worker its share of the
runs at once (:mod:`catalogue.balance`), so each starts work as soon as it is warm, and one that is ready
late finds its share waiting instead of the first-ready workers having taken it. Nothing the warm-up
makes changes an image's bytes (the caches it fills are the ones a job fills itself, and a throwaway
renderer is released). The context is made on the worker's own EGL device (round robin where there are
several: :meth:`catalogue.worker.WorkerState.context`).

The embedded ``LocalCluster`` of :func:`catalogue.driver.dask_client` preloads it; on a real cluster start
workers with ``dask worker ADDRESS --nthreads 1 --preload catalogue.warmup`` (optional: without it the
first job of each worker is simply slower).
"""

from __future__ import annotations

import logging
import time
from typing import Any

#: This module's name, as ``LocalCluster(preload=…)`` and ``dask worker --preload`` take it.
PRELOAD = __name__
#: The side of the throwaway frame (pixels): enough to run every pass once.
WARM_SIZE = 64

log = logging.getLogger(__name__)


def warm_up() -> float:
    """Make this thread's GL context and run every renderer pass once on the sample head; seconds taken.

    Never raises: a worker that cannot warm up (no sample head, no GL) still takes jobs, which then report
    their own errors.
    """
    t0 = time.perf_counter()
    try:
        from catalogue.worker import encode_png, worker_state, worker_version
        from painting import Document
        from painting.head import load_head
        from painting.looks import apply_look, load_look
        from render import Renderer
        from render.binding import layer_inputs

        worker_version()  # hashes the renderer's source: the driver asks for it before any job
        state = worker_state()
        ctx = state.context()  # on this worker's own EGL device (round robin over several)
        head = load_head(None)
        doc = Document(head, resolution=256)
        apply_look(doc, load_look("red-lip"))
        renderer = Renderer(ctx, head, layout=doc.layout)
        try:
            renderer.set_layers(layer_inputs(doc, doc.library))
            encode_png(renderer.render_image((WARM_SIZE, WARM_SIZE)))
        finally:
            renderer.release()
    except Exception as exc:  # a warm-up is an optimisation: say why it failed and carry on
        log.warning("catalogue worker warm-up failed: %s", exc)
    return time.perf_counter() - t0


def dask_setup(worker: Any) -> None:
    """Dask's preload hook: queue :func:`warm_up` on the worker's task thread (returns at once).

    It first notes the worker's index (from its name, :func:`catalogue.worker.worker_index`), which picks
    its EGL device when the machine has several.
    """
    from catalogue.worker import worker_index, worker_state

    worker_state().index = worker_index(getattr(worker, "name", None))
    executor = getattr(worker, "executors", {}).get("default")
    if executor is not None:
        executor.submit(warm_up)
