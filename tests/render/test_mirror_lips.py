"""The mirror view's lipstick on her own lips (render/mirror_lips.py, ``mirror_face.frag.glsl``), on Grace
Hopper's automatic capture (the session's ``hopper_face``: her face-mesh landmarks, her own head).

Measured (``python -m pytest tests/render/test_mirror_lips.py``; before = :attr:`MirrorView.clip_lips`
False, the composite as the atlas paints the layer; the layers' own lobes off for the detail):

================================================ ========== ==========
measure                                           before     after
================================================ ========== ==========
detail correlation under Lipstick Classic Red     0.28       0.58
detail correlation under Lipstick Red Matte       0.29       0.58
detail correlation under Lipstick Red Gloss 6 µm  0.71       0.79
lipstick beyond +0.5 mm of her lip contour        0.95 %     0.07 %
edge steps > 0.3 mm (4× photo, 5.2 px/mm)        12         3
================================================ ========== ==========

*Detail correlation*: Pearson's r, over the pixels ≥ 0.3 mm inside her outer-lip landmark polygon, of the
high-pass log-luminance (log Y − its Gaussian low-pass, σ = 1 mm) of the made-up frame against the bare
photograph's. *Beyond +0.5 mm*: the share of the lipstick's difference |made-up − photograph| (linear RGB)
on pixels more than 0.5 mm outside that polygon (mm from the fitted head through the camera).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest
from PIL import Image

from km.srgb import srgb_decode
from tests.capture import portraits

if TYPE_CHECKING:
    from pathlib import Path

    from painting.head import Head

pytestmark = [pytest.mark.slow, pytest.mark.gl, pytest.mark.xdist_group(portraits.GROUP)]
LUM = np.array([0.2126, 0.7152, 0.0722])
#: Bounds (the table above, with margin): a full-coverage lipstick keeps at least this correlation with
#: her lips' own detail (the atlas-painted fill: 0.28–0.29, its smooth model shading only)...
DETAIL_MIN = 0.45
#: ... and a sheer gloss (6 µm) this much more than a matte cream (the matte hides her lips' colour).
GLOSS_OVER_MATTE = 0.1
#: The lipstick's share beyond +0.5 mm of her lip contour (atlas fill: ~1 %).
OUTSIDE_MAX = 0.003


@dataclasses.dataclass(frozen=True)
class Lips:
    face: Any
    head: Head
    photo8: np.ndarray
    ppmm: float
    sd_mm: np.ndarray  # signed distance to her outer-lip landmark polygon, mm (positive outside)


@pytest.fixture(scope="module")
def lips(hopper_face: Path) -> Lips:
    from capture.face import load_face
    from render import mirror_lips as ml
    from render.mirror import photo_camera_at

    face = load_face(hopper_face)
    head = face.load_head()
    assert face.photo_path is not None
    with Image.open(face.photo_path) as im:
        photo8 = np.asarray(im.convert("RGB"))
    h, w = photo8.shape[:2]
    pts = ml.face_landmarks_px(face, w, h)
    assert pts is not None
    poly = np.concatenate([pts[list(ml.UPPER_OUTER)], pts[list(ml.LOWER_OUTER)][::-1][1:-1]])
    ppmm = ml.px_per_mm(photo_camera_at(face, w, h), head, np.asarray(head.metadata.landmarks["lip_centre"]))
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    return Lips(face, head, photo8, ppmm, ml.signed_distance(poly, xx, yy) / ppmm)


def _lip_layers(head: Head, material: str, amount_um: float = 20.0) -> list[Any]:
    """red-lip's lipstick (its lips fill) in ``material`` at ``amount_um``."""
    from km import default_library
    from painting import Document
    from painting.looks import apply_look, load_look
    from render.binding import layer_inputs

    doc = Document(head, resolution=512, library=default_library())
    lk = load_look("red-lip")
    lay = next(x for x in lk.layers if "Lipstick" in x.material)
    strokes = [dataclasses.replace(s, amount_um=amount_um) for s in lay.strokes]
    apply_look(doc, dataclasses.replace(lk, layers=[dataclasses.replace(lay, material=material, strokes=strokes)]))
    return layer_inputs(doc)


def _render(gl_ctx: Any, lips: Lips, layers: list[Any], clip: bool = True, spec: float | None = 0.0) -> np.ndarray:
    from render.mirror import MirrorView

    mv = MirrorView(gl_ctx, lips.head, lips.face, lips.photo8)
    try:
        mv.clip_lips = clip
        if spec is not None:
            mv.spec_intensity = spec
        mv.set_layers(layers)
        return mv.render_image()
    finally:
        mv.release()


def detail_correlation(made_up8: np.ndarray, photo8: np.ndarray, where: np.ndarray, sigma_px: float) -> float:
    """Pearson's r of the high-pass log-luminance (σ pixels) of the two frames over ``where``."""
    from scipy.ndimage import gaussian_filter

    def hp(img8: np.ndarray) -> np.ndarray:
        y = np.log(np.maximum(srgb_decode(img8 / 255.0) @ LUM, 1e-4))
        return np.asarray(y - gaussian_filter(y, sigma_px))

    return float(np.corrcoef(hp(photo8)[where], hp(made_up8)[where])[0, 1])


def outside_share(made_up8: np.ndarray, photo8: np.ndarray, sd_mm: np.ndarray, beyond_mm: float = 0.5) -> float:
    """The share of the difference |made-up − photograph| (linear RGB) more than ``beyond_mm`` outside."""
    eff = np.abs(srgb_decode(made_up8 / 255.0) - srgb_decode(photo8 / 255.0)).sum(axis=2)
    return float(eff[sd_mm > beyond_mm].sum() / max(eff.sum(), 1e-12))


def test_lipstick_keeps_her_lips_detail(lips: Lips, gl_ctx: Any) -> None:
    inner = lips.sd_mm < -0.3
    assert inner.sum() > 200
    r = {}
    for key, material, um in (("classic", "Lipstick Classic Red", 20.0), ("matte", "Lipstick Red Matte", 20.0),
                              ("gloss", "Lipstick Red Gloss", 6.0)):
        made_up = _render(gl_ctx, lips, _lip_layers(lips.head, material, um))
        r[key] = detail_correlation(made_up, lips.photo8, inner, lips.ppmm)
    assert r["classic"] >= DETAIL_MIN and r["matte"] >= DETAIL_MIN, r
    assert r["gloss"] >= r["matte"] + GLOSS_OVER_MATTE, r


def test_lipstick_stays_within_her_lips(lips: Lips, gl_ctx: Any) -> None:
    made_up = _render(gl_ctx, lips, _lip_layers(lips.head, "Lipstick Classic Red"), spec=None)
    share = outside_share(made_up, lips.photo8, lips.sd_mm)
    assert share <= OUTSIDE_MAX, share
    changed = np.abs(made_up.astype(int) - lips.photo8.astype(int)).max(axis=2) > 2
    assert (changed & (lips.sd_mm < -0.5)).sum() > 0.9 * (lips.sd_mm < -0.5).sum()  # and fills them


def test_red_lip_look_keeps_the_foundation_around_her_lips(lips: Lips, gl_ctx: Any) -> None:
    """Outside her lips the other layers (red-lip's foundation) still make their difference: the clip
    takes off the lip layers alone."""
    from km import default_library
    from painting import Document
    from painting.looks import apply_look, load_look
    from render.binding import layer_inputs

    doc = Document(lips.head, resolution=512, library=default_library())
    apply_look(doc, load_look("red-lip"))
    layers = layer_inputs(doc)
    on = _render(gl_ctx, lips, layers, spec=None)
    off = _render(gl_ctx, lips, layers, clip=False, spec=None)
    far = lips.sd_mm > 3.0  # beyond the atlas's lip fill: the foundation alone, the same either way
    assert np.abs(on[far].astype(int) - off[far].astype(int)).max() <= 1
    assert np.abs(on[far].astype(int) - lips.photo8[far].astype(int)).max() > 2  # the foundation shows


def edge_steps(made_up8: np.ndarray, photo8: np.ndarray, pts: np.ndarray, step_px: float = 1.5) -> int:
    """Columns (the middle 70 % of her mouth) where the lipstick's upper or lower edge jumps by more than
    ``step_px`` from the column before: a staircase or a facet's kink (a smooth edge steps by under a pixel)."""
    changed = np.abs(made_up8.astype(int) - photo8.astype(int)).max(axis=2) > 2
    xl, xr = pts[61, 0], pts[291, 0]
    xs = np.arange(int(xl + 0.15 * (xr - xl)), int(xr - 0.15 * (xr - xl)))
    ymid = int(pts[[13, 14], 1].mean())
    lower = np.array([ymid + np.argmin(changed[ymid:, x]) for x in xs], float)
    upper = np.array([ymid - np.argmin(changed[:ymid + 1, x][::-1]) for x in xs], float)
    return int((np.abs(np.diff(lower)) > step_px).sum() + (np.abs(np.diff(upper)) > step_px).sum())


def test_lip_edge_is_smooth(lips: Lips, gl_ctx: Any) -> None:
    """Her photograph 4× larger (5.2 px/mm): the atlas-painted edge shows the mesh polygon's facets and
    the paint map's texels as steps (12); her contour's spline steps by under 0.3 mm but where it turns
    steeply (3)."""
    from render import mirror_lips as ml
    from render.mirror import MirrorView

    h, w = lips.photo8.shape[:2]
    big = np.asarray(Image.fromarray(lips.photo8).resize((4 * w, 4 * h), Image.Resampling.BICUBIC))
    mv = MirrorView(gl_ctx, lips.head, lips.face, big)
    try:
        mv.spec_intensity = 0.0
        mv.set_layers(_lip_layers(lips.head, "Lipstick Classic Red"))
        made_up = mv.render_image()
    finally:
        mv.release()
    pts = ml.face_landmarks_px(lips.face, 4 * w, 4 * h)
    assert pts is not None
    steps = edge_steps(made_up, big, pts)
    assert steps <= 4, steps
