#!/usr/bin/env python3
"""Build the canonical face's shipped files (issue #15): its sidecar's landmarks and its regions.

- ``resources/heads/canonical-face.json``: the landmarks, each the mean of the face-mesh vertices
  :data:`capture.landmarks.STANDARD_LANDMARKS` names for it, projected onto the surface
  (:func:`capture.person.surface_points`) — the same definitions a captured face's sidecar gets, checked
  against the sample head (tests/capture/test_auto_landmarks.py);
- ``resources/heads/canonical-face.regions.png``: the facial regions of the canonical topology
  (:func:`painting.region_shapes.derive_regions`: lips, eyes, lids, crease, brow bone, under-eye and
  brows from MediaPipe's face-mesh contour indices, the rest from the landmarks), as
  ``scripts/build_head_regions.py`` builds them; a captured face (same topology, same UVs) copies it.

Deterministic: running it again gives the same bytes. Usage::

    python scripts/build_canonical_face.py           # rewrite both files
    python scripts/build_canonical_face.py --check   # exit 1 if either differs from what this builds
"""

from __future__ import annotations

import argparse
import importlib.util
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SIDECAR = ROOT / "resources" / "heads" / "canonical-face.json"
REGIONS = ROOT / "resources" / "heads" / "canonical-face.regions.png"
SCALE_NOTE = (
    "The canonical face model's units are centimetres (MediaPipe face geometry: metric 3D space in cm), so 10 mm "
    "per unit. Check: outer eye corners (33-263) 8.89 u = 88.9 mm, inner (133-362) 3.71 u = 37.1 mm, mouth corners "
    "(61-291) 4.91 u = 49.1 mm, all close to adult means. Landmarks from the MediaPipe 468-point topology (vertex i = "
    "landmark i), each the mean of the vertices capture.landmarks.STANDARD_LANDMARKS names, projected on the surface "
    "(built by scripts/build_canonical_face.py): {defs}. The indices were checked against the sample head's sidecar "
    "(its landmarks projected into renders at -15, 0, +15 deg of yaw against MediaPipe's detections). Subject's left = +X."
)


def sidecar_text() -> str:
    """The canonical face sidecar with the landmarks of :func:`capture.person.surface_points`."""
    from capture.landmarks import STANDARD_LANDMARKS
    from capture.person import canonical_topology, compact_json, surface_points

    topo = canonical_topology()
    data = json.loads(SIDECAR.read_text(encoding="utf-8"))
    data["landmarks"] = {k: list(v) for k, v in surface_points(topo.vertices, topo.faces).items()}
    defs = ", ".join(f"{k} {'+'.join(map(str, v))}" for k, v in STANDARD_LANDMARKS.items())
    data["scale_note"] = SCALE_NOTE.format(defs=defs)
    return compact_json(data)


def regions_bytes() -> bytes:
    """The canonical face's regions, built by scripts/build_head_regions.py's ``build``."""
    from core.assets import find_asset

    spec = importlib.util.spec_from_file_location("build_head_regions", ROOT / "scripts" / "build_head_regions.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    blob, _ = module.build(str(find_asset("heads/canonical-face/canonical_face_model.obj")))
    return blob


def main(argv: list[str] | None = None) -> int:
    """Write (or ``--check``) the canonical face's sidecar and regions; returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if a file differs from what this builds")
    args = parser.parse_args(argv)
    from core.atomicio import atomic_write_bytes, atomic_write_text

    text = sidecar_text()
    if args.check:
        ok = SIDECAR.read_text(encoding="utf-8") == text
        print(f"{SIDECAR}: {'up to date' if ok else 'differs from what this script builds'}")
        same = REGIONS.is_file() and REGIONS.read_bytes() == regions_bytes()
        print(f"{REGIONS}: {'up to date' if same else 'differs from what this script builds'}")
        return 0 if ok and same else 1
    atomic_write_text(SIDECAR, text)  # first: the regions read the landmarks
    print(f"wrote {SIDECAR}")
    blob = regions_bytes()
    atomic_write_bytes(REGIONS, blob)
    print(f"wrote {REGIONS} ({len(blob):,} bytes)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
