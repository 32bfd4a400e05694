"""Level of detail (Paris et al. 2003, Fig. 13): a coarse head by quadric decimation, and the detail
texture re-baked onto it.

- :func:`simplify_head`: pyvista's (VTK's) quadric decimation to a target triangle count, the through the attribute error metric; the vertex normals are recomputed and the
  metadata (scale, landmarks, textures) kept.
- :func:`rebake_detail`: for every texel the coarse head covers in its own UV layout, the closest point
  on the fine surface (trimesh's proximity query) gives the fine UV where the fine detail texture is
  sampled (bilinear); uncovered texels take the nearest covered value. Decimation moves the UVs
  slightly, so reusing the fine texture unchanged would slide the detail against the coarse surface.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage

from km.errors import SheerError

from .raster import rasterize_uv


class SimplifyError(SheerError, ValueError):
    """A simplification request that cannot be met."""


def simplify_head(head: Any, faces: int) -> Any:
    """A coarse copy of ``head`` (a :class:`painting.head.Head`) with about ``faces`` triangles."""
    import pyvista as pv
    import trimesh

    n = len(head.faces)
    if not 4 <= faces < n:
        raise SimplifyError(f"--faces must be between 4 and {n - 1} (the head has {n} triangles), got {faces}")
    cells = np.hstack([np.full((n, 1), 3), head.faces]).ravel()
    mesh = pv.PolyData(np.asarray(head.vertices, dtype=np.float64), cells)
    mesh.active_texture_coordinates = np.asarray(head.uv, dtype=np.float64)
    coarse = mesh.decimate(1.0 - faces / n, boundary_constraints=True, boundary_weight=10.0)
    f = np.asarray(coarse.faces).reshape(-1, 4)[:, 1:].astype(np.int64)
    v = np.asarray(coarse.points, dtype=np.float64)
    # UVs: VTK's interpolated texture coordinates break where collapses cross the UV seams (a third of
    # the triangles spanned the whole atlas), so the UVs are taken per triangle corner from the fine
    # surface: each corner, nudged 15 % towards its triangle's centroid so the three land in the same UV
    # island, takes the UV of its closest point on the fine head. Corners are then unwelded (a vertex
    # per corner), as a UV seam needs.
    corners = v[f]  # (F, 3, 3)
    centroid = corners.mean(axis=1, keepdims=True)
    probe = 0.85 * corners + 0.15 * centroid
    uv_c = _closest_uv(head, probe.reshape(-1, 3))
    tri_pos = corners.reshape(-1, 3)
    v = tri_pos
    f = np.arange(len(tri_pos), dtype=np.int64).reshape(-1, 3)
    uv = uv_c
    # Smooth normals: those of the welded coarse surface, looked up per corner.
    welded = trimesh.Trimesh(np.asarray(coarse.points, dtype=np.float64),
                             np.asarray(coarse.faces).reshape(-1, 4)[:, 1:], process=False)
    normals = np.asarray(welded.vertex_normals, dtype=np.float64)[np.asarray(coarse.faces).reshape(-1, 4)[:, 1:]]
    normals = normals.reshape(-1, 3)
    return dataclasses.replace(head, vertices=v, faces=f, uv=np.clip(np.asarray(uv, dtype=np.float64), 0, 1),
                               normals=normals)


def _closest_uv(head: Any, points: np.ndarray) -> np.ndarray:
    """The fine head's UV at the closest surface point of each point (N, 3)."""
    import trimesh

    mesh = trimesh.Trimesh(head.vertices, head.faces, process=False)
    closest, _, tri = trimesh.proximity.closest_point(mesh, points)
    bary = trimesh.triangles.points_to_barycentric(mesh.triangles[tri], closest)
    return np.einsum("pk,pkc->pc", bary, np.asarray(head.uv)[head.faces[tri]])


def rebake_detail(fine: Any, coarse: Any, detail: np.ndarray, size: int | None = None) -> np.ndarray:
    """The fine head's detail texture (H, W, 3) re-baked into the coarse head's UV layout (size², float32)."""
    import trimesh

    from .pipeline import sample_texture

    size = int(size or detail.shape[0])
    gb = rasterize_uv(coarse.uv, coarse.faces, (size, size))
    cov = gb.covered
    b = gb.bary[cov].astype(np.float64)
    fc = coarse.faces[gb.tri[cov]]
    pos = np.einsum("pk,pkc->pc", b, coarse.vertices[fc])
    mesh = trimesh.Trimesh(fine.vertices, fine.faces, process=False)
    closest, _, tri = trimesh.proximity.closest_point(mesh, pos)
    corners = mesh.triangles[tri]
    bary = trimesh.triangles.points_to_barycentric(corners, closest)
    fine_uv = np.einsum("pk,pkc->pc", bary, fine.uv[fine.faces[tri]])
    out = np.zeros((size, size, 3), dtype=np.float32)
    out[cov] = sample_texture(np.asarray(detail, dtype=np.float64), fine_uv)
    _, (iy, ix) = ndimage.distance_transform_edt(~cov, return_indices=True)
    return out[iy, ix]


def write_obj(head: Any, path: str | Path) -> None:
    """Write a head mesh as OBJ with UVs and normals (trimesh), positions in mesh units."""
    import trimesh

    mesh = trimesh.Trimesh(head.vertices, head.faces, vertex_normals=head.normals, process=False,
                           visual=trimesh.visual.TextureVisuals(uv=head.uv))
    text = trimesh.exchange.obj.export_obj(mesh, include_normals=True, include_texture=True, write_texture=False)
    if isinstance(text, tuple):  # some trimesh versions return (obj, {material files})
        text = text[0]
    Path(path).write_text(text, encoding="utf-8")
