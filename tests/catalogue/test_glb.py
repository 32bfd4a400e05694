"""The made-up head as GLB from the command line: a structurally valid glTF 2.0 file, rendered back."""

from __future__ import annotations

import dataclasses
import json
import struct
from typing import TYPE_CHECKING

import numpy as np
import pytest

from app.cli import main

if TYPE_CHECKING:
    from pathlib import Path

pytestmark = pytest.mark.gl
_COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
_TYPE_COUNT = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def check_glb(blob: bytes) -> dict:
    """Validate a GLB's container and JSON structurally; returns the JSON."""
    magic, version, length = struct.unpack_from("<4sII", blob, 0)
    assert (magic, version, length) == (b"glTF", 2, len(blob))
    json_len, json_type = struct.unpack_from("<I4s", blob, 12)
    assert json_type == b"JSON"
    doc = json.loads(blob[20:20 + json_len])
    bin_len, bin_type = struct.unpack_from("<I4s", blob, 20 + json_len)
    assert bin_type == b"BIN\0" and 28 + json_len + bin_len == len(blob)
    assert doc["asset"]["version"] == "2.0"
    assert len(doc["buffers"]) == 1 and doc["buffers"][0]["byteLength"] <= bin_len
    for view in doc["bufferViews"]:
        assert view.get("byteOffset", 0) + view["byteLength"] <= doc["buffers"][view["buffer"]]["byteLength"]
    for acc in doc["accessors"]:
        view = doc["bufferViews"][acc["bufferView"]]
        size = acc["count"] * _COMPONENT_BYTES[acc["componentType"]] * _TYPE_COUNT[acc["type"]]
        assert acc.get("byteOffset", 0) + size <= view["byteLength"]
    prim = doc["meshes"][0]["primitives"][0]
    assert {"POSITION", "NORMAL", "TEXCOORD_0"} <= set(prim["attributes"])
    tex = doc["materials"][prim["material"]]["pbrMetallicRoughness"]["baseColorTexture"]["index"]
    image = doc["images"][doc["textures"][tex]["source"]]
    assert image["mimeType"] in ("image/png", "image/jpeg") and "bufferView" in image
    return doc


def _lip_redness(image: np.ndarray, renderer: object, point: np.ndarray) -> float:
    """R / G of a 5×5 patch around the 3-D ``point`` (mesh units) projected into the last frame."""
    w, h = renderer.last.size  # type: ignore[attr-defined]
    clip = renderer.last.view_proj @ np.append(point, 1.0)  # type: ignore[attr-defined]
    x = int(round((clip[0] / clip[3] * 0.5 + 0.5) * w))
    y = int(round((0.5 - clip[1] / clip[3] * 0.5) * h))
    patch = image[y - 2:y + 3, x - 2:x + 3].reshape(-1, 3).astype(float)
    return float(patch[:, 0].mean() / max(patch[:, 1].mean(), 1.0))


def test_project_export_gltf_is_valid_and_renders_back(gl_ctx, tmp_path: Path) -> None:
    import trimesh
    from PIL import Image

    from painting.head import load_head
    from render import Renderer

    project, glb = tmp_path / "red.sheer", tmp_path / "red.glb"
    assert main(["project", "new", "--out", str(project), "--look", "red-lip", "--resolution", "256"]) == 0
    assert main(["project", "export", str(project), "--gltf", str(glb)]) == 0
    doc = check_glb(glb.read_bytes())
    sample = load_head(None)
    assert doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]["count"] == len(sample.vertices)

    mesh = trimesh.load(glb, force="mesh", process=False)
    texture = np.asarray(mesh.visual.material.baseColorTexture.convert("RGB"))
    back = dataclasses.replace(sample, vertices=np.asarray(mesh.vertices, float), faces=np.asarray(mesh.faces),
                               uv=np.asarray(mesh.visual.uv, float), albedo=texture)
    images = {}
    for name, head in (("bare", sample), ("glb", back)):
        r = Renderer(gl_ctx, head)
        try:
            images[name] = r.render_image((160, 160))
            lips = _lip_redness(images[name], r, head.landmark("lower_lip"))
            cheek = _lip_redness(images[name], r, head.landmark("left_cheek"))
            images[name + "_ratio"] = lips / cheek
        finally:
            r.release()
    assert images["glb"].std() > 10  # the head is there
    # the baked lipstick shows: the lips are redder against the cheek than on the bare head
    assert images["glb_ratio"] > images["bare_ratio"] * 1.1, (images["glb_ratio"], images["bare_ratio"])
    Image.fromarray(images["glb"]).save(tmp_path / "back.png")
    assert main(["project", "export", str(project), "--gltf", str(tmp_path / "x.obj")]) == 2
