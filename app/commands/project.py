"""``sheer project new|info|validate|export``: create, inspect, check and unpack ``.sheer`` files.

- ``new --out FILE [--head PATH] [--look NAME] [--name TEXT] [--self-contained]``: an empty project.
- ``info FILE [--json]``: what the project holds (does not need the head).
- ``validate FILE``: every check of ``docs/FORMAT.md``; exit 0 when valid, 2 with a one-line reason.
- ``export FILE --out DIR [--ora]``: each layer's map as EXR float32 (exact) and 16-bit PNG, the
  materials, and ``manifest.json``; ``--ora`` adds ``layers.ora`` (OpenRaster, for GIMP and Krita);
  ``--gltf OUT.glb`` writes the made-up head as glTF/GLB (the makeup baked into the albedo).
- ``upgrade FILE``: rewrite a project from an older Sheer in the current format (the original is
  kept as ``FILE.v<N>.bak``); refused (exit 2) while a studio has the project open.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from app.commands import Subcommands


def register(sub: Subcommands) -> None:
    """Add ``sheer project`` and its actions to the sub-command parsers ``sub``."""
    p = sub.add_parser("project", help="create, inspect, validate and export .sheer projects", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    cmds = p.add_subparsers(dest="project_command", metavar="ACTION", required=True)

    new = cmds.add_parser("new", help="create an empty project")
    new.add_argument("--out", required=True, help="the .sheer file to write")
    new.add_argument("--head", default=None, help="head mesh (default: the sample head)")
    new.add_argument("--look", default=None,
                     help="paint this look (a built-in name such as natural, or a look .json file) on the head")
    new.add_argument("--resolution", type=int, default=1024,
                     help="layer resolution, texels per side (multiple of 64; default 1024)")
    new.add_argument("--name", default=None, help="project name (default: the file name)")
    new.add_argument("--self-contained", action="store_true", help="embed the head's files")
    new.add_argument("--force", action="store_true", help="replace an existing file (kept as FILE.bak)")
    new.set_defaults(func=run_new)

    info = cmds.add_parser("info", help="describe a project")
    info.add_argument("file")
    info.add_argument("--json", action="store_true", help="print JSON")
    info.set_defaults(func=run_info)

    val = cmds.add_parser("validate", help="check a project; exit 0 when valid, 2 otherwise")
    val.add_argument("file")
    val.set_defaults(func=run_validate)

    exp = cmds.add_parser("export", help="write the layer maps and a manifest into a folder, or the made-up head as glTF")
    exp.add_argument("file")
    exp.add_argument("--out", help="output folder (created) for the layer maps")
    exp.add_argument("--gltf", metavar="OUT.glb", help="write the head with the makeup baked into its albedo (.glb/.gltf)")
    exp.add_argument("--ora", action="store_true", help="also write layers.ora (OpenRaster)")
    exp.set_defaults(func=run_export)

    up = cmds.add_parser("upgrade", help="rewrite an older project in the current format (keeps FILE.v<N>.bak)")
    up.add_argument("file")
    up.set_defaults(func=run_upgrade)


def run_new(args: argparse.Namespace) -> int:
    """Write an empty project on a head (optionally with a look painted); returns 0."""
    from pathlib import Path

    from core.errors import SheerError
    from project.io import new_project, save_project

    out = Path(args.out)
    if out.exists() and not args.force:
        raise SheerError(f"{out}: already exists (use --force to replace it; the old file is kept as .bak)")
    project = new_project(args.name or out.stem, head_path=args.head, resolution=args.resolution)
    if args.look:
        from painting.document import Document
        from painting.head import load_head
        from painting.looks import apply_look, load_look
        from project.document import project_from_document

        look = load_look(args.look)  # validated before the (slow) document is built
        assert project.head.mesh_path is not None
        doc = Document(load_head(project.head.mesh_path), resolution=args.resolution)
        apply_look(doc, look)
        meta = {"name": look.name, "description": look.description} if look.description else {"name": look.name}
        project = project_from_document(doc, name=project.name, head=project.head, look=meta)
    save_project(project, out, self_contained=args.self_contained)
    print(f"wrote {out} (head '{project.head.name}', {len(project.layers)} layers, "
          f"resolution {project.resolution}²)")
    return 0


def _summary(project: object) -> dict:
    from project.model import Project

    assert isinstance(project, Project)
    return {
        "name": project.name,
        "schema_version": project.source_schema_version,
        "created_by": project.created_by,
        "resolution": project.resolution,
        "layout": project.layout,
        "head": {"name": project.head.name, "embedded": project.head.embedded,
                 "path": None if project.head.mesh_path is None else str(project.head.mesh_path),
                 "asset": project.head.asset, "files": project.head.files},
        "layers": [{"name": layer.name, "material": layer.material, "visible": layer.visible,
                    "opacity": layer.opacity, "max_thickness_um": layer.max_thickness_um,
                    "encoding": layer.encoding, "resolution": layer.resolution,
                    "peak_um": float(layer.thickness.max(initial=0.0)),
                    "mean_um": float(layer.thickness.mean()) if layer.thickness.size else 0.0}
                   for layer in project.layers],
        "materials": sorted(project.materials),
        "lights": len(project.lights),
        "camera": project.camera is not None,
        "look": project.look,
    }


def run_info(args: argparse.Namespace) -> int:
    """Print what a project holds (text, or JSON with ``--json``); returns 0."""
    from project.io import open_project

    summary = _summary(open_project(args.file, verify_head=False))
    if args.json:
        print(json.dumps(summary, indent=2, ensure_ascii=False))
        return 0
    head = summary["head"]
    print(f"{args.file}: '{summary['name']}' (schema_version {summary['schema_version']}, {summary['created_by']})")
    print(f"  head: {head['name']} ({'embedded' if head['embedded'] else head['path'] or head['asset']})")
    print(f"  default layer resolution: {summary['resolution']}² texels")
    print(f"  layers ({len(summary['layers'])}, bottom first):")
    for layer in summary["layers"]:
        print(f"    {layer['name']!r:24} {layer['material']!r:24} {'shown' if layer['visible'] else 'hidden':6} "
              f"opacity {layer['opacity']:.2f}  max thickness {layer['max_thickness_um']:g} µm  "
              f"painted: peak {layer['peak_um']:.2f} µm, mean {layer['mean_um']:.3f} µm "
              f"[{layer['resolution']}² {layer['encoding']}]")
    print(f"  materials: {', '.join(summary['materials']) or 'none'}")
    print(f"  lights: {summary['lights']}; camera: {'yes' if summary['camera'] else 'no'}; "
          f"look: {summary['look']['name'] if summary['look'] else 'none'}")
    return 0


def run_validate(args: argparse.Namespace) -> int:
    """Check a project against docs/FORMAT.md; returns 0 when valid, 2 with a one-line reason."""
    from core.errors import SheerError
    from project.io import open_project

    try:
        project = open_project(args.file)
    except SheerError as exc:
        print(f"sheer: invalid: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"sheer: invalid: {args.file}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    print(f"{args.file}: valid ({len(project.layers)} layers, schema_version {project.source_schema_version})")
    return 0


def run_export(args: argparse.Namespace) -> int:
    """Write each layer's map (EXR and 16-bit PNG), the materials and a manifest into --out; returns 0.

    With ``--gltf OUT.glb`` the made-up head is written as glTF (:mod:`catalogue.glb`, as the studio's
    File → Export glTF does).
    """
    from core.errors import SheerError

    if not args.out and not args.gltf:
        raise SheerError("give --out DIR (the layer maps) and/or --gltf OUT.glb (the made-up head)")
    if args.gltf:
        from catalogue.glb import write_gltf
        from project.document import document_from_project
        from project.io import open_project

        write_gltf(document_from_project(open_project(args.file)), None, args.gltf)
        print(f"wrote {args.gltf}")
    if not args.out:
        return 0
    from project.export import export_project

    manifest = export_project(args.file, args.out, ora=args.ora)
    print(f"wrote {len(manifest['layers'])} layer maps and manifest.json to {args.out}")
    return 0


def run_upgrade(args: argparse.Namespace) -> int:
    """Rewrite a project from an older Sheer in the current format (keeping ``FILE.v<N>.bak``); returns 0.

    The project's lock is held from the read to the write (:func:`core.locks.writing`): refused, exit 2,
    while a studio has it open; another save waits for it.
    """
    from core.locks import writing
    from project.io import SCHEMA_VERSION, open_project, save_project

    with writing(args.file):
        project = open_project(args.file)
        old = project.source_schema_version
        if old == SCHEMA_VERSION:
            print(f"{args.file}: already schema_version {SCHEMA_VERSION}; nothing to do")
            return 0
        save_project(project, args.file)
    print(f"{args.file}: upgraded from schema_version {old} to {SCHEMA_VERSION} (original kept as "
          f"{args.file}.v{old}.bak)")
    return 0
