"""``sheer bench capture``'s automatic-capture figures (issue #15): landmarks and photo → face folder.

- ``landmarks_ms`` (target ≤ 300): :func:`capture.landmarks.detect_faces` on the two shared portraits and
  a render of the sample head, the detector already loaded (a kiosk's steady state), median / p90 / max
  over the runs; ``landmarks_first_ms``: the first call in the process (MediaPipe's import and model load).
- ``capture_auto_s`` (target ≤ 10): :func:`capture.auto.capture_auto` from Grace Hopper's portrait file to
  a written face folder (the person's own head, the default 512² detail texture, progress lines asked for
  as the kiosk asks for them), median / p90 / max;
  ``capture_auto_first_s``: the first one in the process (the imports of trimesh, OpenEXR… included);
  ``capture_auto_cpu_s``: the process's CPU seconds per capture (median; on a loaded machine the wall
  time grows with the load average, this does not).
- ``focal_*`` (issue 14, :func:`focal_sweep`): what the photograph's EXIF focal length changes in the
  automatic capture. The sample head drawn on the GPU (:func:`bench.capture_truth.render_photo`: per-pixel
  normals, its albedo, the flash 4° above the lens with its cast shadows) through lenses of
  :data:`FOCAL_LENSES_MM` (35 mm equivalent), each from the distance that frames
  :data:`FRAME_HEIGHT_MM` of the face in the photograph's height (so the face has the same size in every
  photograph and only the perspective differs: a 26 mm phone lens at 34 cm, 135 mm at 1.8 m), the head
  turned by :data:`FOCAL_YAWS`; each photograph written twice as a PNG file — with EXIF
  FocalLengthIn35mmFilm (whole mm, as a camera writes it) and without — and captured from the file
  (:func:`capture.auto.capture_auto`, the person's own head). Per case (``focal_cases``) and per lens and
  EXIF/prior (``focal_by_lens``), medians over the yaws of: ``focal_ratio`` (the capture's focal length /
  the true one); ``distance_error_pct`` (the camera's distance to the eyes' midpoint, through the
  similarity that best maps the person's head's standard landmarks onto the sample head's, against the
  true distance: the camera's geometry without the metric scale); ``metric_distance_error_pct`` (the same
  distance in the person's head's own millimetres: with the scale from the eyes, here the mean 63 mm
  inter-pupillary distance since the sample head's eyes are closed); ``rotation_error_deg`` (the
  camera's rotation in the sample head's frame through that similarity, against the true one);
  ``shape_rms_mm`` (the landmarks' RMS after the similarity, mm: the head's shape, perspective left in it
  included), ``reproduction_de2000`` (the capture's own mean ΔE2000 on skin), ``specular_error_pct`` and
  ``exponent_error_pct`` (the captured i_s and s against the drawn :data:`FOCAL_SPECULAR` and
  :data:`FOCAL_EXPONENT`; the sweep gives no probe, so the capture assumes a white flash on the lens's
  axis where it is 4° above it). The summary fields ``focal_distance_error_pct_exif`` / ``_prior`` and
  the same for the rotation, the shape, the specular intensity and the exponent are the medians of the
  absolute values over every case.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np


def _render_sample() -> np.ndarray:
    """The sample head from the front (the capture's CPU rasteriser, albedo × Lambert), uint8 512²."""
    from capture.camera import Camera
    from capture.pipeline import linear_to_srgb8, pixel_data, sample_texture
    from km.srgb import srgb_decode
    from painting.head import load_head

    head = load_head()
    cam = Camera.looking_at(np.array([-0.1, 1.1, 22.0]), np.array([-0.1, 1.1, 2.0]),
                            np.array([0.0, 1.0, 0.0]), 15.0, 512, 512)
    pix = pixel_data(head, cam)
    albedo = srgb_decode(np.asarray(head.albedo, dtype=np.float64) / 255.0)
    lam = np.clip(np.einsum("pc,pc->p", pix.normals, pix.view), 0.0, 1.0)
    img = np.full((512, 512, 3), 0.18)
    img[pix.rows, pix.cols] = sample_texture(albedo, pix.uv) * (0.25 + 0.9 * lam[:, None])
    return linear_to_srgb8(img)


def measure(quick: bool = False) -> dict[str, Any]:
    """The automatic capture's timings (see the module docstring); ``quick``: fewer runs."""
    from PIL import Image

    from bench.stats import spread
    from capture.auto import capture_auto
    from capture.landmarks import detect_faces
    from core.assets import find_asset

    photos = [np.asarray(Image.open(find_asset(p)).convert("RGB"))
              for p in ("photos/grace_hopper.jpg", "photos/astronaut.png")] + [_render_sample()]
    t = time.perf_counter()
    detect_faces(photos[0])
    first_ms = 1000.0 * (time.perf_counter() - t)
    runs = 3 if quick else 10
    times = []
    for _ in range(runs):
        for img in photos:
            t = time.perf_counter()
            faces = detect_faces(img)
            times.append(1000.0 * (time.perf_counter() - t))
            assert faces, "a benchmark photo lost its face"
    captures, cpu = [], []
    with tempfile.TemporaryDirectory(prefix="sheer-bench-auto-") as tmp:
        for i in range(2 if quick else 5):
            t, c = time.perf_counter(), time.process_time()
            # with progress lines, as the kiosk and the studio capture (the capture then also builds what
            # its lines say, the paper's reflectance map: capture.pipeline.CaptureResult)
            capture_auto(find_asset("photos/grace_hopper.jpg"), Path(tmp) / f"face{i}", progress=_quiet)
            captures.append(time.perf_counter() - t)
            cpu.append(time.process_time() - c)
    return {"landmarks_first_ms": round(first_ms, 1), **spread("landmarks_ms", times, 1),
            "landmarks_runs": len(times), "capture_auto_first_s": round(captures[0], 2),
            **spread("capture_auto_s", captures[1:] or captures, 2), "capture_auto_runs": len(captures),
            "capture_auto_cpu_s": round(float(np.median(cpu[1:] or cpu)), 2), **focal_sweep(quick)}


def _quiet(line: str) -> None:
    """A capture's progress lines, not printed (the benchmark prints one JSON object)."""


#: The focal sweep's lenses (35 mm-equivalent mm): a phone's main camera, a wide normal, the automatic
#: capture's own assumption for a square photograph (2 × its side = 61.2 mm), a portrait lens and a long one.
FOCAL_LENSES_MM = (26.0, 35.0, 61.2, 135.0)
#: The head's turns in the focal sweep (degrees about its vertical; the quality gate refuses beyond 20°).
FOCAL_YAWS = (-12.0, 0.0, 12.0)
#: The height of the face's plane the photograph frames (mm): the sample head's face (brow to chin about
#: 19 cm) fills about half the height, above the gate's 30 % and under the capture's 280 px at 512².
FRAME_HEIGHT_MM = 400.0
#: The focal sweep's photographs (pixels, square).
FOCAL_PHOTO_PX = 512
#: The sweep's drawn specular intensity i_s (photograph units) and Phong exponent s: the out-of-sample
#: bench's i_s and its middle exponent (bench/capture.py).
FOCAL_SPECULAR = 0.18
FOCAL_EXPONENT = 24.0


def focal_camera(head: Any, focal_mm: float, yaw_deg: float) -> Any:
    """The sweep's true camera: ``focal_mm`` (35 mm equivalent) framing :data:`FRAME_HEIGHT_MM` at the face."""
    from capture.camera import Camera
    from capture.exif import focal_px_from_35mm

    size = FOCAL_PHOTO_PX
    f_px = focal_px_from_35mm(focal_mm, size, size)
    distance = f_px * FRAME_HEIGHT_MM / size / head.mm_per_unit
    target = np.array([0.0, 1.3, 0.0])  # the sample head's face (bench.capture_truth.case_camera's aim)
    yaw = np.radians(yaw_deg)
    fov = float(np.degrees(2 * np.arctan(size / 2 / f_px)))
    return Camera.looking_at(target + distance * np.array([np.sin(yaw), 0.0, np.cos(yaw)]), target,
                             np.array([0.0, 1.0, 0.0]), fov, size, size)


def _eyes(landmarks: dict[str, Any]) -> np.ndarray:
    return (np.asarray(landmarks["left_eye"], dtype=np.float64) + np.asarray(landmarks["right_eye"])) / 2


def compare_camera(truth_head: Any, true_cam: Any, face: Any) -> tuple[dict[str, float], np.ndarray]:
    """The captured face's camera and head against the truth (see the module docstring's ``focal_*``).

    Returns the figures and the camera's rotation in the truth's frame (3, 3), through the similarity.
    """
    from scipy.spatial.transform import Rotation

    head = face.load_head()
    cam = face.camera()
    names = sorted((set(truth_head.metadata.landmarks) & set(head.metadata.landmarks)) - {"gnathion"})
    src = np.array([head.metadata.landmarks[n] for n in names], dtype=np.float64)
    dst = np.array([truth_head.metadata.landmarks[n] for n in names], dtype=np.float64)
    # Umeyama's similarity (scipy's align_vectors gives the rotation of the centred sets; the scale is
    # the ratio of their spreads along it): dst ≈ k·Q·src + t
    sc, dc = src - src.mean(axis=0), dst - dst.mean(axis=0)
    rot, _ = Rotation.align_vectors(dc, sc)
    q = rot.as_matrix()
    k = float(np.sum(dc * (sc @ q.T)) / np.sum(sc ** 2))
    t = dst.mean(axis=0) - k * q @ src.mean(axis=0)
    shape = float(np.sqrt(np.mean(np.sum((k * sc @ q.T - dc) ** 2, axis=1)))) * truth_head.mm_per_unit
    true_d = float(np.linalg.norm(true_cam.centre - _eyes(truth_head.metadata.landmarks)))
    centre = k * q @ cam.centre + t
    d = float(np.linalg.norm(centre - _eyes(truth_head.metadata.landmarks)))
    metric = float(np.linalg.norm(cam.centre - _eyes(head.metadata.landmarks))) * head.mm_per_unit
    in_truth = cam.R @ q.T
    turn = Rotation.from_matrix(in_truth @ true_cam.R.T).magnitude()
    return {"focal_ratio": float(cam.K[0, 0] / true_cam.K[0, 0]), "distance_error_pct": 100 * (d / true_d - 1),
            "metric_distance_error_pct": 100 * (metric / (true_d * truth_head.mm_per_unit) - 1),
            "rotation_error_deg": float(np.degrees(turn)), "shape_rms_mm": shape,
            "reproduction_de2000": float(face.data["residual"]["reproduction_mean_de2000_skin"]),
            "specular_error_pct": 100 * (face.params.specular / FOCAL_SPECULAR - 1),
            "exponent_error_pct": 100 * (face.params.exponent / FOCAL_EXPONENT - 1)}, in_truth


def focal_photo(ctx: Any, head: Any, texture: np.ndarray, camera: Any) -> np.ndarray:
    """The sample head through ``camera`` drawn on the GPU (uint8 sRGB): flash 4° above the lens, shadows."""
    from bench.capture_synthetic import DIM_ROOM, FLASH_RGB, light_from_camera
    from bench.capture_truth import SKIN, render_photo

    light = light_from_camera(camera, 4.0, 0.0)
    return render_photo(ctx, head, texture, camera, np.asarray(SKIN), specular=FOCAL_SPECULAR,
                        exponent=FOCAL_EXPONENT, light=light,
                        flash=FLASH_RGB, ambient=np.full(3, DIM_ROOM), shadows=True).srgb8


def focal_sweep(quick: bool = False) -> dict[str, Any]:
    """The ``focal_*`` fields (see the module docstring); ``quick``: the two ends' lenses, the head frontal."""
    from PIL import Image
    from scipy.spatial.transform import Rotation

    from bench.capture_truth import case_head
    from capture.auto import capture_auto
    from capture.face import load_face
    from render.context import standalone_context

    lenses = (FOCAL_LENSES_MM[0], FOCAL_LENSES_MM[-1]) if quick else FOCAL_LENSES_MM
    yaws = (0.0,) if quick else FOCAL_YAWS
    head, texture = case_head("sample")
    rows: list[dict[str, Any]] = []
    rotations: dict[tuple[float, float, str], np.ndarray] = {}
    cameras: dict[tuple[float, float], Any] = {}
    ctx = standalone_context()
    try:
        with tempfile.TemporaryDirectory(prefix="sheer-bench-focal-") as tmp:
            for lens in lenses:
                for yaw in yaws:
                    camera = focal_camera(head, lens, yaw)
                    srgb8 = focal_photo(ctx, head, texture, camera)
                    exif = Image.Exif()
                    exif.get_ifd(0x8769)[0xA405] = round(lens)  # FocalLengthIn35mmFilm, whole mm
                    for source in ("exif", "prior"):
                        path = Path(tmp) / f"{lens:g}_{yaw:g}_{source}.png"
                        Image.fromarray(srgb8).save(path, exif=exif.tobytes() if source == "exif" else b"")
                        capture_auto(path, Path(tmp) / f"face_{lens:g}_{yaw:g}_{source}", allow_closed_eyes=True)
                        face = load_face(Path(tmp) / f"face_{lens:g}_{yaw:g}_{source}")
                        assert face.data["focal"]["source"] == source, face.data["focal"]
                        figures, rotations[(lens, yaw, source)] = compare_camera(head, camera, face)
                        cameras[(lens, yaw)] = camera
                        rows.append({"lens_mm": lens, "yaw_deg": yaw, "focal": source,
                                     **{k: round(v, 3) for k, v in figures.items()}})
    finally:
        ctx.release()
    for r in rows:  # the turn from the frontal capture against the true turn (the frames' bias cancels)
        lens, yaw, src = r["lens_mm"], r["yaw_deg"], r["focal"]
        if yaw != 0.0 and (lens, 0.0, src) in rotations:
            est = rotations[(lens, yaw, src)] @ rotations[(lens, 0.0, src)].T
            true = cameras[(lens, yaw)].R @ cameras[(lens, 0.0)].R.T
            r["turn_error_deg"] = round(float(np.degrees(Rotation.from_matrix(est @ true.T).magnitude())), 3)
    keys = ("focal_ratio", "distance_error_pct", "metric_distance_error_pct", "rotation_error_deg", "turn_error_deg",
            "shape_rms_mm", "reproduction_de2000", "specular_error_pct", "exponent_error_pct")

    def median(lens: float, src: str, key: str) -> float | None:
        vals = [r[key] for r in rows if r["lens_mm"] == lens and r["focal"] == src and key in r]
        return round(float(np.median(vals)), 3) if vals else None

    by_lens = {f"{lens:g}": {src: {k: median(lens, src, k) for k in keys} for src in ("exif", "prior")}
               for lens in lenses}
    out: dict[str, Any] = {"focal_lenses_mm": list(lenses), "focal_yaws_deg": list(yaws)}
    for src in ("exif", "prior"):
        for k in ("distance_error_pct", "rotation_error_deg", "turn_error_deg", "shape_rms_mm", "specular_error_pct",
                  "exponent_error_pct"):
            vals = [abs(r[k]) for r in rows if r["focal"] == src and k in r]
            if vals:
                out[f"focal_{k}_{src}"] = round(float(np.median(vals)), 3)
    return {**out, "focal_by_lens": by_lens, "focal_cases": rows}
