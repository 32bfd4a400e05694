"""Mesh cleaning, the UV check (overlap/mirroring), the xatlas fallback, the bake and its cache, and the
canonical face."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import trimesh

from core.assets import find_asset
from painting import Brush, Document
from painting.atlas import bake
from painting.layout import build_layout, check_uvs
from tests.painting.helpers import StandInLibrary, sample_atlas, sample_layout

if TYPE_CHECKING:
    from pathlib import Path

    import pytest


def _grid(n: int = 12, offset: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A bumpy square surface in [-1, 1]² (+offset in x), z up, counter-clockwise seen from +z."""
    xs = np.linspace(-1, 1, n + 1)
    x, y = np.meshgrid(xs, xs)
    z = 0.15 * np.sin(2.1 * x + 0.3) * np.cos(1.7 * y)
    v = np.stack([x.ravel() + offset, y.ravel(), z.ravel()], axis=1)
    i = np.arange(n * (n + 1)).reshape(n, n + 1)[:, :n].ravel()
    f = np.concatenate([np.stack([i, i + 1, i + n + 2], 1), np.stack([i, i + n + 2, i + n + 1], 1)])
    return v, f


def _write_obj(path: Path, v: np.ndarray, f: np.ndarray, uv: np.ndarray) -> Path:
    lines = [f"v {a:.9f} {b:.9f} {c:.9f}" for a, b, c in v]
    lines += [f"vt {a:.9f} {b:.9f}" for a, b in uv]
    lines += ["f " + " ".join(f"{k + 1}/{k + 1}" for k in tri) for tri in f]
    path.write_text("\n".join(lines) + "\n")
    return path


class _Head:
    def __init__(self, v: np.ndarray, f: np.ndarray, uv: np.ndarray, mm: float = 10.0) -> None:
        self.vertices, self.faces, self.uv, self.mm_per_unit = v, f, uv, mm


def test_sample_head_uses_its_own_uvs_and_reports_cleaning() -> None:
    layout = sample_layout()
    assert layout.source == "mesh"
    assert layout.check.valid and layout.check.overlapping_texels < 1000
    clean = layout.clean
    assert clean.welded_vertices > 0 and clean.degenerate_faces == 0 and clean.watertight
    assert "welded" in clean.summary()
    assert layout.charts == layout.check.charts > 1
    assert np.array_equal(layout.vertex_map, np.arange(len(layout.vertices)))


def test_mirrored_overlapping_uvs_are_detected_and_unwrapped(tmp_path: Path) -> None:
    v, f = _grid()
    uv = np.stack([0.1 + 0.8 * np.abs(v[:, 0]), 0.5 + 0.4 * v[:, 1]], axis=1)  # left half mirrors right
    check, _, _ = check_uvs(v, f, uv)
    assert not check.valid
    assert "overlapping" in check.reason and check.overlapping_texels > 1000
    stages: list[tuple[str, float]] = []
    layout = build_layout(_Head(v, f, uv), progress=lambda s, x: stages.append((s, x)))
    assert layout.source == "xatlas"
    assert ("unwrap", 1.0) in stages
    assert np.allclose(layout.vertices, v[layout.vertex_map])  # new -> original vertex map
    # Triangles keep their order and corners: layout triangle i is the file's triangle face_map[i].
    assert np.allclose(layout.vertices[layout.faces], v[f[layout.face_map]])
    assert np.allclose(layout.source_uv(_Head(v, f, uv)), uv[f[layout.face_map]])
    assert check_uvs(layout.vertices, layout.faces, layout.uv)[0].overlapping_texels == 0
    # The same mesh through the file loader and a document: paintable.
    obj = _write_obj(tmp_path / "mirrored.obj", v, f, uv)
    doc = Document.from_head(obj, library=StandInLibrary(), resolution=256, cache=False)
    assert doc.layout.source == "xatlas"
    layer = doc.add_layer("Foundation 1")
    with doc.stroke(layer, Brush(radius_mm=3.0, hardness=1.0)) as s:
        s.dab(v[f[40, 0]])
    assert layer.thickness.any()


def test_a_mirrored_but_separate_chart_is_valid() -> None:
    v1, f1 = _grid(8, offset=-1.5)
    v2, f2 = _grid(8, offset=1.5)
    uv1 = np.stack([0.05 + 0.2 * (v1[:, 0] + 2.5), 0.5 + 0.4 * v1[:, 1]], 1)
    uv2 = np.stack([0.95 - 0.2 * (v2[:, 0] - 0.5), 0.5 + 0.4 * v2[:, 1]], 1)  # flipped in u
    v = np.concatenate([v1, v2])
    f = np.concatenate([f1, f2 + len(v1)])
    check, chart, _ = check_uvs(v, f, np.concatenate([uv1, uv2]))
    assert check.valid, check.reason
    assert check.charts == 2 and check.mirrored_charts == 1 and check.mirrored_faces == 0
    # A fold inside one chart (a single flipped triangle) is caught.
    uv_fold = np.concatenate([uv1, uv2])
    k = f1[30, 0]
    uv_fold[k] = uv_fold[k] + np.array([0.12, 0.0])
    assert not check_uvs(v, f, uv_fold)[0].valid


def test_bake_is_conservative_on_the_surface_and_padded() -> None:
    atlas = sample_atlas(256)
    layout = sample_layout()
    res = atlas.resolution
    # Every triangle with some UV area covers the texel under its UV centroid.
    cen = layout.uv[layout.faces].mean(axis=1)
    t = layout.uv[layout.faces]
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    area = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) / 2
    big = area > 4.0 / res**2
    rows = np.clip((cen[big, 1] * res).astype(int), 0, res - 1)
    cols = np.clip((cen[big, 0] * res).astype(int), 0, res - 1)
    assert atlas.coverage[rows, cols].all()
    # Covered texels lie on the surface, normals are unit.
    mesh = layout.trimesh()
    flat = np.flatnonzero(atlas.coverage.reshape(-1))[::97]
    _, dist, _ = trimesh.proximity.closest_point(mesh, atlas.position.reshape(-1, 3)[flat])
    assert dist.max() < 1e-4
    n = atlas.normal[atlas.coverage]
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-4)
    # Padding: within N texels of coverage, copies of the nearest covered texel.
    from scipy import ndimage

    dist_px = ndimage.distance_transform_edt(~atlas.coverage)
    assert np.array_equal(atlas.padded, (~atlas.coverage) & (dist_px <= atlas.padding))
    pos = atlas.position.reshape(-1, 3)
    assert np.array_equal(pos[atlas.pad_dst], pos[atlas.pad_src])
    assert atlas.coverage.reshape(-1)[atlas.pad_src].all()
    assert np.all(np.diff(atlas.pad_src) >= 0)


def test_bake_cache_round_trip(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from core.cache import load_arrays, save_arrays
    from painting.atlas import _CACHE_VERSION

    monkeypatch.setenv("SHEER_CACHE_DIR", str(tmp_path))
    layout = sample_layout()
    first = bake(layout, 512, cache=True)
    entries = list((tmp_path / "atlas").iterdir())
    assert len(entries) == 1 and entries[0].is_file() and entries[0].suffix == ".cache"
    second = bake(layout, 512, cache=True)
    for name in ("position", "normal", "face", "chart", "coverage", "padded", "pad_dst", "pad_src"):
        assert np.array_equal(getattr(first, name), getattr(second, name))
    assert (second.resolution, second.padding, second.texel_mm) == (first.resolution, first.padding, first.texel_mm)
    entries[0].write_bytes(b"broken")  # a damaged cache is ignored, baked and written again
    third = bake(layout, 512, cache=True)
    assert np.array_equal(third.position, first.position)
    stored = load_arrays(entries[0], _CACHE_VERSION)
    assert stored is not None and np.array_equal(stored["position"], first.position)
    stored["position"] = np.zeros((4, 4, 3), np.float32)  # well-formed, the wrong shape: baked again
    save_arrays(entries[0], stored, _CACHE_VERSION)
    assert np.array_equal(bake(layout, 512, cache=True).position, first.position)


def test_spatial_index_is_kept_beside_the_bake(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The texel index of a cached bake is written once and read back equal; a damaged copy is rebuilt."""
    from core.cache import load_arrays
    from painting.atlas import _INDEX_CACHE_VERSION

    monkeypatch.setenv("SHEER_CACHE_DIR", str(tmp_path))
    layout = sample_layout()
    built = bake(layout, 512, cache=True).index
    entries = list((tmp_path / "index").iterdir())
    assert len(entries) == 1 and entries[0].is_file()
    read = bake(layout, 512, cache=True).index
    for name in ("cell_start", "pn", "flat", "tile", "has_pad", "x", "nz", "origin"):
        assert np.array_equal(getattr(read, name), getattr(built, name)), name
    assert (read.cell, read.dims) == (built.cell, built.dims)
    # the same dab through either index
    p = built.point(len(built) // 2).astype(np.float64)
    assert np.array_equal(read.query_sphere(p, 0.2), built.query_sphere(p, 0.2))
    entries[0].write_bytes(b"broken")
    again = bake(layout, 512, cache=True).index
    assert np.array_equal(again.pn, built.pn)
    stored = load_arrays(entries[0], _INDEX_CACHE_VERSION)
    assert stored is not None and np.array_equal(stored["pn"], built.pn)  # written anew
    entries[0].unlink()
    entries[0].mkdir()  # a folder where the entry should be: not readable, rebuilt (not written over it)
    assert np.array_equal(bake(layout, 512, cache=True).index.flat, built.flat)


def test_canonical_face_loads_with_the_right_uvs_and_paints() -> None:
    path = find_asset("heads/canonical-face/canonical_face_model.obj")
    vt, corners_v, corners_t = [], [], []
    for line in path.read_text().splitlines():
        parts = line.split()
        if parts and parts[0] == "vt":
            vt.append([float(parts[1]), float(parts[2])])
        elif parts and parts[0] == "f":
            for c in parts[1:]:
                a, b = c.split("/")[:2]
                corners_v.append(int(a) - 1)
                corners_t.append(int(b) - 1)
    doc = Document.from_head(path, library=StandInLibrary(), resolution=256, cache=False)
    # trimesh applies the face lines' UV indices: vertex i gets the vt its face corners name.
    assert np.allclose(doc.head.uv[corners_v], np.asarray(vt)[corners_t])
    assert doc.head.mm_per_unit == 10.0
    assert doc.layout.source in ("mesh", "xatlas")
    layer = doc.add_layer("Blush 1")
    cheek = doc.head.landmark("left_cheek")
    with doc.stroke(layer, Brush(radius_mm=12.0, hardness=1.0, mirror=True)) as s:
        s.dab(cheek)
    flat = np.flatnonzero(doc.atlas.coverage.reshape(-1))
    pos = doc.atlas.position.reshape(-1, 3)[flat]
    t = layer.thickness.reshape(-1)[flat]
    for p in (cheek, doc.mirror_point(cheek)):
        near = np.linalg.norm(pos - p, axis=1) < 0.5  # 5 mm
        assert near.any() and np.all(t[near] == 8.0)
    hit = doc.hit(doc.head.landmark("nose_tip") + np.array([0, 0, 5.0]), (0, 0, -1))
    assert hit is not None and np.linalg.norm(hit.point - doc.head.landmark("nose_tip")) < 0.05


def test_cleaning_drops_degenerate_and_fixes_winding() -> None:
    from painting.layout import clean_mesh

    v, f = _grid(6)
    f = f.copy()
    f[:5] = f[:5][:, [0, 2, 1]]  # five triangles wound the wrong way
    bad = np.array([[0, 0, 1], [3, 4, 3]])  # repeated corners
    kept, index, normals, report = clean_mesh(v, np.concatenate([f, bad]))
    assert report.degenerate_faces == 2 and len(kept) == len(f)
    assert report.flipped_faces == 5 and report.flipped is not None and report.flipped[:5].all()
    n = np.cross(v[kept[:, 1]] - v[kept[:, 0]], v[kept[:, 2]] - v[kept[:, 0]])
    assert np.all(np.sign(n[:, 2]) == np.sign(n[0, 2]))  # one consistent orientation
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)
