"""The 3D brush on the sample head: exact dab footprint, seams, back faces, modes, symmetry, strokes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from painting import Brush
from tests.painting.helpers import make_doc, texel_positions


def _surface_point(doc, name: str) -> np.ndarray:
    """The covered texel nearest to a landmark (exactly on the baked surface)."""
    k, _ = doc.atlas.index.nearest(doc.head.landmark(name), 1.0)
    return doc.atlas.index.point(k)


def _footprint(doc, p, radius_mm, max_angle_deg):
    flat, pos, nrm = texel_positions(doc.atlas)
    k, _ = doc.atlas.index.nearest(p, 1.0)
    n0 = doc.atlas.index.normal(k)
    d = np.linalg.norm(pos - p, axis=1)
    r = radius_mm / doc.mm_per_unit
    cosine = nrm @ n0
    limit = math.cos(math.radians(max_angle_deg))
    facing = cosine >= limit + 1e-4
    away = cosine < limit - 1e-4
    return flat, d, r, facing, away


@pytest.mark.parametrize("max_angle", [60.0, 180.0])
def test_dab_paints_exactly_the_covered_texels_within_the_radius(max_angle: float) -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1")
    p = _surface_point(doc, "nose_tip")
    brush = Brush(radius_mm=12.0, hardness=1.0, mode="add", max_angle_deg=max_angle)
    with doc.stroke(layer, brush) as s:
        s.dab(p)
    flat, d, r, facing, away = _footprint(doc, p, 12.0, max_angle)
    # Texels right at the radius or the angle threshold are ambiguous in float32: leave them out.
    sure_in = (d < r * 0.999) & facing
    sure_out = (d > r * 1.001) | away
    painted = layer.thickness.reshape(-1)[flat] > 0
    assert painted[sure_in].all()
    assert not painted[sure_out].any()
    assert sure_in.sum() > 30
    # Only covered texels and the padding they feed were written.
    t = layer.thickness.reshape(-1)
    outside = ~(doc.atlas.coverage | doc.atlas.padded).reshape(-1)
    assert not t[outside].any()
    if max_angle < 180:
        assert (away & (d < r)).any(), "the nose tip should have back-facing texels within the radius"


def test_hard_dab_value_is_amount_times_strength_and_padding_follows() -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1")
    p = _surface_point(doc, "left_cheek")
    with doc.stroke(layer, Brush(radius_mm=12.0, hardness=1.0, strength=0.5)) as s:
        s.dab(p)
    t = layer.thickness.reshape(-1)
    assert np.isclose(t.max(), 10.0)  # 20 µm default × strength 0.5
    a = doc.atlas
    assert np.array_equal(t[a.pad_dst], t[a.pad_src])


def test_seam_continuity_in_3d() -> None:
    """Texels of different charts at equal 3D distance from the dab get equal thickness."""
    doc = make_doc(512)
    layer = doc.add_layer("Foundation 1")
    flat, pos, _ = texel_positions(doc.atlas)
    chart = doc.atlas.chart.reshape(-1)[flat]
    # A dab centre on a chart border of the face: a texel with a texel of another chart within 1 mm.
    from scipy.spatial import cKDTree

    front = (pos[:, 2] > 1.5) & (np.abs(pos[:, 1] - 1.2) < 1.2)
    tree = cKDTree(pos[front])
    pairs = tree.query_pairs(1.0 / doc.mm_per_unit, output_type="ndarray")
    cf = chart[front]
    cross = pairs[cf[pairs[:, 0]] != cf[pairs[:, 1]]]
    assert len(cross), "expected UV seams on the face"
    centre = pos[front][cross[0, 0]]
    radius_mm = 10.0
    with doc.stroke(layer, Brush(radius_mm=radius_mm, hardness=0.2, max_angle_deg=180.0)) as s:
        s.dab(centre)
    d = np.linalg.norm(pos - centre, axis=1) * doc.mm_per_unit
    t = layer.thickness.reshape(-1)[flat]
    inside = d < radius_mm * 0.98
    charts_hit = np.unique(chart[inside])
    assert len(charts_hit) >= 2
    expected = 20.0 * Brush(hardness=0.2).falloff(d[inside] / radius_mm)
    # Thickness depends only on the 3D distance, whichever chart (side of the seam) holds the texel.
    assert np.allclose(t[inside], expected, atol=1e-3)
    for c in charts_hit:
        sel = chart[inside] == c
        assert np.allclose(t[inside][sel], expected[sel], atol=1e-3)


def test_erase_and_set_and_add_cap() -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1", max_thickness=30.0)
    p = _surface_point(doc, "forehead")
    hard = Brush(radius_mm=10.0, hardness=1.0)
    for _ in range(3):
        with doc.stroke(layer, hard) as s:
            s.dab(p)
    assert np.isclose(layer.thickness.max(), 30.0)  # capped at the layer maximum
    with doc.stroke(layer, Brush(radius_mm=6.0, hardness=1.0, mode="erase")) as s:
        s.dab(p)
    flat, d, r, facing, _ = _footprint(doc, p, 6.0, 80.0)
    t = layer.thickness.reshape(-1)[flat]
    assert np.all(t[(d < r * 0.999) & facing] == 0.0)
    assert np.all(t[(d > 10.0 / doc.mm_per_unit * 1.001)] == 0.0)
    assert np.any(t > 0)
    with doc.stroke(layer, Brush(radius_mm=10.0, hardness=1.0, mode="set", amount_um=5.0)) as s:
        s.dab(p)
    flat, d, r, facing, _ = _footprint(doc, p, 10.0, 80.0)
    assert np.allclose(layer.thickness.reshape(-1)[flat][(d < r * 0.999) & facing], 5.0)


def test_smooth_keeps_the_total() -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1")
    p = _surface_point(doc, "left_cheek")
    q = doc.atlas.index.point(doc.atlas.index.nearest(p + np.array([0.1, 0.05, 0.0]), 0.5)[0])
    with doc.stroke(layer, Brush(radius_mm=4.0, hardness=1.0)) as s:
        s.dab(p)
        s.dab(q)
    before = layer.thickness.astype(np.float64)
    flat = np.flatnonzero(doc.atlas.coverage.reshape(-1))
    total = before.reshape(-1)[flat].sum()
    with doc.stroke(layer, Brush(radius_mm=15.0, hardness=0.5, mode="smooth", strength=1.0)) as s:
        for _ in range(3):
            s.dab(p, pressure=1.0)
            s._last = None  # force repeated dabs at the same spot
    after = layer.thickness.astype(np.float64)
    assert not np.array_equal(before, after)
    assert abs(after.reshape(-1)[flat].sum() - total) <= 1e-4 * total
    assert after.max() < before.max()  # peaks flattened


def test_fill_whole_layer_and_one_chart() -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1")
    doc.fill(layer, 7.0)
    cov = doc.atlas.coverage
    assert np.all(layer.thickness[cov] == 7.0)
    assert np.all(layer.thickness[~(cov | doc.atlas.padded)] == 0.0)
    doc.undo()
    assert not layer.thickness.any()
    chart = int(np.bincount(doc.atlas.chart[cov]).argmax())
    doc.fill(layer, 3.0, chart=chart)
    sel = cov & (doc.atlas.chart == chart)
    assert np.all(layer.thickness[sel] == 3.0)
    assert not layer.thickness[cov & ~sel].any()
    # Brush mode "fill" fills the chart under the dab.
    layer2 = doc.add_layer("Blush 1")
    p = _surface_point(doc, "nose_tip")
    with doc.stroke(layer2, Brush(mode="fill", strength=1.0)) as s:
        s.dab(p)
    k, _ = doc.atlas.index.nearest(p, 1.0)
    c = doc.atlas.chart.reshape(-1)[doc.atlas.index.flat[k]]
    assert np.all(layer2.thickness[cov & (doc.atlas.chart == c)] == 8.0)


def test_mirror_symmetry_one_undo_step() -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Blush 1")
    p = _surface_point(doc, "left_cheek")
    steps = len(doc.history)
    with doc.stroke(layer, Brush(radius_mm=10.0, hardness=1.0, mirror=True)) as s:
        s.dab(p)
    assert len(doc.history) == steps + 1
    flat, pos, _ = texel_positions(doc.atlas)
    t = layer.thickness.reshape(-1)[flat]
    pm = doc.mirror_point(p)
    near_right = np.linalg.norm(pos - pm, axis=1) < 5.0 / doc.mm_per_unit
    near_left = np.linalg.norm(pos - p, axis=1) < 5.0 / doc.mm_per_unit
    assert np.all(t[near_left] > 0) and np.all(t[near_right] > 0)
    # Painted areas on both sides are about equal (the face is nearly symmetric).
    side = (pos - np.asarray(doc.head.metadata.midplane_point)) @ np.asarray(doc.head.metadata.midplane_normal)
    a, b = np.sum((t > 0) & (side > 0)), np.sum((t > 0) & (side < 0))
    assert 0.7 < a / b < 1.4
    doc.undo()
    assert not layer.thickness.any()


def test_fast_stroke_leaves_no_gap() -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1")
    a = _surface_point(doc, "right_cheek")
    b = _surface_point(doc, "left_cheek")
    with doc.stroke(layer, Brush(radius_mm=6.0, hardness=1.0, max_angle_deg=180.0)) as s:
        s.dab(a)
        s.dab(b)
    # The nose lies between the cheeks: points along the path (snapped to the surface) are painted.
    idx = doc.atlas.index
    for f in np.linspace(0.1, 0.9, 9):
        q = a + (b - a) * f
        k, _ = idx.nearest(q, 2.0)
        assert layer.thickness.reshape(-1)[idx.flat[k]] > 0


def test_spacing_skips_close_dabs_and_pressure_scales() -> None:
    doc = make_doc(256)
    layer = doc.add_layer("Foundation 1")
    p = _surface_point(doc, "forehead")
    with doc.stroke(layer, Brush(radius_mm=8.0, hardness=1.0, spacing=0.5)) as s:
        s.dab(p, pressure=0.25)
        assert s.dab(p) == ()  # closer than spacing × radius: skipped
    assert np.isclose(layer.thickness.max(), 5.0)  # 20 µm × pressure 0.25


def test_upper_lip_brush_does_not_paint_the_lower_lip_through_the_mouth() -> None:
    doc = make_doc(512)
    layer = doc.add_layer("Lipstick 1")
    p = _surface_point(doc, "upper_lip")
    flat, pos, nrm = texel_positions(doc.atlas)
    near = np.linalg.norm(pos - p, axis=1) * doc.mm_per_unit < 6.0
    # The lower lip's texels facing up towards the upper lip, inside the brush sphere.
    lower_inner = near & (pos[:, 1] < doc.head.landmark("lip_centre")[1]) & (nrm[:, 1] > 0.3)
    assert lower_inner.sum() >= 5
    with doc.stroke(layer, Brush(radius_mm=6.0, hardness=1.0)) as s:
        s.dab(p)
    t = layer.thickness.reshape(-1)[flat]
    assert not t[lower_inner].any()
    assert t[near].any()
    with doc.stroke(layer, Brush(radius_mm=6.0, hardness=1.0, max_angle_deg=180.0)) as s:
        s.dab(p)  # without back-face rejection they would be painted
    assert layer.thickness.reshape(-1)[flat][lower_inner].all()


def test_smooth_reaches_its_full_width_on_fine_maps_and_never_overshoots() -> None:
    """No neighbour cap: a 2 mm spot smoothed by a 20 mm brush (kernel width h = 10 mm) spreads 7–9 mm
    out even at 1024² (a cap of 500,000 pairs allowed only ~3.8 mm there); the total is conserved, no
    value leaves [old min, old max], and nothing beyond the brush radius changes."""
    doc = make_doc(1024)
    layer = doc.add_layer("Foundation 1")
    p = _surface_point(doc, "left_cheek")
    with doc.stroke(layer, Brush(radius_mm=2.0, hardness=1.0)) as s:
        s.dab(p)
    before = layer.thickness.astype(np.float64)
    with doc.stroke(layer, Brush(radius_mm=20.0, hardness=0.5, mode="smooth", smooth_radius=0.5)) as s:
        s.dab(p)
    after = layer.thickness.astype(np.float64)
    flat, pos, _ = texel_positions(doc.atlas)
    d = np.linalg.norm(pos - p, axis=1) * doc.mm_per_unit
    t0, t1 = before.reshape(-1)[flat], after.reshape(-1)[flat]
    ring = (d > 7.0) & (d < 9.0)
    assert ring.sum() > 100 and (t1[ring] > 0).mean() > 0.9
    assert t1.max() <= t0.max() and t1.min() >= 0.0
    assert abs(t1.sum() - t0.sum()) <= 1e-5 * t0.sum()
    assert np.array_equal(t1[d > 20.0 * 1.001], t0[d > 20.0 * 1.001])
    assert t1.max() < 0.5 * t0.max()  # the spot really spread
