"""The three caches keyed by painting code (a look's painted maps, the derived regions, a mask recipe's values)
take that code's digest from :func:`core.cache.source_digest`: an edit of any module a key names is a new
key, the same bytes are the same key, and a module outside the list does not matter."""

from __future__ import annotations

import shutil
from typing import TYPE_CHECKING

import pytest

from core.cache import forget_source_digests
from painting import Document, LayerMask, document_masks, looks, mask

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator
    from pathlib import Path


@pytest.fixture(scope="module")
def doc() -> Document:
    return Document.from_head(None, resolution=256)


@pytest.fixture(autouse=True)
def _fresh(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    monkeypatch.setenv("SHEER_CACHE_DIR", str(tmp_path / "cache"))
    forget_source_digests()
    yield
    forget_source_digests()


def _keys(doc: Document) -> dict[str, Callable[[], object]]:
    recipe = LayerMask((("union", "lips"),), feather_mm=2.0)
    texel_mm = doc.atlas_at(256).texel_mm
    return {
        "_MAPS_SOURCES": lambda: looks._maps_cache_path(doc, looks.Look("plain"), []),
        "_REGIONS_SOURCES": lambda: doc._regions_cache_path(),
        "_RECIPE_SOURCES": lambda: mask._recipe_cache_path(recipe, doc.regions, 256, texel_mm),
    }


CALLERS = {"_MAPS_SOURCES": looks, "_REGIONS_SOURCES": document_masks, "_RECIPE_SOURCES": mask}


def test_each_key_names_the_modules_that_compute_its_value() -> None:
    names = {attr: {p.name for p in getattr(module, attr)} for attr, module in CALLERS.items()}
    assert {"stroke.py", "brush.py", "kernels.py", "looks.py", "mask.py", "regions.py"} <= names["_MAPS_SOURCES"]
    assert names["_REGIONS_SOURCES"] == {"regions.py", "region_shapes.py"}
    assert names["_RECIPE_SOURCES"] == {"mask.py", "regions.py"}
    for attr, module in CALLERS.items():
        missing = [p.name for p in getattr(module, attr) if not p.is_file()]
        assert not missing, f"{attr} names modules that do not exist: {missing}"


@pytest.mark.parametrize("attr", list(CALLERS))
def test_an_edit_of_a_hashed_module_is_a_new_key(attr: str, doc: Document, tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    key = _keys(doc)[attr]
    real = key()
    assert real is not None
    copies = tmp_path / "src"
    copies.mkdir()
    sources = tuple(shutil.copy(p, copies / p.name) for p in getattr(CALLERS[attr], attr))
    monkeypatch.setattr(CALLERS[attr], attr, tuple(copies / p.name for p in getattr(CALLERS[attr], attr)))
    assert key() == real, "the same source bytes must give the same key"
    edited = copies / "regions.py"
    assert str(edited) in map(str, sources)
    original = edited.read_text()
    edited.write_text(original + "\n# an edit\n")
    assert key() == real, "memoised: the code that runs is the code that was imported"
    forget_source_digests()
    changed = key()
    assert changed != real, f"an edit of regions.py did not change the key of {attr}"
    edited.write_text(original)
    forget_source_digests()
    assert key() == real
    (copies / "layer_unlisted.py").write_text("x = 1\n")  # not a module of the key: no new key
    forget_source_digests()
    assert key() == real
