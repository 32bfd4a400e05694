"""Layer masks: where a layer's thickness shows, from facial regions and a paintable channel.

A :class:`LayerMask` is a recipe — regions combined in order (``"union"`` takes the larger value,
``"subtract"`` keeps ``min(m, 1 − region)``; a recipe that starts with a subtraction starts from a full
mask, an empty recipe is the full mask), then optionally inverted, then blurred by ``feather_mm`` —
plus the layer's **paint channel**: a float32 map ``c`` in [0, 2] at the layer's resolution, neutral at
1, painted with the ordinary brushes (add reveals towards 2, erase hides towards 0, "set" to 1
restores). The mask a layer is rendered with is::

    mask = clip(recipe + c − 1, 0, 1)          # float32 in [0, 1], the layer's resolution

The renderer multiplies the layer's thickness by it (``render.binding``); the thickness map itself is
never changed by a mask, so editing the mask is lossless.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from painting.layer import DocumentError
from painting.regions import REGION_NAMES, RegionError, RegionSet, check_region_name
from painting.tiles import TILE

if TYPE_CHECKING:
    from painting.layer import Layer

MASK_OPS = ("union", "subtract")
#: The paint channel's neutral value (neither reveals nor hides) and its range's top.
CHANNEL_NEUTRAL = 1.0
CHANNEL_MAX = 2.0
#: The largest extra feather of a mask (mm).
MAX_MASK_FEATHER_MM = 50.0


@dataclass(frozen=True)
class LayerMask:
    """A layer mask's recipe (immutable; see the module docstring).

    Attributes:
        regions: ((op, region name), …) in order; op in :data:`MASK_OPS`.
        invert: show the layer where the recipe is 0.
        feather_mm: extra blur of the recipe's edge (mm, [0, :data:`MAX_MASK_FEATHER_MM`]); a Gaussian of
            σ = feather / 2 at the atlas's median texel size.
    """

    regions: tuple[tuple[str, str], ...] = ()
    invert: bool = False
    feather_mm: float = 0.0

    def validate(self, known: RegionSet | None = None) -> LayerMask:
        """Raise :class:`DocumentError` naming the bad op, region or value; return self.

        With ``known``, every region must be one this head has (the message says why it lacks one).
        """
        if not isinstance(self.regions, tuple):
            raise DocumentError(f"mask regions must be a tuple of (op, region) pairs, got {self.regions!r}")
        for item in self.regions:
            if not (isinstance(item, tuple) and len(item) == 2):
                raise DocumentError(f"mask region entry must be (op, region), got {item!r}")
            op, name = item
            if op not in MASK_OPS:
                raise DocumentError(f"mask op must be one of {', '.join(MASK_OPS)}, got {op!r}")
            try:
                check_region_name(name)
                if known is not None:
                    known.get(name)
            except RegionError as exc:
                raise DocumentError(str(exc)) from None
        try:
            f = float(self.feather_mm)
        except (TypeError, ValueError):
            raise DocumentError(f"mask feather_mm must be a number, got {self.feather_mm!r}") from None
        if not math.isfinite(f) or not 0.0 <= f <= MAX_MASK_FEATHER_MM:
            raise DocumentError(f"mask feather_mm must be in [0, {MAX_MASK_FEATHER_MM:g}] mm, got {self.feather_mm!r}")
        if not isinstance(self.invert, bool):
            raise DocumentError(f"mask invert must be true or false, got {self.invert!r}")
        return self

    def to_json(self) -> dict[str, Any]:
        """The recipe as JSON (the paint channel is stored apart)."""
        return {"regions": [[op, name] for op, name in self.regions], "invert": self.invert,
                "feather_mm": float(self.feather_mm)}

    @classmethod
    def from_json(cls, data: Any, where: str) -> LayerMask:
        """A recipe from :meth:`to_json`'s form; :class:`DocumentError` naming ``where`` when malformed."""
        if not isinstance(data, dict):
            raise DocumentError(f"{where}: a mask must be an object")
        raw = data.get("regions", [])
        if not isinstance(raw, list) or not all(isinstance(r, list) and len(r) == 2 for r in raw):
            raise DocumentError(f"{where}: mask 'regions' must be a list of [op, region] pairs")
        mask = cls(tuple((str(op), str(name)) for op, name in raw), invert=data.get("invert", False),
                   feather_mm=data.get("feather_mm", 0.0))
        try:
            return mask.validate()
        except DocumentError as exc:
            raise DocumentError(f"{where}: {exc}") from None


def recipe_values(mask: LayerMask, regions: RegionSet, resolution: int, texel_mm: float) -> np.ndarray:
    """The recipe's mask (float32 (R, R) in [0, 1]) at ``resolution`` texels of ``texel_mm`` mm.

    Kept in the disk cache (kind ``looks``) keyed by its content — the recipe, the regions' own masks,
    the resolution, the texel size and this module's and :mod:`painting.regions`' code — so a studio
    opening on a look with a mask reads it (≈ 10 ms at 2048²) instead of resampling and feathering it
    (0.5–1.8 s of the start-up, scipy's import included, issue #13). The same bits either way (tested).
    """
    from core.cache import load_array, save_array

    path = _recipe_cache_path(mask, regions, resolution, texel_mm)
    out = load_array(path, _RECIPE_CACHE_VERSION)  # None when absent or damaged
    if (out is not None and out.shape == (resolution, resolution) and out.dtype == np.float32
            and bool(np.all((out >= 0.0) & (out <= 1.0)))):
        return out
    out = _recipe_values(mask, regions, resolution, texel_mm)
    save_array(path, out, _RECIPE_CACHE_VERSION)
    return out


#: the cached recipe masks' format (:func:`recipe_values`)
_RECIPE_CACHE_VERSION = 1
#: The code that computes a recipe's values: a change of it is a new entry (:func:`core.cache.source_digest`).
_RECIPE_SOURCES: tuple[Path, ...] = (Path(__file__).with_name("mask.py"), Path(__file__).with_name("regions.py"))


def _recipe_cache_path(mask: LayerMask, regions: RegionSet, resolution: int, texel_mm: float) -> Any:
    """The cache entry of a recipe's values: a digest of everything :func:`_recipe_values` reads."""
    import hashlib
    import json

    from core.cache import cache_dir, source_digest

    h = hashlib.blake2b(digest_size=20)
    h.update(f"{source_digest(_RECIPE_SOURCES)}|{int(resolution)}|{float(texel_mm)!r}|{json.dumps(mask.to_json())}".encode())
    for name in dict.fromkeys(name for _, name in mask.regions):
        m = np.ascontiguousarray(regions.get(name).mask)
        h.update(f"|{name}|{m.dtype.str}|{m.shape}|".encode())
        h.update(m.data)  # (contiguous: hashed without a copy)
    return cache_dir("looks") / f"mask-{h.hexdigest()}-v{_RECIPE_CACHE_VERSION}.cache"


def _recipe_values(mask: LayerMask, regions: RegionSet, resolution: int, texel_mm: float) -> np.ndarray:
    """:func:`recipe_values` computed (no cache)."""
    out: np.ndarray | None = None
    for op, name in mask.regions:
        m = regions.at(name, resolution)
        if out is None:
            out = m.copy() if op == "union" else 1.0 - m
        elif op == "union":
            np.maximum(out, m, out=out)
        else:
            np.minimum(out, 1.0 - m, out=out)
    if out is None:
        out = np.ones((resolution, resolution), np.float32)
    if mask.invert:
        out = 1.0 - out
    if mask.feather_mm > 0:
        out = _feather(out, mask.feather_mm / (2.0 * texel_mm))
    return np.clip(out, 0.0, 1.0).astype(np.float32)


#: a feather wider than this many texels (Gaussian σ) is blurred on a coarser grid (see :func:`_feather`)
_COARSE_SIGMA = 4.0


def _feather(values: np.ndarray, sigma: float) -> np.ndarray:
    """``values`` (square float32) blurred by a Gaussian of ``sigma`` texels.

    A wide feather (σ > :data:`_COARSE_SIGMA` texels, e.g. a 4 mm blush edge at 2048²: σ ≈ 16) is blurred
    on a grid coarser by a power of two that keeps σ ≥ 2 coarse texels, then resampled back bilinearly
    (:func:`painting.regions.resample`, texel centres kept): the result is smooth on the fine grid's scale,
    so nothing visible is lost, and the blur costs 1/16 or less (0.62 s → under 0.05 s for the blush of
    the ``natural`` look at 2048², most of a studio start-up before).
    """
    from scipy.ndimage import gaussian_filter

    n = values.shape[0]
    factor = 1
    while sigma / (factor * 2) >= 2.0 and sigma > _COARSE_SIGMA and n % (factor * 2) == 0:
        factor *= 2
    if factor == 1:
        return gaussian_filter(values, sigma=sigma, mode="nearest")
    from painting.regions import resample

    coarse = values.reshape(n // factor, factor, n // factor, factor).mean(axis=(1, 3))
    return resample(gaussian_filter(coarse, sigma=sigma / factor, mode="nearest"), n)


def neutral_channel(resolution: int) -> np.ndarray:
    """A paint channel that neither reveals nor hides (float32 (R, R) of :data:`CHANNEL_NEUTRAL`)."""
    return np.full((resolution, resolution), CHANNEL_NEUTRAL, np.float32)


def check_channel(values: Any, layer: Layer) -> np.ndarray:
    """A paint channel for ``layer`` as a new float32 array; :class:`DocumentError` when it does not fit."""
    arr = np.asarray(values)
    if arr.shape != (layer.resolution, layer.resolution):
        got = "×".join(str(s) for s in arr.shape[::-1]) or "a scalar"
        raise DocumentError(f"mask channel of layer {layer.name!r} is {got}, the layer is "
                            f"{layer.resolution}×{layer.resolution}")
    arr = np.array(arr, dtype=np.float32)
    if not np.all(np.isfinite(arr)) or arr.min() < 0.0 or arr.max() > CHANNEL_MAX:
        raise DocumentError(f"mask channel of layer {layer.name!r} must be finite values in [0, {CHANNEL_MAX:g}]")
    return arr


class MaskChannel:
    """A layer's paint channel as a stroke target (what :class:`painting.stroke.Stroke` paints).

    Has the fields a stroke and an undo record use (``id`` — the layer's, so the renderer's paint events
    name the layer — ``name``, ``resolution``, ``data``, thickness bounds in channel units).
    """

    def __init__(self, layer: Layer, data: np.ndarray) -> None:
        self.id = layer.id
        self.name = f"{layer.name} (mask)"
        self.resolution = layer.resolution
        self.data = data
        self.max_thickness = CHANNEL_MAX
        self.default_thickness = CHANNEL_MAX  # "add" reveals fully unless the brush names an amount

    @property
    def thickness(self) -> np.ndarray:
        """The channel (read-only view)."""
        v = self.data.view()
        v.flags.writeable = False
        return v


def effective_tiles(recipe: np.ndarray | None, channel: np.ndarray | None, tiles: list[tuple[int, int]] | None
                    ) -> np.ndarray | None:
    """``clip(recipe + channel − 1, 0, 1)`` on ``tiles`` (64² (row, col)) or everywhere (``tiles`` None).

    Either input may be None (a full recipe / a neutral channel); returns None when both are (no mask).
    With ``tiles``, returns float32 (n, 64, 64); else (R, R).
    """
    if recipe is None and channel is None:
        return None
    # (a missing recipe is the full mask: 1 + c − 1 = c)

    def pick(a: np.ndarray) -> np.ndarray:
        if tiles is None:
            return a
        n = a.shape[0] // TILE
        idx = np.asarray(tiles, dtype=np.int64).reshape(-1, 2)
        return a.reshape(n, TILE, n, TILE)[idx[:, 0], :, idx[:, 1], :]

    base = pick(recipe) if recipe is not None else None
    if channel is None:
        assert base is not None
        return np.asarray(base, np.float32).copy()
    ch = pick(channel)
    # (c − 1) first: a neutral channel then leaves the recipe bit-exact
    out = ch if base is None else base + (ch - np.float32(CHANNEL_NEUTRAL))
    return np.clip(out, 0.0, 1.0).astype(np.float32)


def layer_mask_values(layer: Layer, tiles: list[tuple[int, int]] | None = None) -> np.ndarray | None:
    """The mask ``layer`` is rendered with (:func:`effective_tiles` of its recipe and channel), or None."""
    return effective_tiles(layer.mask_recipe, layer.mask_channel, tiles)


__all__ = ["CHANNEL_MAX", "CHANNEL_NEUTRAL", "MASK_OPS", "REGION_NAMES", "LayerMask", "MaskChannel",
           "check_channel", "effective_tiles", "layer_mask_values", "neutral_channel", "recipe_values"]
