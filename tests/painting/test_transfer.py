"""Look transfer between heads (painting.transfer): the sample head ↔ the MediaPipe canonical face.

Real heads, real bakes, real strokes; every figure is measured on the maps the transfer writes.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import numpy as np
import pytest

from painting import Brush
from painting.document import Document
from painting.transfer import (
    MIN_SHARED_LANDMARKS,
    Correspondence,
    LandmarkWarp,
    TransferError,
    transfer_document,
    transfer_layers,
)
from tests.painting.helpers import StandInLibrary, sample_head

RES = 512


@functools.cache
def canonical_head() -> Any:
    from core.assets import find_asset
    from painting.head import load_head

    return load_head(find_asset("heads/canonical-face/canonical_face_model.obj"))


def doc_on(head: Any) -> Document:
    return Document(head, library=StandInLibrary(), resolution=RES)


def mass_centre_mm(doc: Document, values: np.ndarray) -> np.ndarray:
    """Thickness-weighted mean 3D position of a map on ``doc``'s covered texels (mm)."""
    atlas = doc.atlas_at(values.shape[0])
    w = np.where(atlas.coverage, values, 0.0).reshape(-1).astype(np.float64)
    pos = atlas.position.reshape(-1, 3).astype(np.float64)
    return (w @ pos) / w.sum() * doc.mm_per_unit


def lipstick_on(doc: Document) -> Any:
    """A lipstick stroke along the mouth (landmark to landmark, 4 mm brush, no region limit)."""
    layer = doc.add_layer("Lipstick 1", name="Lipstick")
    with doc.stroke(layer, Brush(radius_mm=4.0, hardness=0.6, amount_um=20.0, spacing=0.1)) as s:
        for name in ("mouth_right", "upper_lip", "mouth_left", "lower_lip", "mouth_right", "lip_centre"):
            s.dab(doc.head.landmark(name))
    return layer


def blush_on(doc: Document) -> Any:
    layer = doc.add_layer("Blush 1", name="Blush")
    with doc.stroke(layer, Brush(radius_mm=18.0, hardness=0.3, amount_um=8.0, mirror=True)) as s:
        s.dab(doc.head.landmark("left_cheek"))
    return layer


def near_region(doc: Document, values: np.ndarray, region: str, mm: float) -> float:
    """Fraction of a map's mass on texels within ``mm`` (3D) of ``region`` (soft edge included)."""
    from scipy.spatial import cKDTree

    atlas = doc.atlas_at(values.shape[0])
    pos = atlas.position.astype(np.float64) * doc.mm_per_unit
    painted = atlas.coverage & (values > 0)
    d, _ = cKDTree(pos[(doc.region_values(region, values.shape[0]) > 0) & atlas.coverage]).query(pos[painted])
    w = values[painted]
    return float(w[d <= mm].sum() / w.sum())


def paint(doc: Document) -> Document:
    """Layers: a lipstick stroke, the lips filled, a blush, a constant, a smooth field, a masked layer."""
    from painting.mask import LayerMask

    lipstick_on(doc)
    doc.fill_region(doc.add_layer("Lipstick 1", name="Lip fill"), "lips", 20.0)
    blush_on(doc)
    doc.fill(doc.add_layer("Foundation 1", name="Flat"), 10.0)
    atlas = doc.atlas_at(RES)
    pos_mm = atlas.position.astype(np.float64) * doc.mm_per_unit
    centre = doc.head.landmark("nose_tip") * doc.mm_per_unit
    field_um = np.clip(20.0 + 0.2 * (pos_mm[..., 0] - centre[0]) + 0.1 * (pos_mm[..., 1] - centre[1]), 0.0, 60.0)
    doc.set_thickness(doc.add_layer("Foundation 1", name="Field"),
                      np.where(atlas.coverage | atlas.padded, field_um, 0.0).astype(np.float32))
    masked = doc.add_layer("Lipstick 1", name="Masked")
    doc.fill(masked, 15.0)
    doc.set_layer_mask(masked, LayerMask((("union", "lips"),), feather_mm=0.5))
    with doc.mask_stroke(masked, Brush(radius_mm=5.0, mode="erase", strength=1.0)) as s:
        s.dab(doc.head.landmark("mouth_left"))
    doc.set_layer(masked, opacity=0.7, visible=False)
    return doc


LAYERS = ["Lipstick", "Lip fill", "Blush", "Flat", "Field", "Masked"]


@pytest.fixture(scope="module")
def sample_painted() -> Document:
    return paint(doc_on(sample_head()))


@pytest.fixture(scope="module")
def canonical_painted() -> Document:
    return paint(doc_on(canonical_head()))


@pytest.fixture(scope="module")
def to_canonical(sample_painted: Document) -> tuple[Document, Any]:
    return transfer_document(sample_painted, canonical_head())


@pytest.fixture(scope="module")
def to_sample(canonical_painted: Document) -> tuple[Document, Any]:
    return transfer_document(canonical_painted, sample_head())


def matched_texels(source: Document, target: Document) -> np.ndarray:
    """bool (RES, RES): the target's covered texels that have a counterpart on the source."""
    corr = Correspondence.build(source, target, RES)
    out = np.zeros(RES * RES, bool)
    out[corr.flat] = True
    return out.reshape(RES, RES)


def test_lipstick_on_the_sample_head_lands_on_the_canonical_lips(sample_painted: Document,
                                                                  to_canonical: tuple[Document, Any]) -> None:
    target, report = to_canonical
    assert [lay.name for lay in target.layers] == LAYERS
    assert [lay.material for lay in target.layers] == [lay.material for lay in sample_painted.layers]
    assert not target.can_undo  # a new document: no history
    src_stroke, stroke = sample_painted.layers[0].thickness, target.layers[0].thickness
    # The stroke (4 mm brush from landmark to landmark): measured 0.71 of it on the sample head's lips,
    # 0.85 on the canonical face's; within 2 mm of them 0.89 → 0.94.
    assert near_region(target, stroke, "lips", 0.0) >= near_region(sample_painted, src_stroke, "lips", 0.0)
    assert near_region(target, stroke, "lips", 2.0) >= 0.9
    # Its centre lands where it was relative to the lip centre (measured 2.9 mm → 3.0 mm away).
    before = np.linalg.norm(mass_centre_mm(sample_painted, src_stroke)
                            - sample_head().landmark("lip_centre") * sample_painted.mm_per_unit)
    after = np.linalg.norm(mass_centre_mm(target, stroke) - canonical_head().landmark("lip_centre") * 10.0)
    assert after < before + 1.0, (before, after)
    # The lips filled to their line: 0.96 on the canonical lips, 0.997 within 2 mm (measured).
    fill = target.layers[1].thickness
    assert near_region(target, fill, "lips", 0.0) >= 0.92 and near_region(target, fill, "lips", 2.0) >= 0.99
    # The blush lands on both cheeks, not on the lips.
    b = target.layers[2].thickness
    assert near_region(target, b, "lips", 0.0) < 0.01
    atlas = target.atlas_at(RES)
    x = atlas.position[..., 0]
    left, right = float(b[atlas.coverage & (x > 0)].sum()), float(b[atlas.coverage & (x < 0)].sum())
    assert 0.8 < left / right < 1.25, (left, right)
    assert report.matched_fraction > 0.95  # measured 1.00: the whole canonical face is on the sample head


def test_lipstick_on_the_canonical_face_lands_on_the_sample_lips(to_sample: tuple[Document, Any]) -> None:
    target, report = to_sample
    fill = target.layers[1].thickness
    # Measured: 0.71 on the sample head's lips (its vermilion is thinner than the canonical model's),
    # 0.91 within 2 mm, 0.97 within 5 mm; its centre 2.2 mm from the sample head's lip centre.
    assert near_region(target, fill, "lips", 0.0) >= 0.65
    assert near_region(target, fill, "lips", 2.0) >= 0.85 and near_region(target, fill, "lips", 5.0) >= 0.95
    centre = mass_centre_mm(target, fill)
    assert np.linalg.norm(centre - sample_head().landmark("lip_centre") * target.mm_per_unit) < 3.0
    # The canonical face has no scalp, ears or neck: most of the whole head has no counterpart (0.15).
    assert 0.08 < report.matched_fraction < 0.3


def _round_trip_errors(a: np.ndarray, back: np.ndarray, where: np.ndarray) -> tuple[float, float, float]:
    """(mean |Δ| / peak, 99th percentile |Δ| / peak, mass ratio) over ``where``."""
    d = np.abs(back - a)[where]
    peak = float(a.max())
    return float(d.mean()) / peak, float(np.percentile(d, 99)) / peak, float(back[where].sum() / a[where].sum())


#: Round-trip tolerances per layer (mean |Δ| / peak, p99 |Δ| / peak, mass ratio range), measured at 512²
#: (see the README's look-transfer table for the figures).
#: The lips' mass comes back short where part of it lands on the other head's inner mouth, which a transfer
#: never paints (the canonical face's lips part 5.5 mm, the sample head's curl in): measured over A's texels
#: outside its inner mouth, sample → canonical → sample 0.86 of a stroke along the mouth and 0.77 of the lips
#: filled to their line (1.00 and 0.99 before the inner mouth was kept clear), the other way 0.87 and 0.93.
ROUND_TRIP_TOLERANCE = {"Lipstick": (0.01, 0.15, 0.8, 1.1), "Lip fill": (0.01, 0.3, 0.7, 1.1),
                        "Blush": (0.005, 0.05, 0.97, 1.03), "Field": (0.01, 0.05, 0.98, 1.02)}


@pytest.mark.parametrize("direction", ["sample→canonical→sample", "canonical→sample→canonical"])
def test_round_trip_returns_the_maps(direction: str, sample_painted: Document, canonical_painted: Document,
                                     to_canonical: tuple[Document, Any], to_sample: tuple[Document, Any]) -> None:
    """A→B→A on the texels of A that B covers (for the sample head: the face)."""
    start, (middle, _) = ((sample_painted, to_canonical) if direction.startswith("sample")
                          else (canonical_painted, to_sample))
    back, _ = transfer_document(middle, start.head)
    # a transfer never paints the inner mouth: A's texels there are left out (what lands on B's is lost: the
    # lower bounds of the lips' mass ratios)
    where = matched_texels(middle, back) & start.atlas_at(RES).coverage & ~(start.region_values("inner_mouth", RES) > 0.05)
    for i, name in enumerate(LAYERS):
        if name not in ROUND_TRIP_TOLERANCE:
            continue
        mean_tol, p99_tol, lo, hi = ROUND_TRIP_TOLERANCE[name]
        mean, p99, mass = _round_trip_errors(np.asarray(start.layers[i].thickness),
                                             np.asarray(back.layers[i].thickness), where)
        assert mean <= mean_tol and p99 <= p99_tol and lo <= mass <= hi, (name, mean, p99, mass)


def _seam_samples(doc: Document, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A map read bilinearly (as the renderer does) on both sides of every UV seam of ``doc``'s layout.

    For each mesh edge that two charts share, at 1/4, 1/2 and 3/4 along it: the value at the edge's
    UV in one chart and in the other (the same 3D point). Returns (side one, side two), float64.
    """
    import trimesh
    from scipy import ndimage

    layout = doc.layout
    _, welded = trimesh.grouping.unique_rows(layout.vertices, digits=8)
    corners = np.concatenate([layout.faces[:, [0, 1]], layout.faces[:, [1, 2]], layout.faces[:, [2, 0]]])
    ends = welded[corners]
    flip = ends[:, 0] > ends[:, 1]
    corners[flip], ends[flip] = corners[flip][:, ::-1], ends[flip][:, ::-1]
    order = np.lexsort((ends[:, 1], ends[:, 0]))
    corners, ends = corners[order], ends[order]
    twin = np.flatnonzero(np.all(ends[1:] == ends[:-1], axis=1))
    seam = twin[np.any(corners[twin] != corners[twin + 1], axis=1)]  # the same edge, split vertices: a seam
    res = values.shape[0]
    sides = []
    for k in (seam, seam + 1):
        uv0, uv1 = layout.uv[corners[k, 0]], layout.uv[corners[k, 1]]
        uv = np.concatenate([(1 - t) * uv0 + t * uv1 for t in (0.25, 0.5, 0.75)])
        sides.append(ndimage.map_coordinates(np.asarray(values, np.float64), [uv[:, 1] * res - 0.5,
                                              uv[:, 0] * res - 0.5], order=1, mode="nearest"))
    return sides[0], sides[1]


@pytest.fixture(scope="module")
def cut_canonical() -> Document:
    """The canonical face unwrapped by xatlas: 5 charts, seams across the face (its own UVs have none)."""
    doc = Document(canonical_head(), library=StandInLibrary(), resolution=RES, force_unwrap=True)
    assert doc.layout.charts >= 3
    return doc


def test_target_seams_stay_clean(sample_painted: Document, cut_canonical: Document) -> None:
    """The sample head's layers moved onto the cut canonical face.

    Across its UV seams the two sides hold the same value (the same 3D place maps to the same source
    place): no gap, no step; a constant stays constant on every matched texel, and the padding copies
    its texel, so bilinear filtering of the result shows no seam either.
    """
    target = Document(cut_canonical.head, cut_canonical.layout, library=StandInLibrary(), resolution=RES)
    transfer_layers(sample_painted, target)
    matched = matched_texels(sample_painted, target)
    atlas = target.atlas_at(RES)
    both = np.minimum(*_seam_samples(target, (matched | atlas.padded).astype(np.float64))) == 1.0
    assert both.sum() > 150, both.sum()  # seam points whose bilinear taps all have a counterpart
    field_map = np.asarray(target.layers[LAYERS.index("Field")].thickness)
    one, two = _seam_samples(target, field_map)
    # The field (gradient ≤ 0.22 µm/mm, ~20 µm) reads the same on both sides of every seam, within what
    # it changes over two texels (0.5 mm each; the taps reach the padding): measured max 0.15 µm, p99 0.07 µm.
    assert float(np.abs(one - two)[both].max()) <= 0.22 * 2 * atlas.texel_mm
    for name in ("Lipstick", "Lip fill"):
        # Steep edges (a 4 mm brush, the lips' 0.5 mm feather): across a seam the value changes no more
        # than the map itself does between two neighbouring texels of one chart, and mostly hardly at all
        # (measured median 0.06 / 0.12 µm of 20 µm).
        m = np.asarray(target.layers[LAYERS.index(name)].thickness)
        one, two = _seam_samples(target, m)
        inside = both & (np.maximum(one, two) > 1.0)
        same = (atlas.chart[:, 1:] == atlas.chart[:, :-1]) & atlas.coverage[:, 1:] & atlas.coverage[:, :-1]
        steepest = float(np.abs(np.diff(m, axis=1))[same].max())
        jump = np.abs(one - two)[inside]
        assert inside.sum() > 20 and float(np.median(jump)) < 0.25 and float(jump.max()) <= steepest, name
    flat_map = np.asarray(target.layers[LAYERS.index("Flat")].thickness).reshape(-1)
    # a transfer never paints the inner mouth (painting.transfer.inner_mouth_texels): 0 there
    inner = (target.region_values("inner_mouth", RES) >= 0.5).reshape(-1)
    matched = matched.reshape(-1)
    assert inner.any() and np.all(flat_map[inner] == 0.0)
    assert np.allclose(flat_map[matched & ~inner], 10.0, atol=1e-4)
    assert np.array_equal(flat_map[atlas.pad_dst], flat_map[atlas.pad_src])
    assert atlas.padded.sum() > 0 and np.all(flat_map[atlas.pad_dst] == flat_map[atlas.pad_src])


def test_source_seams_do_not_bleed(cut_canonical: Document) -> None:
    """A constant on the cut canonical face arrives constant on the sample head: the bilinear taps never
    read another chart's texels or the empty space between charts."""
    src = Document(cut_canonical.head, cut_canonical.layout, library=StandInLibrary(), resolution=RES)
    flat = src.add_layer("Foundation 1")
    src.fill(flat, 10.0)
    target, _ = transfer_document(src, sample_head())
    corr = Correspondence.build(src, target, RES)
    outside = ~(target.region_values("inner_mouth", RES) >= 0.5).reshape(-1)[corr.flat]  # never painted
    got = np.asarray(target.layers[0].thickness).reshape(-1)[corr.flat][outside]
    assert np.allclose(got, 10.0, atol=1e-4), (got.min(), got.max())
    # the places lie in several charts, many next to a chart border (so the test can fail: measured
    # with plain bilinear taps, values down to ~2.5 µm there)
    atlas = src.atlas_at(RES)
    x = np.clip((corr.source_uv[:, 0] * RES).astype(int), 0, RES - 1)
    y = np.clip((corr.source_uv[:, 1] * RES).astype(int), 0, RES - 1)
    near_border = np.zeros(len(x), bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            near_border |= ~atlas.coverage[np.clip(y + dy, 0, RES - 1), np.clip(x + dx, 0, RES - 1)]
    assert len(np.unique(corr.source_chart)) >= 3 and near_border.sum() > 100


def test_masks_move_with_their_layer(sample_painted: Document, to_canonical: tuple[Document, Any]) -> None:
    target, report = to_canonical
    i = LAYERS.index("Masked")
    lay, new = sample_painted.layers[i], target.layers[i]
    assert report.layers[i]["mask"] == "recipe" and report.layers[0]["mask"] == "none"
    assert new.mask == lay.mask and new.opacity == pytest.approx(0.7) and not new.visible
    assert new.mask_channel is not None
    # The erased spot arrives at the canonical face's left mouth corner; elsewhere the channel stays neutral.
    atlas = target.atlas_at(RES)
    erased = (new.mask_channel < 0.5) & atlas.coverage
    assert erased.any()
    spot = atlas.position[erased].astype(np.float64).mean(axis=0) * target.mm_per_unit
    assert np.linalg.norm(spot - canonical_head().landmark("mouth_left") * target.mm_per_unit) < 6.0
    assert float(np.mean(new.mask_channel[atlas.coverage & ~erased] == 1.0)) > 0.95


def test_too_few_shared_landmarks_is_one_clear_error() -> None:
    head = canonical_head()
    few = dict(list(head.metadata.landmarks.items())[:MIN_SHARED_LANDMARKS - 1])
    poor = dataclasses.replace(head, metadata=dataclasses.replace(head.metadata, name="Poor", landmarks=few))
    with pytest.raises(TransferError, match=r"share 5 usable landmark\(s\).*at least 6") as exc:
        LandmarkWarp.fit(sample_head(), poor)
    assert "\n" not in str(exc.value)
    flat = {k: (v[0], v[1], 0.0) for k, v in head.metadata.landmarks.items()}
    planar = dataclasses.replace(head, metadata=dataclasses.replace(head.metadata, name="Flat", landmarks=flat))
    with pytest.raises(TransferError, match="on one plane"):
        transfer_document(doc_on(sample_head()), planar)


def test_the_warp_fits_its_landmarks_and_says_how_well_it_generalises() -> None:
    warp = LandmarkWarp.fit(sample_head(), canonical_head())
    for name in warp.names:
        got = warp(canonical_head().landmark(name)[None])[0]
        assert np.linalg.norm(got - sample_head().landmark(name)) * sample_head().mm_per_unit < 1e-3
    loo = np.array(list(warp.loo_mm.values()))
    assert len(warp.names) >= 20 and float(np.median(loo)) < 8.0  # measured: median 4.4 mm, max 14 mm


def test_finer_layers_are_matched_coarser_and_upsampled(sample_painted: Document,
                                                        to_canonical: tuple[Document, Any]) -> None:
    """Layers over ``max_resolution`` are put in correspondence at it, then upsampled in the target's UVs:
    here 256² for the 512² layers, against the direct 512² transfer."""
    direct, _ = to_canonical
    coarse, report = transfer_document(sample_painted, canonical_head(), max_resolution=256)
    assert [lay.resolution for lay in coarse.layers] == [RES] * len(LAYERS)
    atlas = coarse.atlas_at(RES)
    inner = atlas.coverage & matched_texels(sample_painted, coarse)
    for name, tol in (("Field", 0.01), ("Lip fill", 0.02), ("Blush", 0.01)):
        i = LAYERS.index(name)
        a, b = np.asarray(direct.layers[i].thickness), np.asarray(coarse.layers[i].thickness)
        # measured: mean |Δ| / peak 0.06 % (field), 0.08 % (lip fill), 0.01 % (blush)
        assert float(np.abs(a - b)[inner].mean()) / float(a.max()) < tol, name
    assert near_region(coarse, coarse.layers[1].thickness, "lips", 2.0) >= 0.99
    flat = np.asarray(coarse.layers[LAYERS.index("Flat")].thickness)
    assert np.all(flat.reshape(-1)[atlas.pad_dst] == flat.reshape(-1)[atlas.pad_src])
    assert not np.any(flat[~(atlas.coverage | atlas.padded)])


def test_a_material_the_target_lacks_changes_nothing(sample_painted: Document) -> None:
    from painting.layer import DocumentError

    library = StandInLibrary()
    del library.materials["blush 1"]
    target = Document(canonical_head(), library=library, resolution=RES)
    with pytest.raises(DocumentError, match="Blush 1"):
        transfer_layers(sample_painted, target)
    assert target.layers == [] and not target.can_undo


def test_a_mask_whose_region_the_target_lacks_is_baked(sample_painted: Document, tmp_path: Any) -> None:
    """The canonical face with a regions file lacking 'lips': the lips mask arrives as rendered (a channel)."""
    import shutil

    from core.assets import resource_path
    from painting.head import load_head
    from painting.regions import RegionSet, decode_regions, encode_regions, regions_file

    mesh = tmp_path / "face.obj"
    shutil.copyfile(canonical_head().path, mesh)
    sidecar = tmp_path / "face.obj.sheer-head.json"
    shutil.copyfile(resource_path("heads", "canonical-face.json"), sidecar)
    full = decode_regions(regions_file(resource_path("heads", "canonical-face.json")).read_bytes(), "shipped")
    partial = RegionSet({k: v for k, v in full.regions.items() if k != "lips"}, head_name="no lips")
    regions_file(sidecar).write_bytes(encode_regions(partial))
    target, report = transfer_document(sample_painted, load_head(mesh))
    i = LAYERS.index("Masked")
    assert report.layers[i]["mask"] == "baked" and "lips" not in target.regions.names()
    new, lay = target.layers[i], sample_painted.layers[i]
    assert new.mask is None and new.mask_channel is not None
    # the baked mask shows the layer on the lips (and the erased corner stays hidden), nowhere else
    shown = np.asarray(target.mask_values(new))
    reference = np.asarray(to_canonical_mask(sample_painted, lay))
    cov = target.atlas_at(RES).coverage
    assert float(np.abs(shown - reference)[cov].mean()) < 0.01
    # It follows the sample head's (thinner) lips, not the canonical face's own: measured a mean of 0.65 over
    # the canonical lips (a recipe, when the target has the region, follows the target's own lips instead).
    lips = full.at("lips", RES)
    assert float(shown[cov & (lips > 0.5)].mean()) > 0.55 and float(shown[cov & (lips == 0)].mean()) < 0.05


def to_canonical_mask(src: Document, lay: Any) -> np.ndarray:
    """The source layer's rendered mask moved onto the canonical face by the same correspondence."""
    target = doc_on(canonical_head())
    corr = Correspondence.build(src, target, RES)
    return np.clip(corr.resample(np.asarray(src.mask_values(lay)), src.atlas_at(RES), fill=1.0), 0.0, 1.0)
