"""Named facial regions in a head's paint UV space: soft masks with a feathered edge in mm, and their source.

A region is a float32 mask in [0, 1] over the paint atlas's texels (top row first, the convention of
:mod:`painting.head`), stored at :data:`REGION_RESOLUTION`² and resampled (bilinear) to a layer's
resolution on use. Its edge is a linear ramp ``feather_mm`` wide (3D surface distance, through the
atlas's local texel size) centred on the hard outline, so the mask reaches 0 half a feather outside it.

Where regions come from (:func:`painting.region_shapes.regions_for`):

- a head whose sidecar ships region files (``<sidecar stem>.regions.png`` beside it, e.g. the sample
  head in ``resources/heads/``): read from there (rebuilt byte-exactly by ``scripts/build_head_regions.py``);
- a head embedded in a project (no files on disk): the shipped region file that records the same mesh
  (:func:`mesh_digest` of its vertices, faces and UVs), so a self-contained project of the sample head
  paints with the very masks of the same project with the head by path;
- a face-mesh head (MediaPipe's 468/478-point topology, e.g. the canonical face): from its lip, eye and
  brow contours (:mod:`painting.region_shapes`), exact for every such face;
- any other head with the sidecar's landmarks: from the landmarks and the geometry;
- otherwise: none; :class:`RegionSet.missing` names each region that could not be derived and why, and
  :meth:`RegionSet.get` says so (paint a layer mask by hand instead).

Region names: :data:`REGION_NAMES`.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from core.errors import SheerError

if TYPE_CHECKING:
    from pathlib import Path

    from painting.atlas import Atlas

#: Texels per side of a stored region mask.
REGION_RESOLUTION = 1024
#: Every region Sheer knows, with what it covers.
REGION_NAMES: dict[str, str] = {
    "upper_lip": "the upper lip's vermilion (red part), without the inner mouth",
    "lower_lip": "the lower lip's vermilion",
    "lips": "both lips' vermilion",
    "lip_line": "a band 1.5 mm wide on the vermilion border (for liner)",
    "eyes": "the eye opening / lash line (closed lids: the lid margin)",
    "lash_line": "the upper lash line: a band on the upper lid's margin, widening outwards (for liner)",
    "upper_eyelid": "the mobile lid, from the lash line to the crease",
    "crease": "the crease band above the mobile lid",
    "brow_bone": "between the crease and the brows",
    "under_eye": "the crescent under the lower lash line",
    "brows": "the eyebrows",
    "cheek_apple": "the apple of the cheek",
    "cheekbone": "from the apple up and out along the cheekbone to the temple",
    "nose_bridge": "the bridge of the nose, nasion to above the tip",
    "forehead": "the forehead, brows to hairline",
    "t_zone": "forehead, nose and chin",
    "jawline": "a band along the jaw from ear to chin",
    "inner_mouth": "inside the mouth: a face mesh's mouth opening (over the teeth when she smiles), the lips' "
                   "hidden inner curl; no transferred layer paints it",
    "skin": "the facial skin as a whole, without the lips, eyes, brows and the inner mouth",
}
#: Default feather (full ramp width, mm) per region.
DEFAULT_FEATHER_MM: dict[str, float] = {
    "upper_lip": 0.5, "lower_lip": 0.5, "lips": 0.5, "lip_line": 0.5, "eyes": 1.0, "lash_line": 0.5,
    "upper_eyelid": 1.0, "crease": 1.0, "brow_bone": 3.0, "under_eye": 3.0, "brows": 1.5, "cheek_apple": 10.0, "cheekbone": 10.0,
    "nose_bridge": 3.0, "forehead": 6.0, "t_zone": 6.0, "jawline": 6.0, "skin": 3.0, "inner_mouth": 0.5,
}
#: Bump when the stored region format changes.
REGIONS_FORMAT_VERSION = 1


class RegionError(SheerError, ValueError):
    """An unknown region, a region this head lacks, or a malformed region file; the message names it."""


@dataclass(frozen=True)
class Region:
    """One soft mask.

    Attributes:
        name: a key of :data:`REGION_NAMES`.
        mask: float32 (R, R) in [0, 1], paint UV space, top row first (read-only).
        feather_mm: the edge ramp's full width (mm, ≥ 0).
        source: how it was made (landmarks, contour indices, albedo edge…), for the user.
    """

    name: str
    mask: np.ndarray
    feather_mm: float
    source: str


@dataclass
class RegionSet:
    """A head's regions, and the ones it could not get.

    Attributes:
        regions: name → :class:`Region`.
        missing: name → why it could not be derived.
        head_name: the head's display name (for messages).
        mesh: the :func:`mesh_digest` of the head they were derived on ("" when unknown).
    """

    regions: dict[str, Region] = field(default_factory=dict)
    missing: dict[str, str] = field(default_factory=dict)
    head_name: str = ""
    #: :func:`mesh_digest` of the head the regions were derived on ("" when unknown)
    mesh: str = ""
    _resampled: dict[tuple[str, int], np.ndarray] = field(default_factory=dict, repr=False)

    def names(self) -> list[str]:
        """The regions this head has, in :data:`REGION_NAMES` order."""
        return [n for n in REGION_NAMES if n in self.regions]

    def get(self, name: str) -> Region:
        """The region ``name``; :class:`RegionError` naming the known ones, or why this head lacks it."""
        check_region_name(name)
        if name not in self.regions:
            why = self.missing.get(name, "not derived")
            raise RegionError(f"head '{self.head_name}' has no region '{name}': {why}; paint a layer mask "
                              f"by hand instead (it has: {', '.join(self.names()) or 'none'})")
        return self.regions[name]

    def at(self, name: str, resolution: int) -> np.ndarray:
        """Region ``name`` resampled to ``resolution``² texels (float32 [0, 1], read-only, cached)."""
        key = (name, int(resolution))
        if key not in self._resampled:
            out = resample(self.get(name).mask, int(resolution))
            out.flags.writeable = False
            self._resampled[key] = out
        return self._resampled[key]

    def missing_message(self) -> str:
        """One line naming the regions that could not be derived (empty when none)."""
        if not self.missing:
            return ""
        parts = [f"{n} ({why})" for n, why in self.missing.items()]
        return f"head '{self.head_name}': regions not derived: {'; '.join(parts)}"


def mesh_digest(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray) -> str:
    """Hex SHA-256 of a mesh's geometry and UVs (float64 / int64, little-endian): which mesh regions fit."""
    import hashlib

    h = hashlib.sha256()
    for arr, dtype in ((vertices, "<f8"), (faces, "<i8"), (uv, "<f8")):
        a = np.ascontiguousarray(arr, dtype=dtype)
        h.update(str(a.shape).encode() + a.tobytes())
    return h.hexdigest()


def check_region_name(name: object) -> str:
    """``name`` if it is a known region; else :class:`RegionError` listing them."""
    if not isinstance(name, str) or name not in REGION_NAMES:
        raise RegionError(f"unknown region {name!r} (known: {', '.join(REGION_NAMES)})")
    return name


def resample(mask: np.ndarray, resolution: int) -> np.ndarray:
    """A square float mask resampled to ``resolution``² by bilinear interpolation at texel centres.

    Texel centres keep the convention of :mod:`painting.head` (texel ``i`` covers ``[i/R, (i+1)/R)``),
    so a mask lands on the same surface at every resolution. Returns float32 in the input's range.
    """
    src = np.asarray(mask, dtype=np.float32)
    n = src.shape[0]
    if n == resolution:
        return src.copy()
    # Texel-centre coordinates of the target in source texels (scipy's map_coordinates would do the
    # same at 3× the cost for this separable case).
    c = (np.arange(resolution, dtype=np.float64) + 0.5) * (n / resolution) - 0.5
    c = np.clip(c, 0.0, n - 1.0)
    i0 = np.floor(c).astype(np.int64)
    i1 = np.minimum(i0 + 1, n - 1)
    f = (c - i0).astype(np.float32)
    rows = src[i0] * (1 - f)[:, None] + src[i1] * f[:, None]
    # the column pass on the transpose: gathering whole rows is a copy of contiguous memory, gathering
    # columns a strided walk (6× slower at 2048²); the same arithmetic, so the same bits
    cols = np.ascontiguousarray(rows.T)
    out = cols[i0] * (1 - f)[:, None] + cols[i1] * f[:, None]
    return np.ascontiguousarray(out.T, dtype=np.float32)


def local_texel_mm(atlas: Atlas) -> np.ndarray:
    """Per-texel size in mm (float64 (R, R)): the 3D step to the next texel, median over a 5² window.

    Texels not covered take the atlas's median texel size.
    """
    pos = atlas.position.astype(np.float64)
    cov = atlas.coverage
    dx = np.zeros(cov.shape)
    dy = np.zeros(cov.shape)
    dx[:, :-1] = np.linalg.norm(pos[:, 1:] - pos[:, :-1], axis=2)
    dy[:-1, :] = np.linalg.norm(pos[1:, :] - pos[:-1, :], axis=2)
    okx = np.zeros(cov.shape, bool)
    oky = np.zeros(cov.shape, bool)
    okx[:, :-1] = cov[:, 1:] & cov[:, :-1]
    oky[:-1, :] = cov[1:, :] & cov[:-1, :]
    step = np.where(okx & oky, 0.5 * (dx + dy), np.where(okx, dx, np.where(oky, dy, np.nan)))
    step *= atlas.mm_per_unit
    step = np.where(np.isfinite(step) & (step > 0), step, atlas.texel_mm)
    # A step across a UV seam is a jump on the surface: cap at 4 texels' worth.
    step = np.minimum(step, 4.0 * atlas.texel_mm)
    return median_filter(step, 5)


def median_filter(values: np.ndarray, size: int, rows: int = 64) -> np.ndarray:
    """``scipy.ndimage.median_filter(values, size=size)`` of a 2D float array without NaNs, in a third of its time.

    Its default ``reflect`` edges; each texel's window sorted in part by ``np.partition``, in blocks of
    ``rows`` rows. ``size`` odd: the median is one of the window's values, so the result is the same.
    """
    from numpy.lib.stride_tricks import sliding_window_view

    r = size // 2
    src = np.asarray(values, dtype=np.float64)
    padded = np.pad(src, r, mode="symmetric")  # scipy's "reflect"
    out = np.empty_like(src)
    mid = size * size // 2
    for i in range(0, len(src), rows):
        windows = sliding_window_view(padded[i:i + rows + 2 * r], (size, size))
        flat = windows.reshape(windows.shape[0], windows.shape[1], size * size)
        out[i:i + rows] = np.partition(flat, mid, axis=-1)[..., mid]
    return out


def signed_distance(inside: np.ndarray, reach: int) -> tuple[tuple[slice, slice], np.ndarray]:
    """Signed Euclidean distance in texels to the outline of ``inside`` (bool, not empty), on a window.

    The distance is ``d_in − 0.5`` inside (``d_in``: texels to the nearest outside texel) and
    ``0.5 − d_out`` outside (``d_out``: to the nearest inside texel), as
    ``scipy.ndimage.distance_transform_edt`` gives them on the whole array. Computed on the window of
    ``inside``'s bounding box grown by ``reach`` (≥ 1) texels: the same values there (every inside
    texel lies in the window, and an outside texel beyond it is no nearer than the window's border ring,
    which is outside), and every texel beyond it is outside, more than ``reach`` texels from the outline.

    Returns:
        The window (row and column slices) and the signed distances on it (float64).
    """
    from scipy.ndimage import distance_transform_edt

    rows = np.flatnonzero(inside.any(axis=1))
    cols = np.flatnonzero(inside.any(axis=0))
    reach = max(int(reach), 1)
    win = (slice(max(int(rows[0]) - reach, 0), min(int(rows[-1]) + reach + 1, inside.shape[0])),
           slice(max(int(cols[0]) - reach, 0), min(int(cols[-1]) + reach + 1, inside.shape[1])))
    part = inside[win]
    d_in = distance_transform_edt(part)  # inside: texels to the nearest outside texel
    d_out = distance_transform_edt(~part)
    return win, np.where(part, d_in - 0.5, 0.5 - d_out)


def reach_texels(reach_mm: float, texel_mm: np.ndarray | float) -> int:
    """Texels that surely span ``reach_mm`` of surface (with two to spare) at the smallest texel size."""
    smallest = float(np.min(texel_mm))
    if not np.isfinite(smallest) or smallest <= 0:
        return 1 << 30  # no bound: the window is the whole array
    return min(int(np.ceil(reach_mm / smallest)) + 2, 1 << 30)


def feather(hard: np.ndarray, feather_mm: float, texel_mm: np.ndarray) -> np.ndarray:
    """A hard mask's soft version: a linear ramp ``feather_mm`` wide centred on its outline.

    Distances are Euclidean in texels (``scipy.ndimage.distance_transform_edt``) times the local texel
    size ``texel_mm`` (mm per texel). Returns float32 in [0, 1]; 1 deep inside, 0 beyond
    ``feather_mm / 2`` outside. ``feather_mm = 0`` gives the hard mask.

    The distances are computed near the mask only (:func:`signed_distance`): a texel farther outside
    than half the feather is 0 either way.
    """
    inside = np.asarray(hard, dtype=bool)
    if not inside.any():
        return np.zeros(inside.shape, np.float32)
    if feather_mm <= 0:
        return inside.astype(np.float32)
    texel = np.broadcast_to(np.asarray(texel_mm, dtype=np.float64), inside.shape)
    win, signed_texels = signed_distance(inside, reach_texels(0.5 * feather_mm, texel))
    signed = signed_texels * texel[win]  # mm, + inside
    out = np.zeros(inside.shape, np.float32)
    out[win] = np.clip(0.5 + signed / feather_mm, 0.0, 1.0).astype(np.float32)
    return out


def spread_to_padding(mask: np.ndarray, atlas: Atlas) -> np.ndarray:
    """``mask`` (at the atlas's resolution) with every padding texel copying its source texel."""
    out = np.array(mask, dtype=np.float32)
    flat = out.reshape(-1)
    if len(atlas.pad_dst):
        flat[atlas.pad_dst] = flat[atlas.pad_src]
    flat[~(atlas.coverage | atlas.padded).reshape(-1)] = 0.0
    return out


# ------------------------------------------------------------------------------------- files
def stored_mesh(path: Path) -> str:
    """The :func:`mesh_digest` a region file records ("" when none, or the file is unreadable).

    Reads the PNG's text chunk only (written before the pixels), not the masks.
    """
    from PIL import Image

    try:
        with Image.open(path) as im:
            text = im.text.get("sheer-regions", "") if hasattr(im, "text") else ""
        return str(json.loads(text).get("mesh", "")) if text else ""
    except Exception:  # Pillow and json raise many types for bad files: then it records nothing
        return ""


def regions_file(sidecar: Path) -> Path:
    """Where a sidecar's region masks are stored: ``<sidecar stem>.regions.png`` beside it."""
    return sidecar.with_name(sidecar.stem + ".regions.png")


def encode_regions(regions: RegionSet) -> bytes:
    """The regions as one 8-bit greyscale PNG: the masks stacked top to bottom, names and metadata in a text chunk.

    Deterministic (no timestamps; fixed zlib level), so a rebuild gives the same bytes.
    """
    from PIL import Image, PngImagePlugin

    names = regions.names()
    if not names:
        raise RegionError("no regions to store")
    stack = np.concatenate([np.round(regions.regions[n].mask * 255.0).astype(np.uint8) for n in names], axis=0)
    meta = {"format": REGIONS_FORMAT_VERSION, "resolution": int(regions.regions[names[0]].mask.shape[0]),
            "regions": [{"name": n, "feather_mm": regions.regions[n].feather_mm,
                         "source": regions.regions[n].source} for n in names],
            "missing": regions.missing}
    if regions.mesh:
        meta["mesh"] = regions.mesh
    info = PngImagePlugin.PngInfo()
    info.add_text("sheer-regions", json.dumps(meta, sort_keys=True))
    buf = io.BytesIO()
    Image.fromarray(stack, mode="L").save(buf, format="PNG", pnginfo=info, optimize=False, compress_level=9)
    return buf.getvalue()


def decode_regions(blob: bytes, where: str, head_name: str = "") -> RegionSet:
    """The :class:`RegionSet` of :func:`encode_regions`'s bytes; ``where`` names the file in messages."""
    from PIL import Image

    try:
        with Image.open(io.BytesIO(blob)) as im:
            text = im.text.get("sheer-regions") if hasattr(im, "text") else None
            pixels = np.asarray(im.convert("L"))
    except Exception as exc:  # Pillow raises many types for bad files
        raise RegionError(f"{where}: cannot read region masks: {exc}") from None
    try:
        meta = json.loads(text or "")
        res = int(meta["resolution"])
        entries = list(meta["regions"])
        if meta.get("format") != REGIONS_FORMAT_VERSION:
            raise ValueError(f"format {meta.get('format')!r} is not {REGIONS_FORMAT_VERSION}")
    except (ValueError, KeyError, TypeError) as exc:
        raise RegionError(f"{where}: region metadata is missing or malformed: {exc}") from None
    if pixels.shape != (res * len(entries), res):
        raise RegionError(f"{where}: region image is {pixels.shape[1]}×{pixels.shape[0]}, expected "
                          f"{res}×{res * len(entries)} for {len(entries)} regions of {res}²")
    out = RegionSet(head_name=head_name, missing={str(k): str(v) for k, v in dict(meta.get("missing", {})).items()},
                    mesh=str(meta.get("mesh", "")))
    for i, e in enumerate(entries):
        name = check_region_name(e.get("name"))
        mask = (pixels[i * res:(i + 1) * res].astype(np.float32) / np.float32(255.0))
        mask.flags.writeable = False
        out.regions[name] = Region(name, mask, float(e.get("feather_mm", 0.0)), str(e.get("source", "")))
    return out


def region_fit(thickness: np.ndarray, mask: np.ndarray, texel_mm: np.ndarray | float, amount_um: float,
               dilate_mm: float = 0.5) -> tuple[float, float]:
    """How well a layer keeps to a region: (fraction outside, coverage).

    Args:
        thickness: the layer's map (µm, (R, R)).
        mask: the region at the same resolution (float [0, 1]); its outline is ``mask ≥ 0.5``.
        texel_mm: texel size (mm), one number or per texel.
        amount_um: the thickness the region should be filled to (µm, > 0).
        dilate_mm: how far beyond the outline thickness still counts as inside (mm).

    Returns:
        The fraction of the layer's total thickness lying more than ``dilate_mm`` outside the outline,
        and the fraction of the outline's texels holding at least 45 % of ``amount_um`` (the outline
        itself sits mid-feather, at 50 %).
    """
    from scipy.ndimage import distance_transform_edt

    inside = np.asarray(mask) >= 0.5
    t = np.asarray(thickness, dtype=np.float64)
    total = float(t.sum())
    near = (distance_transform_edt(~inside) - 0.5) * texel_mm <= dilate_mm
    outside = float(t[~near].sum()) / total if total > 0 else 0.0
    coverage = float(np.mean(t[inside] >= 0.45 * amount_um)) if inside.any() else 0.0
    return outside, coverage
