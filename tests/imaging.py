"""Comparing what the GPU gives back: frames in ΔE2000, non-colour maps relatively, 8-bit levels.

The GL tests run on Mesa's llvmpipe here and on real GPUs elsewhere (e.g. an NVIDIA H200). Another
rasteriser rounds, snaps and filters differently, so a GPU result is compared bit for bit only where it is
exactly determined (a clear colour, texels nothing redraws, bytes copied, two runs of one program on the
same inputs and state: GL 4.5 appendix A, rule 4), each such test saying why. Anything else goes through
these helpers, with bounds set from what llvmpipe measures and what another GPU may change:

- GL (4.5 §2.3.5.2) lets a float's conversion to an 8-bit target take either neighbouring code, and two
  programs (or two variants of one) need not round their float maths alike: frames that are "the same"
  by construction may differ by one 8-bit level on a few pixels (:func:`max_level_difference`).
- GL requires only 4 sub-pixel bits: edges may move by up to 1/32 pixel. The sample head's frames with
  the projection shifted by 1/32 pixel in x and y differ from the stored references by ΔE2000 mean
  0.12–0.13 and p99 1.1–1.3 over the whole 320×240 frame (tests/render/test_frame.py).
- Half-float targets may be written rounded to nearest or truncated (llvmpipe truncates, as D3D's
  float-to-float conversions do); sub-texel filtering weights may have only 8 fractional bits (D3D11's
  minimum), where llvmpipe filters half floats with float weights.

One 8-bit level in one channel is ΔE2000 0.4–0.7 at the median head pixel and at most 1.1
(:data:`ONE_LEVEL_DE`); a just noticeable difference is about 1.

``SHEER_IMAGE_STATS=<file>`` appends every comparison's figures to ``<file>`` as JSON lines (the test,
the name, the figures and the bounds): how the bounds were measured here, and how to measure them on a GPU.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

FAILURE_DIR = Path(__file__).resolve().parent / "_failures"
REFERENCE_DIR = Path(__file__).resolve().parent / "references"

#: ΔE2000 of one 8-bit level in one channel, the most over the head's pixels of the 320×240 bare frame
#: (tests/references/render_bare_fast.png; the median pixel: 0.38 red, 0.74 green, 0.47 blue)
ONE_LEVEL_DE = 1.1


@dataclass(frozen=True)
class DeStats:
    """ΔE2000 between two frames over a set of pixels: mean, 99th percentile, maximum, pixel count."""

    mean: float
    p99: float
    max: float
    pixels: int


def de2000_map(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
    """ΔE2000 (colour-science's CIE 2000, through km.colour) between two uint8 sRGB frames (H, W, 3).

    Returns the values at the pixels of ``mask`` (bool (H, W); default: all), flattened.
    """
    from bench.stats import de2000_srgb8

    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == np.uint8 and b.dtype == np.uint8, (a.dtype, b.dtype)
    assert a.shape == b.shape and a.ndim == 3 and a.shape[-1] >= 3, (a.shape, b.shape)
    m = np.ones(a.shape[:2], bool) if mask is None else np.asarray(mask, bool)
    assert m.shape == a.shape[:2] and m.any(), "the mask must match the frames and select some pixels"
    return de2000_srgb8(a[..., :3], b[..., :3], m)


def de2000_stats(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None = None) -> DeStats:
    """:class:`DeStats` of :func:`de2000_map`."""
    de = de2000_map(a, b, mask)
    return DeStats(float(de.mean()), float(np.percentile(de, 99)), float(de.max()), int(de.size))


def max_level_difference(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None = None) -> int:
    """The largest difference in 8-bit levels between two uint8 frames (any channel, pixels of ``mask``)."""
    d = np.abs(np.asarray(a, np.int16) - np.asarray(b, np.int16))
    if mask is not None:
        d = d[np.asarray(mask, bool)]
    return int(d.max()) if d.size else 0


def record(name: str, **figures: object) -> None:
    """Append ``figures`` under the current test and ``name`` to ``$SHEER_IMAGE_STATS`` (if set)."""
    path = os.environ.get("SHEER_IMAGE_STATS")
    if not path:
        return
    test = os.environ.get("PYTEST_CURRENT_TEST", "?").split(" ")[0]
    with open(path, "a", encoding="utf-8") as f:
        f.write(json.dumps({"test": test, "name": name, **figures}, default=float) + "\n")


def _failure_stem(name: str) -> str:
    test = os.environ.get("PYTEST_CURRENT_TEST", "test").split(" ")[0].split("::")[-1]
    return "".join(c if c.isalnum() or c in "-_.[]" else "_" for c in f"{test}-{name}")[:150]


def _write_failure(name: str, a: np.ndarray, b: np.ndarray, mask: np.ndarray | None) -> Path:
    """Both frames and their ΔE map (25 grey levels per ΔE unit) under tests/_failures; the map's path."""
    from PIL import Image

    FAILURE_DIR.mkdir(parents=True, exist_ok=True)
    stem = _failure_stem(name)
    Image.fromarray(np.ascontiguousarray(a[..., :3])).save(FAILURE_DIR / f"{stem}-a.png")
    Image.fromarray(np.ascontiguousarray(b[..., :3])).save(FAILURE_DIR / f"{stem}-b.png")
    m = np.ones(a.shape[:2], bool) if mask is None else np.asarray(mask, bool)
    vis = np.zeros(m.shape, np.float64)
    vis[m] = de2000_map(a, b, m) * 25.0
    out = FAILURE_DIR / f"{stem}-de2000.png"
    Image.fromarray(np.clip(vis, 0, 255).astype(np.uint8)).save(out)
    return out


def assert_images_close(a: np.ndarray, b: np.ndarray, *, de_mean: float, de_p99: float,
                        mask: np.ndarray | None = None, max_levels: int | None = None,
                        name: str = "frame") -> DeStats:
    """Two uint8 sRGB frames agree: ΔE2000 mean ≤ ``de_mean`` and 99th percentile ≤ ``de_p99`` over ``mask``.

    ``max_levels``: also no channel of a pixel of ``mask`` more than that many 8-bit levels apart. On
    failure both frames and the ΔE map are written to tests/_failures. Returns the figures.
    """
    stats = de2000_stats(a, b, mask)
    levels = max_level_difference(a, b, mask)
    record(name, **asdict(stats), max_levels=levels, bound_mean=de_mean, bound_p99=de_p99,
           bound_levels=max_levels)
    if stats.mean > de_mean or stats.p99 > de_p99 or (max_levels is not None and levels > max_levels):
        where = _write_failure(name, np.asarray(a), np.asarray(b), mask)
        raise AssertionError(
            f"{name}: ΔE2000 mean {stats.mean:.4f} (bound {de_mean}), p99 {stats.p99:.3f} (bound {de_p99}), "
            f"max {stats.max:.2f} over {stats.pixels} pixels; at most {levels} 8-bit levels apart"
            f"{'' if max_levels is None else f' (bound {max_levels})'}; ΔE map: {where}")
    return stats


def assert_matches_reference(image: np.ndarray, reference: str, *, de_mean: float, de_p99: float,
                             mask: np.ndarray | None = None) -> DeStats:
    """A uint8 frame against tests/references/``reference`` with :func:`assert_images_close`'s bounds.

    ``SHEER_REGEN_REFERENCES=1`` rewrites the reference instead (a missing one fails without it).
    """
    import pytest
    from PIL import Image

    path = REFERENCE_DIR / reference
    img = np.ascontiguousarray(image)
    if os.environ.get("SHEER_REGEN_REFERENCES"):
        path.parent.mkdir(parents=True, exist_ok=True)
        Image.fromarray(img).save(path)
        return DeStats(0.0, 0.0, 0.0, int(np.prod(img.shape[:2])))
    if not path.exists():
        pytest.fail(f"no reference image {path}; run with SHEER_REGEN_REFERENCES=1 to make it")
    with Image.open(path) as im:
        ref = np.asarray(im)
    if ref.shape != img.shape:
        pytest.fail(f"image shape {img.shape} differs from reference {ref.shape} ({path})")
    return assert_images_close(img, ref, de_mean=de_mean, de_p99=de_p99, mask=mask, name=Path(reference).stem)


def assert_relative_close(got: np.ndarray, want: np.ndarray, *, rtol: float, floor: float,
                          name: str = "values") -> float:
    """Linear non-colour values (thickness, irradiance, reflectance maps) agree relatively.

    Passes when ``|got - want| <= rtol * max(|want|, floor)`` everywhere: ``floor`` keeps values near 0
    from asking for a relative precision no float format has. Returns the worst ratio of the difference
    to its bound (≤ 1 when it passes).
    """
    g = np.asarray(got, np.float64)
    w = np.asarray(want, np.float64)
    assert g.shape == w.shape, (g.shape, w.shape)
    bound = rtol * np.maximum(np.abs(w), floor)
    worst = float((np.abs(g - w) / bound).max()) if g.size else 0.0
    record(name, worst_over_bound=worst, rtol=rtol, floor=floor,
           max_rel=float((np.abs(g - w) / np.maximum(np.abs(w), floor)).max()) if g.size else 0.0)
    if not worst <= 1.0:
        i = np.unravel_index(int(np.argmax(np.abs(g - w) / bound)), g.shape)
        raise AssertionError(f"{name}: |got - want| reaches {worst:.3g}× its bound (rtol {rtol}, floor {floor}) "
                             f"at {tuple(int(x) for x in i)}: got {g[i]!r}, want {w[i]!r}")
    return worst
