"""The person's own head from one photograph: the face mesh's 468 landmarks as a metric head.

MediaPipe's 468 face-mesh points are the vertices of the canonical face topology (MediaPipe's
``canonical_face_model.obj``, Apache-2.0: 468 vertices in landmark order, 898 triangles, UVs), so the
detected points *are* a mesh with that topology's triangles and UV atlas. :func:`person_head` makes it
a head like any other (:class:`painting.head.Head`):

- **frame**: the canonical model's — +X the subject's left, +Y up, +Z out of the face — the detected
  points (:class:`capture.landmarks.FaceLandmarks`, z MediaPipe's relative depth in the same pixel
  scale) un-projected through the photograph's focal length when it is known (its EXIF or ``--focal-mm``,
  :mod:`capture.exif`), else a portrait lens (:data:`PORTRAIT_FOCAL`), and rotated onto the canonical
  model by the least-squares rotation
  (``scipy.spatial.transform.Rotation.align_vectors``, the Kabsch solution), which also gives the head's
  pose in the photograph (:func:`head_pose`);
- **units**: centimetres, like the canonical model (10 mm per unit), scaled from the iris: its
  visible diameter is about 11.7 mm in adults (a narrow spread, ±0.5 mm). With closed eyes (no iris) or an
  iris measurement that puts the pupils outside 50–75 mm apart, the distance between the eyes' centres
  is taken as the mean adult inter-pupillary distance, 63 mm (Dodgson 2004), instead; the sidecar's
  ``scale_note`` says which;
- **landmarks**: the sidecar's names (:data:`capture.landmarks.STANDARD_LANDMARKS`), each the mean of its
  vertices projected onto the surface (as in ``resources/heads/canonical-face.json``);
- **regions**: the canonical topology's (``resources/heads/canonical-face.regions.png``, built from the
  face-mesh contours by ``scripts/build_canonical_face.py``) copied beside the sidecar: the face-mesh
  contours follow the mesh's edges, so each region covers the same triangles of the UV atlas on every
  face.

:func:`write_person_head` writes ``head.obj`` (vertex i = landmark i, one UV per vertex), its sidecar
``head.obj.sheer-head.json``, ``albedo.png`` and the regions into a face folder; ``painting.head.load_head``
then loads it.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial.transform import Rotation

from capture.landmarks import N_MESH, STANDARD_LANDMARKS, FaceLandmarks

if TYPE_CHECKING:
    from pathlib import Path

    from painting.head import Head, HeadMetadata

#: The canonical face model (asset), whose topology and UVs a person's head takes.
CANONICAL_FACE = "heads/canonical-face/canonical_face_model.obj"
#: Mean visible iris diameter of adults (mm); the person's head is scaled from it.
IRIS_DIAMETER_MM = 11.7
#: Mean adult inter-pupillary distance (mm, Dodgson 2004): the scale when the irises cannot be used.
IPD_MM = 63.0
#: Inter-pupillary distances (mm) the iris scale may imply before it is distrusted.
IPD_PLAUSIBLE_MM = (50.0, 75.0)
#: The person's head's mesh units: centimetres, like the canonical model.
MM_PER_UNIT = 10.0
#: File names in the face folder.
HEAD_FILE = "head.obj"
ALBEDO_FILE = "albedo.png"
#: The canonical topology's regions, shipped in resources/heads/.
CANONICAL_REGIONS = "canonical-face.regions.png"
CREDIT = ("Captured face on the canonical face topology from the MediaPipe project (Apache-2.0); "
          "landmarks by MediaPipe FaceMesh")


@dataclass(frozen=True)
class Topology:
    """The canonical face topology: vertices (468, 3) cm, faces int64 (898, 3), uv (468, 2) (head convention)."""

    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray


_topology: Topology | None = None


def canonical_topology() -> Topology:
    """The canonical face model's arrays (loaded once per process, through the head mesh cache)."""
    global _topology
    if _topology is None:
        from core.assets import find_asset
        from painting.head import load_mesh_arrays

        v, f, uv, _ = load_mesh_arrays(find_asset(CANONICAL_FACE))
        if len(v) != N_MESH:
            from capture.errors import CaptureError

            raise CaptureError(f"{CANONICAL_FACE}: expected {N_MESH} vertices, got {len(v)}")
        _topology = Topology(vertices=v, faces=f, uv=uv)
    return _topology


#: The focal length assumed for a photograph whose focal length is not known (× its longer side: a
#: portrait lens, 61–72 mm in 35 mm terms for a square to a 3:2 frame), the prior of
#: :func:`capture.camera.calibrate` too. One photograph of a face cannot tell it from the distance; the
#: detected points are un-projected with it, so the camera fitted to the mesh lands on it instead of
#: running off towards an orthographic view. A known one (the photograph's EXIF, ``--focal-mm``:
#: :func:`capture.auto.capture_auto`'s ``focal_mm``) replaces it.
PORTRAIT_FOCAL = 2.0


def focal_or_prior(face: FaceLandmarks, focal_px: float | None) -> float:
    """``focal_px`` (pixels of ``face``'s photograph) when known, else :data:`PORTRAIT_FOCAL` × its longer side."""
    return PORTRAIT_FOCAL * max(face.width, face.height) if focal_px is None else float(focal_px)


def _detected_frame(face: FaceLandmarks, focal_px: float | None = None) -> np.ndarray:
    """The 468 mesh points un-projected, in a right-handed y-up frame: float64 (468, 3), pixels at the face.

    Camera coordinates with the face at a distance of f (``focal_px``, else :data:`PORTRAIT_FOCAL` × the
    longer side; one unit is then one pixel at the face whatever the true distance, so the perspective
    is undone exactly when f is the lens's): depth Z = f + z (MediaPipe's relative depth), X = (x − cx)·Z/f,
    Y = (y − cy)·Z/f; returned as (X, −Y, −Z) (y up, z towards the camera).
    """
    p = face.points[:N_MESH]
    f = focal_or_prior(face, focal_px)
    z = f + p[:, 2]
    x = (p[:, 0] - face.width / 2.0) * z / f
    y = (p[:, 1] - face.height / 2.0) * z / f
    return np.stack([x, -y, -z], axis=1)


@dataclass(frozen=True)
class Pose:
    """The head's pose in the photograph, from the detected mesh against the canonical model.

    Attributes:
        rotation: (3, 3) the rotation taking the detected frame (x, −y, −z) onto the canonical frame.
        yaw_deg: turn left/right (about the vertical); pitch_deg: nod up/down; roll_deg: tilt in the
            image plane. Degrees; 0 = facing the camera upright.
        px_per_cm: the detected mesh's size against the canonical model's (pixels per canonical cm).
    """

    rotation: np.ndarray
    yaw_deg: float
    pitch_deg: float
    roll_deg: float
    px_per_cm: float


def head_pose(face: FaceLandmarks, focal_px: float | None = None) -> Pose:
    """The head's pose (:class:`Pose`) from the least-squares rotation of the detected mesh onto the canonical one.

    ``focal_px``: the photograph's focal length (pixels) when known, else the portrait-lens prior.
    """
    can = canonical_topology().vertices
    det = _detected_frame(face, focal_px)
    a = can - can.mean(axis=0)
    b = det - det.mean(axis=0)
    rot, _ = Rotation.align_vectors(a, b)  # b rotated ≈ a
    scale = float(np.sqrt((b ** 2).sum() / (a ** 2).sum()))
    # The head's rotation relative to the camera is the inverse; Euler Y (yaw), X (pitch), Z (roll).
    yaw, pitch, roll = rot.inv().as_euler("YXZ", degrees=True)
    return Pose(rotation=rot.as_matrix(), yaw_deg=float(yaw), pitch_deg=float(pitch), roll_deg=float(roll),
                px_per_cm=scale)


@dataclass(frozen=True)
class Scale:
    """The person's metric scale: millimetres per photograph pixel at the face, and how it was found."""

    mm_per_px: float
    source: str
    ipd_mm: float
    iris_px: float


def eye_centres(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The left and right eye centres of 468+ points (any dimension): the standard ``left_eye``/``right_eye``."""
    return (points[list(STANDARD_LANDMARKS["left_eye"])].mean(axis=0),
            points[list(STANDARD_LANDMARKS["right_eye"])].mean(axis=0))


def metric_scale(face: FaceLandmarks, eyes_open: bool, focal_px: float | None = None) -> Scale:
    """The millimetres per pixel at the face, and how they were found.

    From the iris diameter (:data:`IRIS_DIAMETER_MM`) when ``eyes_open`` and the inter-pupillary distance
    it implies is within :data:`IPD_PLAUSIBLE_MM`, else from the eyes' centres taken :data:`IPD_MM` apart
    (3D distance in the detected frame, so a turned head is not foreshortened; ``focal_px`` as in
    :func:`head_pose`).
    """
    det = _detected_frame(face, focal_px)
    le, re = eye_centres(det)
    eyes_px = float(np.linalg.norm(le - re))
    iris = face.iris_diameter_px()
    if eyes_open and iris > 0:
        mm_px = IRIS_DIAMETER_MM / iris
        ipd = eyes_px * mm_px
        if IPD_PLAUSIBLE_MM[0] <= ipd <= IPD_PLAUSIBLE_MM[1]:
            return Scale(mm_px, f"iris diameter {iris:.2f} px = {IRIS_DIAMETER_MM} mm (the eyes' centres then "
                                f"{ipd:.1f} mm apart)", ipd, iris)
        why = f"the iris ({iris:.2f} px = {IRIS_DIAMETER_MM} mm) would put the eyes {ipd:.1f} mm apart"
    else:
        why = "eyes closed (no iris)"
    return Scale(IPD_MM / eyes_px, f"{why}: the eyes' centres, {eyes_px:.1f} px apart, taken as {IPD_MM} mm "
                                   f"(mean adult inter-pupillary distance)", IPD_MM, iris)


def surface_points(vertices: np.ndarray, faces: np.ndarray) -> dict[str, tuple[float, float, float]]:
    """The standard landmarks on a face-mesh head: each the mean of its vertices, projected onto the surface.

    ``vertices`` (468+, 3) in mesh units, ``faces`` the canonical triangles. Rounded to 1e-4 units.
    """
    import trimesh

    mesh = trimesh.Trimesh(vertices[:N_MESH], faces, process=False)
    names = list(STANDARD_LANDMARKS)
    means = np.stack([vertices[list(STANDARD_LANDMARKS[n])].mean(axis=0) for n in names])
    on, _, _ = trimesh.proximity.closest_point(mesh, means)
    single = np.array([len(STANDARD_LANDMARKS[n]) == 1 for n in names])
    on[single] = means[single]  # a vertex is on the surface already (closest_point may move it by 1e-7)
    return {n: (round(float(p[0]), 4), round(float(p[1]), 4), round(float(p[2]), 4)) for n, p in zip(names, on)}


def midplane(vertices: np.ndarray) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """The face's mirror plane: (point, unit normal towards the subject's left), mesh units.

    From the canonical model's midline vertices (|x| < 1e-6 there) and its mirror pairs.
    """
    from scipy.spatial import cKDTree

    can = canonical_topology().vertices
    mid = np.abs(can[:, 0]) < 1e-6
    pair = cKDTree(can).query(can * np.array([-1.0, 1.0, 1.0]))[1]
    left = can[:, 0] > 1e-6
    n = (vertices[left] - vertices[pair[left]]).sum(axis=0)
    n /= np.linalg.norm(n)
    p = vertices[mid].mean(axis=0)
    return (tuple(float(round(x, 4)) for x in p), tuple(float(round(x, 6)) for x in n))  # type: ignore[return-value]


def person_head(face: FaceLandmarks, folder: Path, eyes_open: bool, name: str = "Captured face",
                focal_px: float | None = None) -> Head:
    """The person's head (in memory; ``path`` = ``folder / HEAD_FILE``, written by :func:`write_person_head`).

    Args:
        face: the detected face.
        folder: the face folder the head will live in.
        eyes_open: whether the irises can set the scale (see :func:`metric_scale`).
        name: the head's display name.
        focal_px: the photograph's focal length (pixels; its EXIF or the user's) the detection is
            un-projected through, else :data:`PORTRAIT_FOCAL` × the longer side.
    """
    import trimesh

    from painting.head import Head, HeadMetadata

    topo = canonical_topology()
    pose = head_pose(face, focal_px)
    scale = metric_scale(face, eyes_open, focal_px)
    det = _detected_frame(face, focal_px)
    lens = (f"a portrait lens assumed ({focal_or_prior(face, None):.0f} px)" if focal_px is None
            else f"the photograph's focal length ({focal_px:.0f} px)")
    centred = (det - det.mean(axis=0)) @ pose.rotation.T  # rotated onto the canonical frame, pixels
    cm_per_px = scale.mm_per_px / MM_PER_UNIT
    vertices = centred * cm_per_px + topo.vertices.mean(axis=0)
    normals = np.asarray(trimesh.Trimesh(vertices, topo.faces, process=False).vertex_normals, dtype=np.float64)
    point, normal = midplane(vertices)
    meta = HeadMetadata(
        name=name, mm_per_unit=MM_PER_UNIT,
        scale_note=(f"Mesh units are centimetres (the canonical face model's). Scale from the photograph: "
                    f"{scale.source}; {scale.mm_per_px:.4f} mm per pixel at the face. Vertex i is MediaPipe "
                    f"face-mesh landmark i (the detection un-projected through {lens}, rotated onto the "
                    f"canonical model by least squares: the head was turned {pose.yaw_deg:+.1f} deg, nodded {pose.pitch_deg:+.1f} "
                    f"deg, tilted {pose.roll_deg:+.1f} deg). Landmarks as in canonical-face.json "
                    f"(capture.landmarks.STANDARD_LANDMARKS). Subject's left = +X."),
        landmarks=surface_points(vertices, topo.faces), midplane_point=point, midplane_normal=normal,
        albedo=ALBEDO_FILE, credit=CREDIT, calibrated=True)
    return Head(path=folder / HEAD_FILE, vertices=vertices, faces=topo.faces.copy(), uv=topo.uv.copy(),
                normals=normals, metadata=meta)


def obj_text(head: Head) -> str:
    """The head as Wavefront OBJ text: one ``vt`` per vertex (same index), so vertex i stays landmark i."""
    lines = ["# Sheer captured face: MediaPipe canonical face topology (Apache-2.0), vertices from the photograph",
             f"# mesh units: centimetres ({head.mm_per_unit:g} mm per unit); see {HEAD_FILE}.sheer-head.json"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in head.vertices]
    lines += [f"vt {u:.6f} {v:.6f}" for u, v in head.uv]
    lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in head.faces]
    return "\n".join(lines) + "\n"


def compact_json(data: object) -> str:
    """JSON text indented by 2, each list of numbers on one line (the style of ``resources/heads/*.json``)."""
    import re

    text = json.dumps(data, indent=2)
    return re.sub(r"\[\s+([-0-9.eE+,\s]*?)\s+\]", lambda m: "[" + ", ".join(x.strip() for x in m.group(1).split(",")) + "]",
                  text) + "\n"


def sidecar_json(meta: HeadMetadata) -> str:
    """The sidecar's JSON text for ``meta``."""
    return compact_json(meta.to_json())


def write_person_head(head: Head, folder: Path, albedo_srgb8: np.ndarray) -> list[Path]:
    """Write the person's head into ``folder``: mesh, sidecar, albedo and the canonical regions.

    ``albedo_srgb8``: uint8 (S, S, 3) sRGB in the head's UV space (top row first). Returns the files.
    """
    from PIL import Image

    from capture.face import PNG_SAVE
    from core.assets import resource_path
    from painting.head import SIDECAR_SUFFIX
    from painting.regions import regions_file

    mesh = folder / HEAD_FILE
    sidecar = folder / (HEAD_FILE + SIDECAR_SUFFIX)
    regions = regions_file(sidecar)
    mesh.write_text(obj_text(head), encoding="utf-8")
    sidecar.write_text(sidecar_json(head.metadata), encoding="utf-8")
    Image.fromarray(np.asarray(albedo_srgb8, dtype=np.uint8)).save(folder / ALBEDO_FILE, **PNG_SAVE)
    shutil.copyfile(resource_path("heads", CANONICAL_REGIONS), regions)
    return [mesh, sidecar, folder / ALBEDO_FILE, regions]
