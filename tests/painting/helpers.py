"""Shared helpers for the painting tests (no tests here): a stand-in material library and documents on
the sample head whose layout and atlas are computed once per session."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from core.errors import SheerError


@dataclass
class StandInMaterial:
    name: str
    category: str = "foundation"
    thickness_um: float = 20.0
    max_thickness_um: float = 60.0


class StandInLibrary:
    """The few attributes the document uses of ``km.Library``: ``get(name)`` raising for unknown names."""

    def __init__(self) -> None:
        self.materials = {m.name.casefold(): m for m in (
            StandInMaterial("Foundation 1"), StandInMaterial("Blush 1", "blush", 8.0, 30.0),
            StandInMaterial("Lipstick 1", "lipstick", 15.0, 40.0))}

    def get(self, name: str) -> StandInMaterial:
        try:
            return self.materials[name.casefold()]
        except KeyError:
            raise SheerError(f"no material named {name!r}") from None


@functools.cache
def sample_head() -> Any:
    from painting.head import load_head

    return load_head(None)


@functools.cache
def sample_layout() -> Any:
    from painting.layout import build_layout

    return build_layout(sample_head())


@functools.cache
def sample_atlas(resolution: int) -> Any:
    from painting.atlas import bake

    return bake(sample_layout(), resolution, cache=False)


def make_doc(resolution: int = 256, **kwargs: Any) -> Any:
    """A fresh document on the sample head sharing the cached layout and atlas."""
    from painting import Document

    doc = Document(sample_head(), sample_layout(), library=StandInLibrary(), resolution=resolution, **kwargs)
    doc._atlases[resolution] = sample_atlas(resolution)
    return doc


def texel_positions(atlas: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(flat indices, positions (n, 3) float64, normals (n, 3)) of the covered texels."""
    flat = np.flatnonzero(atlas.coverage.reshape(-1))
    return (flat, atlas.position.reshape(-1, 3)[flat].astype(np.float64),
            atlas.normal.reshape(-1, 3)[flat].astype(np.float64))
