"""Every ``sheer bench …`` command and the project fuzzer: measurements, outside the runtime graph.

Each benchmark is a module with ``main(argv) -> int`` that prints one JSON object (:mod:`bench.cli` maps
names to modules): :mod:`bench.km` (the CPU KM reference), :mod:`bench.paint` (dabs, strokes, undo),
:mod:`bench.render` (frames and passes), :mod:`bench.lightweight` (the Phong relighting engine),
:mod:`bench.studio` (the studio as a user sees it), :mod:`bench.fuzz` (damaged files, crash-during-save),
:mod:`bench.project` (saving and opening a ``.sheer`` project); :mod:`bench.stats` summarises timed series.

May import every Sheer package; no runtime package imports it (``sheer bench`` finds :mod:`bench.cli` by
name, so a build without it still runs).
"""
