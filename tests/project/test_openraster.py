"""``sheer project export --ora`` and the studio's File → Export OpenRaster write what a painting program shows
usefully: each cosmetic as a layer of its colour with its coverage as alpha (the lipstick opaque on the lips,
not a near-black grey at 38/255), the thickness maps as grey data layers in a hidden group, and a
``mergedimage.png`` that is the visible layers composited as an OpenRaster reader composites them (src-over).
The stack is read here as a reader reads it: stack.xml (OpenRaster 0.0.5, baseline), then each layer's PNG."""

from __future__ import annotations

import io
import xml.etree.ElementTree as ET
import zipfile
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest
from PIL import Image

if TYPE_CHECKING:
    from pathlib import Path


def read_ora(path: Path) -> tuple[ET.Element, dict[str, np.ndarray], np.ndarray]:
    """stack.xml's root, every PNG in the file (name → uint8 array) and the merged image, as a reader gets them."""
    with zipfile.ZipFile(path) as zf:
        names = zf.namelist()
        assert names[0] == "mimetype" and zf.read("mimetype") == b"image/openraster"
        assert zf.getinfo("mimetype").compress_type == zipfile.ZIP_STORED  # (the spec: first, uncompressed)
        root = ET.fromstring(zf.read("stack.xml"))
        pngs = {n: np.asarray(Image.open(io.BytesIO(zf.read(n)))) for n in names if n.endswith(".png")}
    return root, pngs, pngs["mergedimage.png"]


def composite(root: ET.Element, pngs: dict[str, np.ndarray]) -> np.ndarray:
    """The root stack composited as an OpenRaster reader does: bottom to top, src-over, straight alpha, the
    layers' opacity, hidden layers and hidden stacks left out (float RGBA in [0, 1])."""
    stack = root.find("stack")
    assert stack is not None
    w, h = int(root.get("w")), int(root.get("h"))
    out = np.zeros((h, w, 4))

    def visit(element: ET.Element) -> None:
        nonlocal out
        for child in reversed(list(element)):  # the first child is the top
            if child.get("visibility", "visible") != "visible":
                continue
            if child.tag == "stack":
                visit(child)
                continue
            assert child.get("composite-op", "svg:src-over") == "svg:src-over"
            src = pngs[child.get("src")].astype(np.float64) / 255.0
            assert src.shape == (h, w, 4), "each layer an RGBA image of the canvas"
            a = src[..., 3:4] * float(child.get("opacity", "1"))
            da = out[..., 3:4]
            alpha = a + da * (1 - a)
            rgb = (src[..., :3] * a + out[..., :3] * da * (1 - a)) / np.where(alpha > 0, alpha, 1)
            out = np.concatenate([rgb, alpha], axis=-1)

    visit(stack)
    return out


@pytest.fixture(scope="module")
def natural_project(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The sample head wearing the natural look, saved as a project (256² maps)."""
    from app.session import Session
    from project.document import project_from_document
    from project.io import save_project

    session = Session.open(resolution=256, look="natural")
    path = tmp_path_factory.mktemp("ora") / "natural.sheer"
    save_project(project_from_document(session.document, name="natural"), path)
    return session.document, path


def test_cli_ora_shows_each_cosmetic_in_its_colour(natural_project: Any, tmp_path: Path) -> None:
    from app.cli import main

    doc, path = natural_project
    assert main(["project", "export", str(path), "--out", str(tmp_path), "--ora"]) == 0
    root, pngs, merged = read_ora(tmp_path / "layers.ora")
    assert root.get("version") == "0.0.5"
    stack = root.find("stack")
    colour = [e for e in stack if e.tag == "layer"]
    data = stack.find("stack")
    # the cosmetics, top first, each named with its material; the thickness maps in a hidden group
    assert [e.get("name").split(" (")[0] for e in colour] == [lay.name for lay in reversed(doc.layers)]
    assert data is not None and data.get("visibility") == "hidden" and "thickness" in data.get("name")
    assert len(list(data)) == len(doc.layers)
    lips = doc.region_values("lips", 256) > 0.9
    lipstick = next(e for e in colour if e.get("name").startswith("Lipstick"))
    rgba = pngs[lipstick.get("src")]
    # the lipstick covers the lips (alpha, not a grey level of 38/255), in its own red, and nothing elsewhere
    assert np.median(rgba[..., 3][lips]) > 200
    r, g, b = np.median(rgba[..., :3][lips & (rgba[..., 3] > 200)], axis=0)
    material = doc.library.get(doc.layers[[lay.name for lay in doc.layers].index("Lipstick")].material)
    swatch = np.rint(material.swatch_rgb("opaque") * 255)
    assert r > g and r > b and np.abs(np.array([r, g, b]) - swatch).max() < 40, ((r, g, b), swatch)
    assert np.mean(rgba[..., 3][~lips] > 0) < 0.05
    # the merged image is what a reader composites from the stack
    ours = composite(root, pngs)
    assert merged.shape == ours.shape
    assert np.abs(merged.astype(float) / 255 - ours).max() < 2.5 / 255
    # and it shows the makeup: the lips red, the cheeks and skin covered by foundation
    assert np.median(merged[..., 0][lips]) > np.median(merged[..., 1][lips]) + 40
    # the data layers: grey thickness, white at the peak the name states
    first = list(data)[-1]  # the bottom layer's map
    grey = pngs[first.get("src")]
    peak = float(doc.layers[0].effective_thickness().max())
    assert f"{peak:.1f} µm" in first.get("name") and grey[..., 0].max() == 255 and grey[..., 3].min() == 255


def test_a_transparent_canvas_where_nothing_is_painted(tmp_path: Path) -> None:
    from km.library import default_library
    from project.export import document_ora_bytes

    lib = default_library()
    t = np.zeros((64, 64), np.float32)
    t[10:20, 10:20] = 15.0
    name = "Lipstick Classic Red"
    (tmp_path / "x.ora").write_bytes(document_ora_bytes("x", [("Lips", lib.get(name), t, 40.0, 1.0, True),
                                                            ("Hidden", lib.get(name), t, 40.0, 1.0, False)]))
    root, pngs, merged = read_ora(tmp_path / "x.ora")
    assert merged[..., 3][30:, 30:].max() == 0 and merged[..., 3][12:18, 12:18].min() > 200
    assert [e.get("visibility") for e in root.find("stack") if e.tag == "layer"] == ["hidden", "visible"]
