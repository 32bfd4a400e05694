"""``sheer look``: looks and painted projects across heads.

    sheer look transfer --project IN.sheer --head NEW --out OUT.sheer [--embed-head]

Moves every layer of a project (thickness maps, masks, materials, settings) onto another head by surface
correspondence (:mod:`painting.transfer`: a thin-plate spline on the landmarks both heads' sidecars name,
then the closest point on the project's head for every texel of the new one) and saves the result as a
new project on that head, atomically. NEW is a head mesh (.obj/.glb/…), its ``<mesh>.sheer-head.json``
sidecar, a sample head's ``resources/heads/<name>.json`` sidecar, or a face folder written by
``sheer capture`` (the person's own head inside it). Prints one line saying what was transferred.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import argparse
    from pathlib import Path

    from app.commands import Subcommands


def register(sub: Subcommands) -> None:
    """Add ``sheer look`` and its sub-commands to the sub-command parsers ``sub``."""
    from app.commands import command_group

    lsub = command_group(sub, "look", "looks and projects across heads (transfer)", __doc__)
    t = lsub.add_parser("transfer", help="move a project's layers onto another head (e.g. a captured face)")
    t.add_argument("--project", required=True, metavar="IN.sheer", help="the painted project")
    t.add_argument("--head", required=True, metavar="NEW",
                   help="a head mesh, its sidecar, or a face folder from 'sheer capture'")
    t.add_argument("--out", required=True, metavar="OUT.sheer", help="the project to write (on the new head)")
    t.add_argument("--embed-head", action="store_true", help="store the new head's files inside OUT")
    t.set_defaults(func=run_transfer)


def head_mesh_path(value: str | Path) -> Path:
    """The mesh file NEW names (see the module docstring); :class:`core.errors.SheerError` when it names none."""
    from pathlib import Path

    from core.errors import SheerError
    from painting.head import MESH_TYPES, SAMPLE_HEAD, SIDECAR_SUFFIX

    p = Path(value)
    hint = "give a head mesh, its .sheer-head.json sidecar or a face folder from 'sheer capture'"
    if p.is_dir():
        if not (p / "face.json").is_file():
            raise SheerError(f"{p}: not a face folder (no face.json); {hint}")
        from capture.face import load_face

        mesh = load_face(p).head_path
        if mesh is None:
            from core.assets import find_asset

            return find_asset(SAMPLE_HEAD)
        if not mesh.is_file():
            raise SheerError(f"{p}: the face's head {mesh} is missing")
        return mesh
    if not p.is_file():
        raise SheerError(f"{p}: not found; {hint}")
    if p.name.endswith(SIDECAR_SUFFIX):
        mesh = p.with_name(p.name[: -len(SIDECAR_SUFFIX)])
        if not mesh.is_file():
            raise SheerError(f"{p}: its mesh {mesh.name} is not beside it")
        return mesh
    if p.suffix.lower() == ".json":  # a sample head's sidecar in resources/heads/<folder>.json
        from core.assets import assets_search_path

        for root in assets_search_path():
            folder = root / "heads" / p.stem
            meshes = sorted(f for f in folder.glob("*") if f.suffix.lower() in MESH_TYPES) if folder.is_dir() else []
            if len(meshes) == 1:
                return meshes[0]
        raise SheerError(f"{p}: no sample head folder heads/{p.stem}/ with one mesh among the assets; {hint}")
    if p.suffix.lower() not in MESH_TYPES:
        raise SheerError(f"{p}: not a head ({p.suffix or 'no suffix'}); {hint}")
    return p


def run_transfer(args: argparse.Namespace) -> int:
    """Run ``sheer look transfer``; returns 0 (errors are :class:`core.errors.SheerError`, one line)."""
    import sys
    from pathlib import Path

    from core.errors import SheerError
    from painting.head import load_head
    from painting.transfer import transfer_document
    from project import (
        document_from_project,
        make_head_ref,
        open_project,
        project_from_document,
        save_project,
    )

    out = Path(args.out)
    if out.suffix.lower() != ".sheer":
        raise SheerError(f"{out}: the output must be a .sheer file")
    if not out.parent.is_dir():
        raise SheerError(f"{out.parent}: no such folder for the output")
    mesh = head_mesh_path(args.head)
    project = open_project(args.project)
    source = document_from_project(project)
    head = load_head(mesh)
    doc, report = transfer_document(source, head)
    # Lights placed at a point are in the old head's mesh units: they would be wrong on the new head.
    lights = [light for light in project.lights if "position" not in light]
    dropped = len(project.lights) - len(lights)
    result = project_from_document(doc, name=f"{project.name} on {head.name}",
                                   head=make_head_ref(mesh, embed=args.embed_head), lights=lights,
                                   look=project.look)
    written = save_project(result, out, self_contained=args.embed_head, clear_recovery=False)
    note = f"; {dropped} positioned light(s) not carried over (the new head's units differ)" if dropped else ""
    print(f"{report.summary()}; wrote {written}{note}", file=sys.stdout)
    return 0
