"""Catalogue renders at scale: every head × look × product × light × view, as a resumable batch on Dask.

A TOML spec (:mod:`catalogue.spec`, schema ``resources/catalogue.schema.json``, documented in
``docs/CATALOGUE.md``) expands into jobs named by a hash of everything that determines their pixels
(:mod:`catalogue.jobs`); :mod:`catalogue.driver` runs them on Dask distributed (an embedded
``LocalCluster`` of worker processes, or an existing cluster), each worker its even share of them
(:mod:`catalogue.balance`), where each worker process owns one headless GL context, on its own EGL device
when there are several, and its caches (:mod:`catalogue.worker`); :mod:`catalogue.sheets` draws the contact sheets and
:mod:`catalogue.glb` writes the made-up head as GLB.

What catalogue may import: ``render`` and ``capture`` and every layer below them, and Dask; never
``app`` nor Qt (import-linter checks this; see ``pyproject.toml``)::

    from catalogue import load_spec, expand, run_catalogue

    spec = load_spec("spring.toml")              # CatalogueError naming the key, before any work
    jobs = expand(spec)                          # list[Job], each with .key (sha256) and .out (path)
    result = run_catalogue(spec, "out/", jobs=jobs, workers=2)   # RunResult: rendered, skipped, failed
"""

from __future__ import annotations

from core.lazy import install_lazy

#: public name -> module that defines it
_EXPORTS: dict[str, str] = {
    "CatalogueError": "catalogue.errors",
    "Spec": "catalogue.spec",
    "load_spec": "catalogue.spec",
    "Job": "catalogue.jobs",
    "expand": "catalogue.jobs",
    "estimate_seconds": "catalogue.jobs",
    "run_catalogue": "catalogue.driver",
    "RunResult": "catalogue.driver",
}

__getattr__, __dir__, __all__ = install_lazy(__name__, _EXPORTS)
