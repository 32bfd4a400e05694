"""The lash line (issue #16): the sample head's closed-lid slit found in its geometry, the ``lash_line``
region on it, the face mesh's from its EyeUpper0 contour, and a look that lines it."""

from __future__ import annotations

import numpy as np
import pytest

from core.assets import find_asset
from painting import Document
from painting.region_shapes import CONTOURS, FaceFrame, lid_slit
from painting.regions import REGION_RESOLUTION


@pytest.fixture(scope="module")
def sample() -> Document:
    return Document.from_head(None, resolution=1024)


def _front_z(doc: Document, frame: FaceFrame, x: float, y: float) -> float | None:
    """The frontmost surface's face-frame Z (mm) at face-frame (x, y), by a ray along −Z (painting.hit)."""
    ex, ey, ez = frame.axes
    p = frame.origin + (x * ex + y * ey + 200.0 * ez) / frame.mpu
    hit = doc.hit(tuple(p), tuple(-ez))
    if hit is None:
        return None
    return float(frame.mm(np.asarray(getattr(hit, "point", hit), float))[2])


def test_the_slit_is_where_the_upper_lid_overhangs_the_lower(sample: Document) -> None:
    """Checked by rays (painting.hit), independent of the z-buffer the slit was found with: 0.6 mm above
    the slit the surface stands ≥ 0.8 mm in front of the surface 0.6 mm below it, along the middle of
    each eye; and the slit lies between the corners' line and 4 mm below it (closed lids droop)."""
    frame = FaceFrame(sample.head)
    lm = {k: frame.mm(np.asarray(v, float)) for k, v in sample.head.metadata.landmarks.items()}
    for side in ("left", "right"):
        inner, outer = lm[f"{side}_eye_inner"], lm[f"{side}_eye_outer"]
        slit = lid_slit(sample.head, frame, inner, outer)
        assert slit is not None, side
        steps = []
        for s in np.linspace(0.2, 0.8, 7):
            x = inner[0] + s * (outer[0] - inner[0])
            corner_line = inner[1] + s * (outer[1] - inner[1])
            assert corner_line - 4.0 <= slit(s) <= corner_line + 0.5, (side, s)
            above, below = _front_z(sample, frame, x, slit(s) + 0.6), _front_z(sample, frame, x, slit(s) - 0.6)
            assert above is not None and below is not None
            steps.append(above - below)
        print(side, "lid step across the slit (mm):", np.round(steps, 2))
        assert min(steps) >= 0.8, (side, steps)


def test_lash_line_region_lies_on_the_slit(sample: Document) -> None:
    """Every lash-line texel (mask ≥ 0.5) is between 0.3 mm (+ half the feather) below the slit and
    2.2 mm (+ half the feather) above it, between the eye corners; the band covers the slit all along."""
    region = sample.regions.get("lash_line")
    assert "slit" in region.source and region.feather_mm == 0.5
    atlas = sample.atlas_at(REGION_RESOLUTION)
    frame = FaceFrame(sample.head)
    lm = {k: frame.mm(np.asarray(v, float)) for k, v in sample.head.metadata.landmarks.items()}
    sel = (region.mask >= 0.5) & atlas.coverage
    p = frame.mm(atlas.position[sel])
    assert len(p) > 400
    placed = np.zeros(len(p), bool)
    for side in ("left", "right"):
        inner, outer = lm[f"{side}_eye_inner"], lm[f"{side}_eye_outer"]
        slit = lid_slit(sample.head, frame, inner, outer)
        assert slit is not None
        s = (p[:, 0] - inner[0]) / (outer[0] - inner[0])
        mine = (s > -0.1) & (s < 1.1)
        dy = p[mine, 1] - slit(np.clip(s[mine], 0.0, 1.0))
        assert dy.min() >= -0.3 - 0.25 - 0.1 and dy.max() <= 2.2 + 0.25 + 0.1, (side, dy.min(), dy.max())
        placed |= mine
        # the band covers the slit from corner to corner: every 1 mm of s has lash-line texels
        cols = np.floor(s[mine] * abs(outer[0] - inner[0])).astype(int)
        assert set(range(1, int(abs(outer[0] - inner[0])) - 1)) <= set(cols.tolist()), side
    assert placed.all()  # nothing of the lash line away from the eyes


def test_face_mesh_lash_line_is_on_its_upper_lid_contour() -> None:
    from painting.region_shapes import derive_regions

    doc = Document.from_head(find_asset("heads/canonical-face/canonical_face_model.obj"), resolution=512)
    atlas = doc.atlas_at(REGION_RESOLUTION)
    region = derive_regions(doc.head, atlas, head_uv=doc.layout.source == "mesh").get("lash_line")
    assert "EyeUpper0" in region.source
    frame = FaceFrame(doc.head)
    v = frame.mm(doc.head.vertices)[:, :2]
    p = frame.mm(atlas.position[(region.mask >= 0.5) & atlas.coverage])[:, :2]
    assert len(p) > 50
    contour = np.concatenate([v[CONTOURS["leftEyeUpper0"]], v[CONTOURS["rightEyeUpper0"]]])
    # each texel within the band's half-width (0.8 mm) + half the feather + a texel of the contour's segments
    d = np.min(np.linalg.norm(p[:, None, :] - contour[None, :, :], axis=2), axis=1)
    seg = np.max(np.linalg.norm(np.diff(v[CONTOURS["leftEyeUpper0"]], axis=0), axis=1))
    assert d.max() <= 0.8 + 0.25 + 0.5 * seg + 0.6


def test_evening_look_lines_the_lash_line(sample: Document) -> None:
    from painting.looks import apply_look, load_look
    from painting.regions import region_fit

    look = load_look("evening")
    liner = [lay for lay in look.layers if lay.material.startswith("Eyeliner")]
    assert liner and liner[0].strokes[0].fill_region == "lash_line"
    layers = apply_look(sample, look)
    lay = next(lay for lay in layers if lay.material_object.name.startswith("Eyeliner"))
    mask = sample.region_values("lash_line", lay.resolution)
    texel = sample.atlas_at(lay.resolution).texel_mm
    outside, coverage = region_fit(np.asarray(lay.thickness), mask, texel, liner[0].strokes[0].amount_um or 0.0)
    print(f"evening eyeliner: {100 * outside:.2f} % beyond the lash line + 0.5 mm, coverage {100 * coverage:.1f} %")
    assert outside <= 0.02 and coverage >= 0.95
