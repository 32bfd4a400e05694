"""``Document.prepare_painting``: the first dab's loads done ahead, safely beside painting."""

from __future__ import annotations

import dataclasses
import threading

from tests.painting.helpers import make_doc


def test_prepare_painting_loads_the_index_once_across_threads() -> None:
    doc = make_doc()
    doc._atlases[doc.resolution] = dataclasses.replace(doc.atlas, _index=None)  # not the shared atlas's
    assert doc.atlas._index is None
    seen = []
    threads = [threading.Thread(target=lambda: seen.append(doc.atlas.index)) for _ in range(4)]
    prep = threading.Thread(target=doc.prepare_painting)
    for t in (*threads, prep):
        t.start()
    for t in (*threads, prep):
        t.join()
    assert doc.atlas._index is not None
    assert all(ix is doc.atlas._index for ix in seen), "the index was loaded more than once"
