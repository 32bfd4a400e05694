"""A full head for the person: the sample head's skull, ears and neck warped onto her face-mesh landmarks.

The automatic capture's own head (:func:`capture.person.person_head`) is MediaPipe's canonical face
topology: a face and nothing around it, so a turned view shows a mask. :func:`fit_full_head` deforms the
sample head (:func:`painting.head.load_head`) so that its face passes through her 468 metric landmarks and
the rest of it (skull, ears, neck) follows smoothly:

1. **Correspondences** (:func:`sample_correspondences`, computed once per process): each of the canonical
   face model's 468 vertices gets a point on the sample head's surface. The canonical model's standard
   landmarks (``resources/heads/canonical-face.json``, the sidecar definitions of
   :data:`capture.landmarks.STANDARD_LANDMARKS`) are mapped onto the sample head's sidecar landmarks by a
   similarity, then by a thin-plate spline (:class:`scipy.interpolate.RBFInterpolator`); every canonical
   vertex so carried is snapped to the sample head's nearest surface point (trimesh), kept as a triangle
   and barycentric coordinates.
2. **Similarity** (Umeyama's least-squares rotation, uniform scale and translation) of those 468 surface
   points onto her landmarks (the person's head's vertices: the canonical frame, centimetres).
3. **Warp**: a thin-plate spline (degree 1, lightly smoothed: :data:`WARP_SMOOTHING`) of the remaining
   displacements at :data:`WARP_POINTS`, evaluated at every sample-head vertex, so her landmarks are met
   to a fraction of a millimetre (the residual is measured and returned; Grace Hopper's portrait: median
   0.18 mm, 95th percentile 0.61 mm) and the skull, ears and neck follow smoothly.

The fitted head keeps the sample head's topology and UVs (its regions and skin mask apply as they are), is
in her frame and units (centimetres, ``mm_per_unit`` 10) and has her standard landmarks; its albedo is not
the sample's (the capture bakes her own, :mod:`capture.auto`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from capture.errors import CaptureError
from capture.landmarks import N_MESH

if TYPE_CHECKING:
    from pathlib import Path

    from painting.head import Head

#: The canonical face model's sidecar (its standard landmarks), in resources/heads/.
CANONICAL_SIDECAR = "canonical-face.json"
#: The fitted head's mesh units: centimetres, like the person's head (mm per unit).
MM_PER_UNIT = 10.0
#: Face-mesh points the warp does not use: the eyes' and the inner lips' rims between their corners
#: (MediaPipe's ``*EyeUpper0``/``*EyeLower0`` and ``lips*Inner`` contours). The sample head's eyes and mouth
#: are closed, so her open lids' two rims would land on one line of its surface and fold the lids over.
OPEN_RIMS: frozenset[int] = frozenset({
    246, 161, 160, 159, 158, 157, 173, 7, 163, 144, 145, 153, 154, 155,  # right eye (corners 33, 133 kept)
    466, 388, 387, 386, 385, 384, 398, 249, 390, 373, 374, 380, 381, 382,  # left eye (corners 263, 362 kept)
    191, 80, 81, 82, 13, 312, 311, 310, 415, 95, 88, 178, 87, 14, 317, 402, 318, 324})  # inner lips (78, 308 kept)
#: The thin-plate spline's smoothing (scipy's ``smoothing``; displacements in centimetres): on Grace Hopper's
#: portrait 0 left 6 of the 17,684 triangles inverted around the eyes' outer corners, 0.03 none, with the
#: landmark residual's median 0.14 -> 0.18 mm and its 95th percentile 0.50 -> 0.61 mm.
WARP_SMOOTHING = 0.03
#: The face-mesh points the warp is fitted to (all but :data:`OPEN_RIMS`).
WARP_POINTS = np.array(sorted(set(range(N_MESH)) - OPEN_RIMS), dtype=np.int64)


@dataclass(frozen=True)
class Correspondences:
    """The 468 face-mesh points on the sample head's surface.

    Attributes:
        faces: int64 (468,), the sample head's triangle each point lies on.
        bary: float64 (468, 3), the point's barycentric coordinates in it.
        snap_mm: float64 (468,), how far (mm) the carried canonical vertex was from that surface point.
    """

    faces: np.ndarray
    bary: np.ndarray
    snap_mm: np.ndarray

    def points(self, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
        """The points on a mesh with the sample head's topology (``vertices`` (N, 3)): float64 (468, 3)."""
        tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)[self.faces]]  # (468, 3, 3)
        return np.einsum("pk,pkc->pc", self.bary, tri)


@dataclass(frozen=True)
class FullHeadFit:
    """The fitted full head and how well it meets her landmarks.

    Attributes:
        head: the sample head warped onto her (:class:`painting.head.Head`, centimetres, her frame).
        residual_mm: float64 (468,), the distance (mm) of each warped correspondence from her landmark.
        scale: the similarity's scale (her centimetres per sample-head unit).
        correspondences: the face-mesh points on the head (:class:`Correspondences`).
    """

    head: Head
    residual_mm: np.ndarray
    scale: float
    correspondences: Correspondences

    def face_points(self) -> np.ndarray:
        """Her 468 face-mesh points as they lie on the fitted head: float64 (468, 3), centimetres."""
        return self.correspondences.points(self.head.vertices, self.head.faces)


def similarity(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """The least-squares similarity dst ≈ s·R·src + t (Umeyama 1991): (s, R (3, 3), t (3,)).

    ``src``, ``dst``: float (N, 3), N ≥ 3 points not all on a line.
    """
    mu_s, mu_d = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - mu_s, dst - mu_d
    u, sig, vt = np.linalg.svd(b.T @ a / len(src))
    d = np.ones(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        d[2] = -1.0
    rot = u @ np.diag(d) @ vt
    var = float((a ** 2).sum() / len(src))
    if var <= 0:
        raise CaptureError("the landmarks for the full head's fit are all at one point")
    s = float((sig * d).sum() / var)
    return s, rot, mu_d - s * rot @ mu_s


def _tps(src: np.ndarray, dst: np.ndarray, at: np.ndarray, smoothing: float = 0.0) -> np.ndarray:
    """The thin-plate spline taking ``src`` onto ``dst`` (degree 1; ``smoothing`` 0 interpolates), at ``at``."""
    from scipy.interpolate import RBFInterpolator

    warp = RBFInterpolator(src, dst - src, kernel="thin_plate_spline", degree=1, smoothing=smoothing)
    return np.asarray(at, dtype=np.float64) + warp(at)


_correspondences: dict[str, Correspondences] = {}


def sample_correspondences(sample: Head) -> Correspondences:
    """The canonical face model's 468 vertices on ``sample``'s surface (cached per head file; module docstring).

    Raises:
        CaptureError: ``sample``'s sidecar names fewer than 10 of the standard landmarks.
    """
    key = str(sample.path)
    if key in _correspondences:
        return _correspondences[key]
    import json

    import trimesh

    from capture.person import canonical_topology
    from core.assets import resource_path

    canon = json.loads(resource_path("heads", CANONICAL_SIDECAR).read_text(encoding="utf-8"))["landmarks"]
    names = [n for n in canon if n in sample.metadata.landmarks]
    if len(names) < 10:
        raise CaptureError(f"head '{sample.name}': its sidecar names {len(names)} of the standard landmarks; "
                           f"the full head's fit needs at least 10")
    src = np.array([canon[n] for n in names], dtype=np.float64)
    dst = np.array([sample.metadata.landmarks[n] for n in names], dtype=np.float64)
    s, rot, t = similarity(src, dst)
    src_aligned = src @ (s * rot).T + t
    carried = _tps(src_aligned, dst, canonical_topology().vertices @ (s * rot).T + t)
    mesh = trimesh.Trimesh(np.asarray(sample.vertices, dtype=np.float64), np.asarray(sample.faces), process=False)
    on, dist, tri = trimesh.proximity.closest_point(mesh, carried)
    tri = np.asarray(tri, dtype=np.int64)
    bary = trimesh.triangles.points_to_barycentric(mesh.triangles[tri], on)
    corr = Correspondences(faces=tri, bary=np.asarray(bary, dtype=np.float64),
                           snap_mm=np.asarray(dist, dtype=np.float64) * float(sample.mm_per_unit))
    for a in (corr.faces, corr.bary, corr.snap_mm):
        a.flags.writeable = False
    _correspondences[key] = corr
    return corr


def fit_full_head(landmarks_cm: np.ndarray, sample: Head | None = None, name: str = "Captured head") -> FullHeadFit:
    """The sample head warped onto her metric face-mesh landmarks (see the module docstring).

    Args:
        landmarks_cm: her 468 (or 478) face-mesh points, float (N, 3), centimetres in the canonical frame
            (+X her left, +Y up, +Z out of the face): :func:`capture.person.person_head`'s vertices.
        sample: the head to warp (default the sample head, :func:`painting.head.load_head`).
        name: the fitted head's display name.

    Returns:
        The fit (:class:`FullHeadFit`); its head's ``path`` is ``sample``'s (a face folder writes it elsewhere).

    Raises:
        CaptureError: landmarks of the wrong shape or not finite, or a sample head without landmarks.
    """
    import trimesh

    from capture.person import midplane, surface_points
    from painting.head import Head, HeadMetadata, load_head

    her = np.asarray(landmarks_cm, dtype=np.float64)
    if her.ndim != 2 or her.shape[1] != 3 or her.shape[0] < N_MESH or not np.isfinite(her).all():
        raise CaptureError(f"the full head needs {N_MESH} finite 3D face-mesh points, got an array of shape "
                           f"{her.shape}")
    her = her[:N_MESH]
    sample = load_head() if sample is None else sample
    corr = sample_correspondences(sample)
    src = corr.points(sample.vertices, sample.faces)[WARP_POINTS]
    s, rot, t = similarity(src, her[WARP_POINTS])
    aligned = np.asarray(sample.vertices, dtype=np.float64) @ (s * rot).T + t
    vertices = _tps(src @ (s * rot).T + t, her[WARP_POINTS], aligned, WARP_SMOOTHING)
    faces = np.asarray(sample.faces, dtype=np.int64).copy()
    normals = np.asarray(trimesh.Trimesh(vertices, faces, process=False).vertex_normals, dtype=np.float64)
    residual = np.linalg.norm(corr.points(vertices, faces) - her, axis=1) * MM_PER_UNIT
    meta = sample.metadata
    landmarks = surface_points(her, _canonical_faces())
    mid_p, mid_n = midplane(her)
    fitted_meta = HeadMetadata(
        name=name, mm_per_unit=MM_PER_UNIT,
        scale_note=(f"Mesh units are centimetres (her face-mesh landmarks'). The sample head '{sample.name}' "
                    f"warped onto her {N_MESH} face-mesh landmarks (a similarity, scale {s * 10:.3f} mm per "
                    f"sample unit, then a thin-plate spline); landmark residual median "
                    f"{float(np.median(residual)):.3f} mm, max {float(residual.max()):.3f} mm."),
        landmarks=landmarks, midplane_point=mid_p, midplane_normal=mid_n,
        albedo=None, credit=f"Head shape: {meta.credit}; face from her photograph", calibrated=True,
        skin_mask=meta.skin_mask)
    head = Head(path=sample.path, vertices=vertices, faces=faces, uv=np.asarray(sample.uv, dtype=np.float64).copy(),
                normals=normals, metadata=fitted_meta, skin_mask=sample.skin_mask)
    return FullHeadFit(head=head, residual_mm=residual, scale=s, correspondences=corr)



def _canonical_faces() -> np.ndarray:
    from capture.person import canonical_topology

    return canonical_topology().faces


#: Over how many millimetres inside her face mesh's open boundary the photograph's detail fades in.
FACE_FEATHER_MM = 12.0
#: A full-head vertex farther than this (mm) from her face mesh is not on her face.
ON_FACE_MM = 3.0
#: The cosine between a texel's normal and the direction to the photograph's camera below which the
#: photograph's detail fades out (at grazing angles one photograph pixel is smeared over many texels).
FACING_COS = (0.2, 0.5)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def face_weight(head: Head, person: Head, centre: np.ndarray) -> np.ndarray:
    """Per vertex of the fitted ``head``, how much of the photograph's detail it keeps: float64 (N,) in [0, 1].

    1 on her face (within :data:`ON_FACE_MM` of the ``person``'s face mesh) farther than
    :data:`FACE_FEATHER_MM` from its open boundary, falling smoothly to 0 at the boundary; 0 off her face
    (skull, ears, neck); times the facing weight (:data:`FACING_COS`, the vertex normal against the direction
    to the photograph's camera at ``centre``, mesh coordinates).
    """
    import trimesh
    from scipy.spatial import cKDTree

    v = np.asarray(head.vertices, dtype=np.float64)
    face_mesh = trimesh.Trimesh(np.asarray(person.vertices, dtype=np.float64)[:N_MESH], person.faces, process=False)
    lo, hi = face_mesh.bounds
    near = np.all((v >= lo - ON_FACE_MM / float(head.mm_per_unit)) & (v <= hi + ON_FACE_MM / float(head.mm_per_unit)),
                  axis=1)  # the rest (skull, neck, shoulders) is farther than ON_FACE_MM: no surface query
    dist = np.full(len(v), np.inf)
    if near.any():
        dist[near] = trimesh.proximity.closest_point(face_mesh, v[near])[1]
    edges = face_mesh.edges_sorted
    uniq, counts = np.unique(edges, axis=0, return_counts=True)
    boundary = np.unique(uniq[counts == 1])
    d_boundary, _ = cKDTree(face_mesh.vertices[boundary]).query(v, k=1)
    mm = float(head.mm_per_unit)
    on_face = (np.asarray(dist) * mm <= ON_FACE_MM).astype(np.float64)
    inside = _smoothstep(d_boundary * mm / FACE_FEATHER_MM)
    view = np.asarray(centre, dtype=np.float64)[None, :] - v
    view /= np.maximum(np.linalg.norm(view, axis=1, keepdims=True), 1e-12)
    cos = np.einsum("pc,pc->p", np.asarray(head.normals, dtype=np.float64), view)
    facing = _smoothstep((cos - FACING_COS[0]) / (FACING_COS[1] - FACING_COS[0]))
    return on_face * inside * facing


def blend_detail(head: Head, detail: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """The detail texture with the photograph's detail kept by ``weight`` and her plain skin tone elsewhere.

    ``detail``: float32 (S, S, 3), the capture's detail in ``head``'s UV space (1 = the fitted diffuse
    colour); ``weight``: per vertex (:func:`face_weight`), interpolated over each texel's triangle. Her
    skin tone is the detail as her face shows it: per channel, the median of ``detail`` over the texels
    wholly hers (weight ≥ 0.99) that the head's skin mask calls skin (all of them without a mask). The
    fitted diffuse colour alone (detail 1) is not her face's colour as photographed: on Grace Hopper's
    portrait her face's median detail is 0.97, 0.93, 0.82 (R, G, B), the fit's diffuse colour bluer than
    her skin. Returns float32 (S, S, 3): weight·detail + (1 − weight)·tone (the gutter copies the nearest
    covered texel, as the capture's bake does).
    """
    from capture.pipeline import uv_layout

    size = detail.shape[0]
    gb, iy, ix = uv_layout(head.uv, head.faces, size)
    w = np.zeros((size, size), dtype=np.float64)
    cov = gb.covered
    w[cov] = np.einsum("pk,pk->p", gb.bary[cov].astype(np.float64), weight[head.faces[gb.tri[cov]]])
    w = w[iy, ix]
    hers = cov & (w >= 0.99)
    if head.skin_mask is not None:  # the mask at its own size, read at the detail's texels (nearest)
        mh, mw = head.skin_mask.shape[:2]
        skin = head.skin_mask[(np.arange(size) * mh // size)[:, None], (np.arange(size) * mw // size)[None, :]]
        hers &= skin
    tone = np.median(detail[hers], axis=0) if hers.sum() >= 64 else np.ones(3)
    return (w[..., None] * detail + (1.0 - w[..., None]) * tone).astype(np.float32)


#: The fitted head's skin mask in the face folder (the sample head's, in the same UVs).
SKIN_MASK_FILE = "skin-mask.png"


def obj_text(head: Head) -> str:
    """The fitted head as Wavefront OBJ text (one ``vt`` per vertex, same index)."""
    lines = ["# Sheer captured head: the sample head's topology and UVs warped onto the face from the photograph",
             f"# mesh units: centimetres ({head.mm_per_unit:g} mm per unit)"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in head.vertices]
    lines += [f"vt {u:.10f} {v:.10f}" for u, v in head.uv]  # the sample's UVs exactly enough: 6 decimals fold a sliver
    lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in head.faces]
    return "\n".join(lines) + "\n"


def write_full_head(head: Head, folder: Path, albedo_srgb8: np.ndarray, sample: Head | None = None) -> list[Path]:
    """Write the fitted head into ``folder``: ``head.obj``, its sidecar, ``albedo.png``, the regions and skin mask.

    The regions and the skin mask are ``sample``'s (default the sample head; same UVs), copied. ``albedo_srgb8``:
    uint8 (S, S, 3) sRGB in the head's UV space. Returns the files written.
    """
    import dataclasses
    import shutil

    from PIL import Image

    from capture.face import PNG_SAVE
    from capture.person import ALBEDO_FILE, HEAD_FILE, sidecar_json
    from painting.head import SIDECAR_SUFFIX, find_sidecar, load_head
    from painting.regions import regions_file

    sample = load_head() if sample is None else sample
    mesh = folder / HEAD_FILE
    sidecar = folder / (HEAD_FILE + SIDECAR_SUFFIX)
    files = [mesh, sidecar, folder / ALBEDO_FILE]
    sample_sidecar = find_sidecar(sample.path)
    regions = regions_file(sample_sidecar) if sample_sidecar is not None else None
    if head.skin_mask is not None:
        Image.fromarray(np.asarray(head.skin_mask, dtype=np.uint8) * 255).save(folder / SKIN_MASK_FILE, **PNG_SAVE)
        files.append(folder / SKIN_MASK_FILE)
    meta = dataclasses.replace(head.metadata, albedo=ALBEDO_FILE,
                               skin_mask=SKIN_MASK_FILE if head.skin_mask is not None else None)
    mesh.write_text(obj_text(head), encoding="utf-8")
    sidecar.write_text(sidecar_json(meta), encoding="utf-8")
    Image.fromarray(np.asarray(albedo_srgb8, dtype=np.uint8)).save(folder / ALBEDO_FILE, **PNG_SAVE)
    if regions is not None and regions.is_file():
        shutil.copyfile(regions, regions_file(sidecar))
        files.append(regions_file(sidecar))
    return files
