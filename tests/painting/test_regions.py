"""Facial regions (painting.regions, painting.region_shapes): the sample head's stored masks, the face mesh's
contours, other heads, files, and region-aware brushes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from core.assets import find_asset
from painting import Brush, Document, DocumentError
from painting.head import load_head
from painting.region_shapes import CONTOURS, regions_for
from painting.regions import (
    REGION_NAMES,
    REGION_RESOLUTION,
    RegionError,
    RegionSet,
    decode_regions,
    encode_regions,
    feather,
    resample,
)

ROOT = Path(__file__).resolve().parents[2]
CANONICAL = "heads/canonical-face/canonical_face_model.obj"


@pytest.fixture(scope="module")
def sample() -> Document:
    return Document.from_head(None, resolution=1024)


@pytest.fixture(scope="module")
def canonical() -> Document:
    return Document.from_head(find_asset(CANONICAL), resolution=512)


def test_sample_head_has_every_region_from_its_stored_file(sample: Document) -> None:
    regions = sample.regions
    assert regions.names() == list(REGION_NAMES)
    assert not regions.missing
    lips = regions.get("lips")
    assert lips.mask.shape == (REGION_RESOLUTION, REGION_RESOLUTION)
    assert lips.mask.dtype == np.float32 and lips.mask.min() >= 0.0 and lips.mask.max() == 1.0
    assert "albedo" in lips.source and lips.feather_mm == 0.5
    # upper and lower lip do not overlap (beyond their soft edges) and together make the lips
    up, lo, both = (regions.get(n).mask > 0.5 for n in ("upper_lip", "lower_lip", "lips"))
    assert np.count_nonzero(up & lo) <= 0.005 * np.count_nonzero(both)  # only where their soft edges meet
    assert np.count_nonzero(both & ~(up | lo)) <= 0.02 * np.count_nonzero(both)
    # each lip is a sizeable area (a few hundred texels at 1024²: ~0.6 mm texels, 5–6 mm tall lips)
    assert np.count_nonzero(up) > 300 and np.count_nonzero(lo) > 300


def test_lip_region_lies_around_the_lip_landmarks_in_3d(sample: Document) -> None:
    atlas = sample.atlas_at(REGION_RESOLUTION)
    lips = sample.regions.get("lips").mask > 0.5
    pos = atlas.position[lips]
    lm = sample.head.metadata.landmarks
    mm = sample.mm_per_unit
    centre = np.asarray(lm["lip_centre"])
    # every lip texel within the mouth's corners (± 3 mm) and 15 mm of the lip centre vertically
    assert pos[:, 0].min() >= min(lm["mouth_right"][0], lm["mouth_left"][0]) - 3 / mm
    assert pos[:, 0].max() <= max(lm["mouth_right"][0], lm["mouth_left"][0]) + 3 / mm
    assert np.abs(pos[:, 1] - centre[1]).max() <= 15 / mm
    # the upper lip lies above the lower one
    up = atlas.position[sample.regions.get("upper_lip").mask > 0.5][:, 1].mean()
    lo = atlas.position[sample.regions.get("lower_lip").mask > 0.5][:, 1].mean()
    assert up > lo


@pytest.mark.slow  # ~20–40 s: the bake at 2048² and the derivation
def test_stored_file_is_rebuilt_byte_exactly(capsys: pytest.CaptureFixture[str]) -> None:
    # the script's own entry function, in this process (a new interpreter would only add its start-up)
    import importlib.util

    spec = importlib.util.spec_from_file_location("build_head_regions", ROOT / "scripts" / "build_head_regions.py")
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    status = script.main(["--check"])
    out = capsys.readouterr()
    assert status == 0, out.out + out.err
    assert out.out.strip().endswith("lee-perry-smith.regions.png: up to date"), out.out


def test_face_mesh_regions_come_from_contours(canonical: Document) -> None:
    regions = canonical.regions
    assert set(regions.names()) == set(REGION_NAMES), regions.missing
    assert "lipsUpperOuter" in regions.get("upper_lip").source
    atlas = canonical.atlas_at(REGION_RESOLUTION)
    v = canonical.head.vertices
    # each lip's texels lie within its contour vertices' box (± 1.5 mm), and the upper lip above the lower
    for name, chains in (("upper_lip", ("lipsUpperOuter", "lipsUpperInner")),
                         ("lower_lip", ("lipsLowerOuter", "lipsLowerInner"))):
        box = v[sum((CONTOURS[c] for c in chains), [])]
        pos = atlas.position[regions.get(name).mask > 0.5]
        assert np.all(pos[:, :2] >= box[:, :2].min(axis=0) - 0.15)
        assert np.all(pos[:, :2] <= box[:, :2].max(axis=0) + 0.15)
    up = atlas.position[regions.get("upper_lip").mask > 0.5]
    lo = atlas.position[regions.get("lower_lip").mask > 0.5]
    assert up[:, 1].mean() > v[13, 1] > v[14, 1] > lo[:, 1].mean()
    # the eye opening is not part of the upper eyelid; the left eye's lid lies above its lash line
    eyes = regions.get("eyes").mask > 0.5
    lid = regions.get("upper_eyelid").mask > 0.5
    assert np.count_nonzero(eyes & lid) == 0
    assert atlas.position[lid & (atlas.position[..., 0] > 0)][:, 1].mean() > v[386, 1]


def test_head_without_landmarks_names_the_missing_regions(tmp_path: Path) -> None:
    import trimesh

    n = 12  # a flat 12×12-quad sheet with UVs = its (x, y)
    g = np.linspace(0.0, 1.0, n + 1)
    xy = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    q = np.arange((n + 1) * (n + 1)).reshape(n + 1, n + 1)[:-1, :-1].reshape(-1)
    faces = np.concatenate([np.stack([q, q + 1, q + n + 2], 1), np.stack([q, q + n + 2, q + n + 1], 1)])
    mesh = trimesh.Trimesh(np.column_stack([xy, np.zeros(len(xy))]), faces, process=False)
    mesh.visual = trimesh.visual.TextureVisuals(uv=xy)
    path = tmp_path / "sheet.obj"
    mesh.export(path)
    doc = Document.from_head(path, resolution=256, cache=False)
    regions = doc.regions
    assert regions.names() == []
    assert set(regions.missing) == set(REGION_NAMES)
    assert "landmark" in regions.missing_message() and "lips" in regions.missing_message()
    with pytest.raises(RegionError, match="has no region 'lips'.*paint a layer mask"):
        regions.get("lips")
    lay = doc.add_layer("Lipstick Classic Red")
    with pytest.raises(DocumentError, match="no region 'lips'"):
        doc.fill_region(lay, "lips", 10.0)


def test_unknown_region_names_the_known_ones(sample: Document) -> None:
    with pytest.raises(RegionError, match="unknown region 'lipz'.*upper_lip"):
        sample.regions.get("lipz")
    with pytest.raises(DocumentError, match="brush region 'lipz'"):
        sample.stroke(0 if sample.layers else sample.add_layer("Lipstick Classic Red"), Brush(region="lipz"))


def test_encode_decode_round_trip_and_bad_files() -> None:
    rng = np.random.default_rng(1)
    from painting.regions import Region

    masks = {n: (np.round(rng.random((64, 64)) * 255) / 255).astype(np.float32) for n in ("lips", "brows")}
    rs = RegionSet({n: Region(n, m, 1.0, "test") for n, m in masks.items()}, head_name="t")
    blob = encode_regions(rs)
    assert encode_regions(rs) == blob  # deterministic
    back = decode_regions(blob, "x.png")
    for n, m in masks.items():
        assert np.array_equal(back.get(n).mask, m)
    with pytest.raises(RegionError, match="bad.png: cannot read region masks"):
        decode_regions(b"not a png", "bad.png")
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.zeros((64, 64), np.uint8)).save(buf, format="PNG")
    with pytest.raises(RegionError, match="plain.png: region metadata is missing"):
        decode_regions(buf.getvalue(), "plain.png")


def test_feather_is_a_ramp_of_the_given_width_in_mm() -> None:
    hard = np.zeros((64, 64), bool)
    hard[:, :32] = True
    soft = feather(hard, 4.0, np.full((64, 64), 0.5))  # 0.5 mm texels: a 4 mm ramp spans 8 texels
    row = soft[10]
    assert row[:27].min() == 1.0 and row[37:].max() == 0.0
    assert 0.4 < row[31] < 0.6 or 0.4 < row[32] < 0.6
    assert np.all(np.diff(row) <= 0)
    up = resample(soft, 128)
    assert up.shape == (128, 128) and abs(float(up.mean()) - float(soft.mean())) < 1e-3


def test_stay_inside_lips_never_paints_outside(sample: Document) -> None:
    lay = sample.add_layer("Lipstick Classic Red")
    lips = sample.region_values("lips", lay.resolution)
    lm = sample.head.metadata.landmarks
    with sample.stroke(lay, Brush(radius_mm=20, region="lips", amount_um=20)) as s:
        for name in ("mouth_right", "upper_lip", "lip_centre", "lower_lip", "mouth_left", "subnasale", "chin"):
            s.dab(lm[name])
    th = np.asarray(lay.thickness)
    assert th.max() > 10.0
    assert float(th[lips == 0].max()) == 0.0  # never beyond the region's feather
    sample.undo()
    assert not np.any(lay.thickness)
    # avoid: the same stroke never paints the lips
    with sample.stroke(lay, Brush(radius_mm=20, region="lips", region_mode="avoid", amount_um=20)) as s:
        for name in ("mouth_right", "lip_centre", "mouth_left"):
            s.dab(lm[name])
    th = np.asarray(lay.thickness)
    assert th.max() > 10.0 and float(th[lips == 1].max()) == 0.0
    sample.remove_layer(lay)


def test_fill_region_fills_to_the_line_with_a_soft_edge(sample: Document) -> None:
    lay = sample.add_layer("Lipstick Classic Red")
    lips = sample.region_values("lips", lay.resolution)
    sample.fill_region(lay, "lips", 20.0)
    th = np.asarray(lay.thickness)
    cov = sample.atlas_at(lay.resolution).coverage
    assert np.allclose(th[(lips == 1) & cov], 20.0)
    assert float(th[lips == 0].max()) == 0.0
    edge = (lips > 0.2) & (lips < 0.8) & cov
    assert np.all((th[edge] > 0) & (th[edge] < 20.0))
    sample.undo()
    assert not np.any(lay.thickness)
    # a click with the fill brush and a region fills the region, not the chart
    with sample.stroke(lay, Brush(mode="fill", region="lips", amount_um=15)) as s:
        s.dab(sample.head.metadata.landmarks["lip_centre"])
    assert np.allclose(np.asarray(lay.thickness)[(lips == 1) & cov], 15.0)
    sample.remove_layer(lay)


def test_regions_for_reads_stored_file_without_an_atlas() -> None:
    regions = regions_for(load_head())
    assert regions.names() == list(REGION_NAMES)


def test_median_filter_equals_scipys() -> None:
    """painting.regions.median_filter (local_texel_mm's) gives scipy's median filter exactly, edges included."""
    from scipy import ndimage

    from painting.regions import median_filter

    rng = np.random.default_rng(7)
    for shape, size in (((70, 53), 5), ((9, 130), 3), ((5, 5), 5), ((2, 3), 5)):
        values = rng.random(shape)
        values[rng.random(shape) < 0.3] = 0.25  # ties
        np.testing.assert_array_equal(median_filter(values, size, rows=16), ndimage.median_filter(values, size=size))
