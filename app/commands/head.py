"""``sheer head``: operations on head meshes.

    sheer head simplify --faces N [--head PATH] [--face FACE_DIR] [--size WxH] --out DIR

Makes a coarse head with pyvista's quadric decimation (Paris et al. 2003, Fig. 13): DIR/head.obj and its
metadata sidecar (same scale, landmarks and textures). With ``--face`` (a folder from ``sheer capture``)
the detail texture is re-baked onto the coarse head into DIR/face/, both heads are rendered with the
lightweight engine under the same camera and light, and the command prints one JSON object with the
image difference (mean and 95th-percentile ΔE2000 over the head's pixels) and the median frame times
of coarse against fine; DIR/compare.png shows fine | coarse | difference (ΔE2000 × 10).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import argparse

    from app.commands import Subcommands


def register(sub: Subcommands) -> None:
    """Add ``sheer head`` and its sub-commands to the sub-command parsers ``sub``."""
    from app.commands import command_group

    hsub = command_group(sub, "head", "head mesh operations (simplify)", __doc__)
    s = hsub.add_parser("simplify", help="a coarse head by quadric decimation, detail texture re-baked")
    s.add_argument("--faces", type=int, required=True, metavar="N", help="target triangle count")
    s.add_argument("--head", metavar="PATH", help="head mesh; default: the sample head")
    s.add_argument("--face", metavar="FACE_DIR", help="a captured face to re-bake and compare")
    s.add_argument("--size", default="1280x720", metavar="WxH", help="comparison render size")
    s.add_argument("--frames", type=int, default=5, metavar="N", help="frames timed per head")
    s.add_argument("--out", required=True, metavar="DIR", help="output folder")
    s.set_defaults(func=run_simplify)


def run_simplify(args: argparse.Namespace) -> int:
    """Run ``sheer head simplify``: write the coarse head (and with ``--face`` the comparison); returns 0."""
    import json
    import sys
    from pathlib import Path

    from capture.lod import rebake_detail, simplify_head, write_obj
    from core.atomicio import atomic_write_text
    from core.errors import SheerError
    from painting.head import SIDECAR_SUFFIX, load_head

    try:
        w, h = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        raise SheerError(f"--size must look like 1280x720, got {args.size!r}") from None
    if not (16 <= w <= 8192 and 16 <= h <= 8192) or args.frames < 1:
        raise SheerError("--size must be between 16x16 and 8192x8192 and --frames at least 1")
    face = None
    if args.face:
        from capture.face import load_face

        face = load_face(args.face)
    fine = load_head(args.head)
    coarse = simplify_head(fine, args.faces)
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SheerError(f"{out}: cannot create the output folder: {exc.strerror}") from None
    mesh_path = out / "head.obj"
    write_obj(coarse, mesh_path)
    meta = fine.metadata.to_json()
    from painting import head as head_module

    sidecar = head_module.find_sidecar(fine.path)
    for key in ("albedo", "normal_map", "specular_map", "roughness_map", "skin_mask"):
        if meta.get(key):
            meta[key] = str(head_module.resolve_texture_path(meta[key], fine.path, sidecar).resolve())
    meta["name"] = f"{fine.name} ({len(coarse.faces)} triangles)"
    atomic_write_text(mesh_path.with_name(mesh_path.name + SIDECAR_SUFFIX), json.dumps(meta, indent=2))
    print(f"head: {len(fine.faces)} → {len(coarse.faces)} triangles, wrote {mesh_path}", file=sys.stderr)
    report: dict[str, object] = {"fine_triangles": len(fine.faces), "coarse_triangles": len(coarse.faces),
                                 "coarse_vertices": len(coarse.vertices), "mesh": str(mesh_path)}
    if face is not None:
        import shutil

        import numpy as np
        import OpenEXR

        from capture.face import recorded_path

        detail = rebake_detail(fine, coarse, face.detail)
        face_dir = out / "face"
        face_dir.mkdir(exist_ok=True)
        hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        OpenEXR.File(hdr, {"RGB": np.ascontiguousarray(detail, dtype=np.float32)}).write(str(face_dir / "detail.exr"))
        data = dict(face.data)
        data["head"] = recorded_path(mesh_path, face_dir)  # relative to face_dir: the folders move together
        data["rebaked_from"] = str(Path(args.face).resolve())
        atomic_write_text(face_dir / "face.json", json.dumps(data, indent=2))
        for extra in ("report.png", "skin_mask.png"):
            if (Path(args.face) / extra).is_file():
                shutil.copy2(Path(args.face) / extra, face_dir / extra)
        print(f"detail texture re-baked into {face_dir}", file=sys.stderr)
        report.update(_compare(fine, coarse, face, detail, (w, h), args.frames, out))
    print(json.dumps(report, indent=2))
    return 0


def _compare(fine: object, coarse: object, face: object, coarse_detail: object, size: tuple[int, int], frames: int,
             out: object) -> dict[str, object]:
    import dataclasses
    import statistics
    import time
    from pathlib import Path

    import numpy as np
    from PIL import Image

    from capture.phong import delta_e2000
    from core.errors import SheerError
    from km.srgb import srgb_decode
    from render.context import standalone_context
    from render.lights import Light
    from render.lightweight import LightweightRenderer

    try:
        ctx = standalone_context()
    except Exception as exc:
        raise SheerError(f"cannot create an OpenGL 4.5 context (EGL): {exc}") from None
    images, times = [], []
    try:
        for head, detail in ((fine, face.detail), (coarse, coarse_detail)):  # type: ignore[attr-defined]
            lw = LightweightRenderer(ctx, head, dataclasses.replace(face, detail=detail))  # type: ignore[type-var]
            try:
                from render.camera import OrbitCamera

                lw.camera = OrbitCamera.for_face(fine.vertices, fine.metadata.landmarks)  # type: ignore[attr-defined]
                lw.lights = [Light.directional(35, 20, 1.0), Light.directional(-50, 5, 0.35)]
                images.append(lw.render_image(size))
                ts = []
                for _ in range(frames):
                    t = time.perf_counter()
                    lw.render_image(size)
                    ts.append((time.perf_counter() - t) * 1000.0)
                times.append(statistics.median(ts))
            finally:
                lw.release()
    finally:
        ctx.release()
    a, b = (srgb_decode(im / 255.0) for im in images)
    mask = (np.abs(images[0].astype(int) - images[0][0, 0].astype(int)).sum(axis=2) > 6)
    de = delta_e2000(a[mask], b[mask])
    vis = np.zeros(images[0].shape[:2])
    vis[mask] = de
    diff = np.repeat(np.clip(vis * 10, 0, 255).astype(np.uint8)[..., None], 3, axis=2)
    Image.fromarray(np.concatenate([images[0], images[1], diff], axis=1)).save(Path(str(out)) / "compare.png")
    return {"mean_de2000_head": float(de.mean()), "p95_de2000_head": float(np.percentile(de, 95)),
            "fine_frame_ms": times[0], "coarse_frame_ms": times[1], "coarse_over_fine": times[1] / times[0],
            "size": list(size), "note": "frame times include reading the image back"}
