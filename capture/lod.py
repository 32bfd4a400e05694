"""Level of detail (Paris et al. 2003, Fig. 13): a coarse head, and the detail texture re-baked onto it.

- :func:`simplify_head`: pyvista's (VTK's) quadric decimation to a target triangle count; UVs per
  triangle corner from the fine surface (:func:`uv_faults` finds the triangles where that fails, which
  are redone within one UV chart); the vertex normals are recomputed and the metadata (scale,
  landmarks, textures) kept.
- :func:`rebake_detail`: for every texel the coarse head covers in its own UV layout, the closest point
  on the fine surface (trimesh's proximity query) gives the fine UV where the fine detail texture is
  sampled (bilinear); uncovered texels take the nearest covered value. Decimation moves the UVs
  slightly, so reusing the fine texture unchanged would slide the detail against the coarse surface.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from scipy import ndimage

from capture.raster import rasterize_uv
from core.errors import SheerError

if TYPE_CHECKING:
    from painting.head import Head


class SimplifyError(SheerError, ValueError):
    """A simplification request that cannot be met."""


def simplify_head(head: Head, faces: int) -> Head:
    """A coarse copy of ``head`` with about ``faces`` triangles (4 ≤ ``faces`` < the head's count).

    The copy has one vertex per triangle corner (UV seams), the welded coarse surface's vertex normals,
    and the head's metadata and textures. Raises :class:`SimplifyError` for a count out of range.
    """
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
    uv_c = _closest_uv(head, probe.reshape(-1, 3)).reshape(-1, 3, 2)
    # Triangles whose UVs still misrepresent the surface (folded, or straddling a seam: 137 of 1,143 on
    # the sample head) take their corners' UVs within one chart (:func:`_chart_uvs`): the UV texels
    # claimed by two coarse triangles fall from 1,346 to 714 (at 512²), the folds from 46 to 39. The
    # 126 still flagged are not split. Of them (closest fine face at corners, centroid and edge
    # midpoints), 94 reach into a small UV island (eyelids, eyes, the mouth's and the bust's underside:
    # 58-384 fine faces, about a coarse triangle across, so the island's border wiggles in and out of
    # the triangle), 32 lie on the main chart (21 folded, ~10 across its wrap-around seam). A cut at
    # one seam crossing per edge (37 triangles with one corner beyond the seam, +74 triangles) changed
    # nothing measurable: rendered from 36 directions with the albedo re-baked, mean ΔE2000 coarse vs
    # fine 0.416 before and after, 0.525 within 0.3 mesh units of a seam (p99 4.79) before and after;
    # with the fine albedo used directly 0.938 / 1.048 both times. The re-bake samples the fine surface
    # at each texel's 3D position, so a straddling triangle's texels are right where they are seen.
    fault = uv_faults(head, dataclasses.replace(head, vertices=corners.reshape(-1, 3),
                                                faces=np.arange(corners.size // 3).reshape(-1, 3),
                                                uv=uv_c.reshape(-1, 2)))
    if fault.any():
        uv_c[fault] = _chart_uvs(head, corners[fault])
    uv_c = uv_c.reshape(-1, 2)
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


def _face_neighbours(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR (start (V+1,), faces) of the faces around each vertex *index*.

    A UV seam splits vertices, so adjacency through shared indices never crosses a seam.
    """
    vf = faces.ravel()
    owner = np.repeat(np.arange(len(faces)), 3)
    order = np.argsort(vf, kind="stable")
    start = np.searchsorted(vf[order], np.arange(n_vertices + 1))
    return start, owner[order]


def _chart_uvs(fine: Head, corners: np.ndarray) -> np.ndarray:
    """UVs (T, 3, 2) for coarse triangles (T, 3, 3) (mesh units) taken within one UV chart each.

    The chart: the fine faces reachable from the face nearest the triangle's centroid through shared
    vertices (so not across a seam), within 1.25× the triangle's circumradius (+ 2 fine edges) of its
    centroid; each corner takes the UV of its closest point among them (a corner beyond the seam lands on
    the seam's edge).
    """
    import trimesh

    faces = np.asarray(fine.faces)
    verts = np.asarray(fine.vertices, dtype=np.float64)
    start, around = _face_neighbours(faces, len(verts))
    fcen = verts[faces].mean(axis=1)
    mesh = trimesh.Trimesh(verts, faces, process=False)
    cen = corners.mean(axis=1)
    _, _, f0 = trimesh.proximity.closest_point(mesh, cen)
    edge = float(np.median(np.linalg.norm(verts[faces[:, 0]] - verts[faces[:, 1]], axis=1)))
    radius = 1.25 * np.linalg.norm(corners - cen[:, None], axis=2).max(axis=1) + 2 * edge
    pair_t, pair_f = [], []
    for t in range(len(corners)):
        seen = {int(f0[t])}
        stack = [int(f0[t])]
        c, r2 = cen[t], radius[t] ** 2
        while stack:
            f = stack.pop()
            for v in faces[f]:
                for g in around[start[v]:start[v + 1]].tolist():
                    if g not in seen:
                        d = fcen[g] - c
                        if float(d @ d) <= r2:
                            seen.add(g)
                            stack.append(g)
        pair_t.append(np.full(len(seen), t))
        pair_f.append(np.fromiter(seen, dtype=np.int64))
    pt = np.concatenate(pair_t)
    pf = np.concatenate(pair_f)
    tris = verts[faces[pf]]
    uv = np.zeros(corners.shape[:2] + (2,))
    for k in range(3):
        p = corners[pt, k]
        q = trimesh.triangles.closest_point(tris, p)
        d = np.einsum("ij,ij->i", q - p, q - p)
        o = np.lexsort((d, pt))
        first = np.r_[True, pt[o][1:] != pt[o][:-1]]
        sel = o[first]
        b = trimesh.triangles.points_to_barycentric(tris[sel], q[sel])
        uv[pt[sel], k] = np.einsum("pk,pkc->pc", b, np.asarray(fine.uv)[faces[pf[sel]]])
    return uv


def uv_faults(fine: Head, coarse: Head, tol: float = 0.05) -> np.ndarray:
    """Bool (T,), one per coarse triangle: its UVs misrepresent the fine surface under it.

    Folded (UV winding against the fine's there, relative to the 3D winding) or inconsistent (at the
    centroid or an edge midpoint, the UV interpolated on the coarse triangle is more than ``tol`` — UV
    units, [0, 1] across the texture — from the fine surface's UV at the closest point: the triangle
    straddles a seam).
    """
    import trimesh

    mesh = trimesh.Trimesh(fine.vertices, fine.faces, process=False)
    v = np.asarray(coarse.vertices)[coarse.faces]
    t = np.asarray(coarse.uv)[coarse.faces]
    samples = np.array([[1 / 3, 1 / 3, 1 / 3], [0.5, 0.5, 0.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.5]])
    err = np.zeros(len(v))
    tri_c = None
    for w in samples:
        p = np.einsum("k,fkc->fc", w, v)
        closest, _, tri = trimesh.proximity.closest_point(mesh, p)
        tri_c = tri if tri_c is None else tri_c
        b = trimesh.triangles.points_to_barycentric(mesh.triangles[tri], closest)
        uv_f = np.einsum("pk,pkc->pc", b, np.asarray(fine.uv)[fine.faces[tri]])
        err = np.maximum(err, np.linalg.norm(uv_f - np.einsum("k,fkc->fc", w, t), axis=1))

    def winding(uv: np.ndarray, pos: np.ndarray, normal: np.ndarray) -> np.ndarray:
        a2 = (uv[:, 1, 0] - uv[:, 0, 0]) * (uv[:, 2, 1] - uv[:, 0, 1]) - (uv[:, 2, 0] - uv[:, 0, 0]) * (uv[:, 1, 1] - uv[:, 0, 1])
        n3 = np.cross(pos[:, 1] - pos[:, 0], pos[:, 2] - pos[:, 0])
        return np.sign(a2) * np.sign(np.einsum("ij,ij->i", n3, normal))

    fn = mesh.face_normals[tri_c]
    fine_w = winding(np.asarray(fine.uv)[fine.faces[tri_c]], mesh.triangles[tri_c], fn)
    return (winding(t, v, fn) != fine_w) | (err > tol)


def _closest_uv(head: Head, points: np.ndarray) -> np.ndarray:
    """The fine head's UV at the closest surface point of each point (N, 3)."""
    import trimesh

    mesh = trimesh.Trimesh(head.vertices, head.faces, process=False)
    closest, _, tri = trimesh.proximity.closest_point(mesh, points)
    bary = trimesh.triangles.points_to_barycentric(mesh.triangles[tri], closest)
    return np.einsum("pk,pkc->pc", bary, np.asarray(head.uv)[head.faces[tri]])


def rebake_detail(fine: Head, coarse: Head, detail: np.ndarray, size: int | None = None) -> np.ndarray:
    """The fine head's detail texture (H, W, 3) re-baked into the coarse head's UV layout.

    Returns float32 (size, size, 3) (``size`` None: the detail's own height), the values sampled from
    ``detail`` (bilinear), so in its range.
    """
    import trimesh

    from capture.pipeline import sample_texture

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


def write_obj(head: Head, path: str | Path) -> None:
    """Write a head mesh as OBJ with UVs and normals (trimesh), positions in mesh units."""
    import trimesh

    mesh = trimesh.Trimesh(head.vertices, head.faces, vertex_normals=head.normals, process=False,
                           visual=trimesh.visual.TextureVisuals(uv=head.uv))
    text = trimesh.exchange.obj.export_obj(mesh, include_normals=True, include_texture=True, write_texture=False)
    if isinstance(text, tuple):  # some trimesh versions return (obj, {material files})
        text = text[0]
    Path(path).write_text(text, encoding="utf-8")
