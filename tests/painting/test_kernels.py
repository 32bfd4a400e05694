"""The compiled brush kernels (painting.kernels) against the numpy reference path: the same strokes on two
documents, one per path, must give bit-identical maps, events, undo records and undo results — on the
sample head and the canonical face, across UV seams, with mirror symmetry and back-face rejection."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from core.assets import find_asset
from painting import Brush, Document, kernels
from tests.painting.helpers import StandInLibrary, make_doc, texel_positions

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator


@pytest.fixture(autouse=True)
def _restore_kernel_setting() -> Iterator[None]:
    old = kernels.set_enabled(True)
    kernels.warm_up(background=False)
    assert kernels.ready()
    yield
    kernels.set_enabled(old)


def _seam_point(doc: Document, radius_mm: float) -> np.ndarray:
    """A covered texel with a texel of another chart within 1 mm, on the side facing +Z (the face)."""
    from scipy.spatial import cKDTree

    flat, pos, nrm = texel_positions(doc.atlas)
    chart = doc.atlas.chart.reshape(-1)[flat]
    front = nrm[:, 2] > 0.5
    tree = cKDTree(pos[front])
    pairs = tree.query_pairs(1.0 / doc.mm_per_unit, output_type="ndarray")
    cf = chart[front]
    cross = pairs[cf[pairs[:, 0]] != cf[pairs[:, 1]]]
    assert len(cross), "expected a UV seam on the front of the head"
    centre = pos[front][cross[len(cross) // 2, 0]]
    near = np.linalg.norm(pos - centre, axis=1) < radius_mm / doc.mm_per_unit
    assert len(np.unique(chart[near])) >= 2, "the seam dab must reach two charts"
    return centre


def _script(doc: Document, layer: Any, landmarks: list[str]) -> None:
    """Strokes exercising every per-texel path: capsules between distant dabs, pressure, mirror, each
    composite mode, back-face rejection, hard/smoothstep/curve falloffs, a UV seam and smoothing."""
    idx = doc.atlas.index
    pts = [idx.point(idx.nearest(doc.head.landmark(n), 1.0)[0]) for n in landmarks]
    seam = _seam_point(doc, 10.0)
    with doc.stroke(layer, Brush(radius_mm=9.0, hardness=0.5, strength=0.9, flow=0.6), mirror=True) as s:
        for i, p in enumerate(pts):  # long jumps: several capsules per dab, snapped to the surface
            s.dab(p, pressure=0.5 + 0.1 * i)
    with doc.stroke(layer, Brush(radius_mm=10.0, hardness=0.2, max_angle_deg=180.0)) as s:
        s.dab(seam)
        s.dab(seam + np.array([0.05, 0.02, 0.0]))
    with doc.stroke(layer, Brush(radius_mm=12.0, hardness=1.0, mode="erase", strength=0.5,
                                 max_angle_deg=60.0)) as s:
        s.dab(pts[0])
    with doc.stroke(layer, Brush(radius_mm=7.0, mode="set", amount_um=5.0, strength=0.7,
                                 falloff_curve=(1.0, 0.8, 0.3, 0.0), pressure_radius=True)) as s:
        s.dab(pts[-1], pressure=0.8)
        s.dab(pts[-1] + np.array([0.0, 0.08, 0.0]), pressure=0.6)
    with doc.stroke(layer, Brush(radius_mm=8.0, hardness=0.5, mode="smooth")) as s:
        s.dab(seam)


def _run(make: Callable[[], Document], fast: bool, landmarks: list[str]) -> dict[str, Any]:
    kernels.set_enabled(fast)
    doc = make()
    layer = doc.add_layer("Foundation 1", max_thickness=25.0)
    events: list[Any] = []
    doc.subscribe(events.append)
    _script(doc, layer, landmarks)
    after = layer.thickness.copy()
    records = [(d.tiles.copy(), d.data.copy()) for step in doc.history._undo for d in step.deltas]
    for _ in range(5):
        doc.undo()
    undone = layer.thickness.copy()
    for _ in range(5):
        doc.redo()
    return {"after": after, "undone": undone, "redone": layer.thickness.copy(), "records": records,
            "events": [e for e in events if e.kind == "paint"]}


def _assert_same(make: Callable[[], Document], landmarks: list[str]) -> None:
    ref = _run(make, False, landmarks)
    fast = _run(make, True, landmarks)
    assert np.count_nonzero(ref["after"]) > 1000
    assert np.array_equal(fast["after"], ref["after"])  # bit for bit
    assert fast["events"] == ref["events"]  # the same touched tiles per dab
    assert len(fast["records"]) == len(ref["records"])
    for (ft, fd), (rt, rd) in zip(fast["records"], ref["records"]):
        assert np.array_equal(ft, rt) and np.array_equal(fd, rd)
    assert not np.any(fast["undone"]) and not np.any(ref["undone"])
    assert np.array_equal(fast["redone"], ref["after"])


def test_fast_path_equals_reference_on_the_sample_head() -> None:
    _assert_same(lambda: make_doc(512), ["left_cheek", "nose_tip", "chin", "right_cheek"])


@pytest.fixture(scope="module")
def canonical() -> Document:
    path = find_asset("heads/canonical-face/canonical_face_model.obj")
    # Its own UVs are one chart: an xatlas unwrap gives it seams to paint across.
    return Document.from_head(path, library=StandInLibrary(), resolution=512, cache=False, force_unwrap=True)


def test_fast_path_equals_reference_on_the_canonical_face(canonical: Document) -> None:
    def make() -> Document:
        doc = Document(canonical.head, canonical.layout, library=StandInLibrary(), resolution=512)
        doc._atlases[512] = canonical.atlas
        return doc

    _assert_same(make, ["left_cheek", "nose_tip", "chin", "right_cheek"])


def test_back_face_rejection_is_the_same_on_both_paths() -> None:
    """A dab on the nose tip with a 60° limit: texels within the radius facing away are left unpainted,
    identically on both paths (and some exist, so the rejection is exercised)."""
    maps = []
    for fast in (False, True):
        kernels.set_enabled(fast)
        doc = make_doc(512)
        layer = doc.add_layer("Foundation 1")
        idx = doc.atlas.index
        k, _ = idx.nearest(doc.head.landmark("nose_tip"), 1.0)
        p, n0 = idx.point(k), idx.normal(k)
        with doc.stroke(layer, Brush(radius_mm=12.0, hardness=1.0, max_angle_deg=60.0)) as s:
            s.dab(p)
        maps.append(layer.thickness.copy())
    flat, pos, nrm = texel_positions(doc.atlas)
    within = np.linalg.norm(pos - p, axis=1) < 0.99 * 12.0 / doc.mm_per_unit
    away = nrm @ n0 < math.cos(math.radians(60.0)) - 1e-4
    assert (within & away).sum() > 10
    assert not maps[1].reshape(-1)[flat][within & away].any()
    assert np.array_equal(maps[0], maps[1])


def test_nearest_kernel_equals_reference() -> None:
    doc = make_doc(512)
    idx = doc.atlas.index
    rng = np.random.default_rng(4)
    ks = rng.integers(0, len(idx), 300)
    pts = np.array([idx.point(k) for k in ks]) + rng.normal(scale=0.05, size=(300, 3))
    pts[:20] += 50.0  # far off the head: no texel within the distance
    kernels.set_enabled(True)
    for p, dist in zip(pts, rng.uniform(0.01, 0.3, 300)):
        assert idx.nearest(p, dist) == idx.nearest_reference(p, dist)


def test_warm_up_compiles_what_a_dab_uses() -> None:
    """After warm_up, painting compiles nothing new: the JIT cost never lands in a dab."""
    kernels.set_enabled(True)
    kernels.warm_up(background=False)
    fns = (kernels.nearest, kernels.weights, kernels.composite)
    before = [len(f.signatures) for f in fns]
    assert all(before)
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1")
    with doc.stroke(layer, Brush(radius_mm=8.0, mirror=True)) as s:
        s.dab(doc.head.landmark("left_cheek"))
        s.dab(doc.head.landmark("nose_tip"))
    with doc.stroke(layer, Brush(radius_mm=8.0, falloff_curve=(1.0, 0.0), mode="erase")) as s:
        s.dab(doc.head.landmark("left_cheek"))
    assert np.any(layer.thickness)
    assert [len(f.signatures) for f in fns] == before


def test_dabs_take_the_numpy_path_until_the_kernels_are_loaded(monkeypatch: pytest.MonkeyPatch) -> None:
    """While the warm-up is still compiling or loading, a dab never calls (and so never waits for) a
    kernel; the map is the same either way."""
    kernels.set_enabled(True)

    def not_yet(*args: Any) -> None:
        raise AssertionError("a kernel was called before the warm-up ended")

    maps = []
    for loaded in (False, True):
        with monkeypatch.context() as m:
            if not loaded:
                m.setattr(kernels, "_ready", False)
                for name in ("nearest", "weights", "composite"):
                    m.setattr(kernels, name, not_yet)
            assert kernels.active() is loaded
            doc = make_doc(256)
            layer = doc.add_layer("Foundation 1")
            with doc.stroke(layer, Brush(radius_mm=8.0, mirror=True)) as s:
                s.dab(doc.head.landmark("left_cheek"))
                s.dab(doc.head.landmark("nose_tip"))
            maps.append(layer.thickness.copy())
    assert np.any(maps[0]) and np.array_equal(maps[0], maps[1])
