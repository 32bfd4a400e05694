"""Stand-ins used by the studio only while the real packages are not available in this build.

The real model lives in ``km`` (materials, optics) and ``painting`` (the document). Until those land, the
studio runs on these small, honest stand-ins with the same shape of API (see :mod:`app.seams`):

- :class:`FallbackMaterial`, :class:`FallbackLibrary`: a few *modelled* cosmetics (no measured spectra).
- Kubelka–Munk maths (:func:`km_layer_rt`, :func:`km_r_inf`) after Kubelka & Munk (hyperbolic solution).
- :class:`FallbackDocument`: layers of thickness maps in UV space, painted with 3D spherical dabs through
  a baked texel-position map, one undo step per stroke stored as 64² tile deltas.

No Qt here: the UI talks to these through :mod:`app.seams` exactly as it talks to the real ones.
"""

from __future__ import annotations

import contextlib
import copy
import json
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from km.errors import SheerError

WAVELENGTHS = np.arange(400.0, 701.0, 10.0)
TILE = 64
BLOCK = 16


class FallbackLibraryError(SheerError, ValueError):
    """A library edit or import that cannot be done."""


def km_r_inf(S: np.ndarray, K: np.ndarray) -> np.ndarray:
    """R∞ of an infinitely thick layer (S, K per mm)."""
    ks = np.asarray(K, float) / np.maximum(np.asarray(S, float), 1e-9)
    return 1.0 + ks - np.sqrt(ks * ks + 2.0 * ks)


def km_layer_rt(S: np.ndarray, K: np.ndarray, x_mm: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Reflectance and transmittance of a layer of thickness ``x_mm`` (broadcast, wavelengths last)."""
    S = np.maximum(np.asarray(S, float), 1e-9)
    K = np.maximum(np.asarray(K, float), 0.0)
    x = np.asarray(x_mm, float)
    a = 1.0 + K / S
    b = np.sqrt(np.maximum(a * a - 1.0, 1e-12))
    bsx = np.minimum(b * S * x, 50.0)
    sh, ch = np.sinh(bsx), np.cosh(bsx)
    den = a * sh + b * ch
    return sh / den, b / den


def _lobe(w: np.ndarray, mu: float, s1: float, s2: float) -> np.ndarray:
    return np.exp(-0.5 * ((w - mu) / np.where(w < mu, s1, s2)) ** 2)


def cie_xyz_cmf(w: np.ndarray) -> np.ndarray:
    """CIE 1931 2° colour-matching functions, the analytic multi-lobe fit of Wyman, Sloan & Shirley (2013);
    shape (..., 3) for wavelengths ``w`` in nm."""
    w = np.asarray(w, float)
    x = 1.056 * _lobe(w, 599.8, 37.9, 31.0) + 0.362 * _lobe(w, 442.0, 16.0, 26.7) - 0.065 * _lobe(w, 501.1, 20.4, 26.2)
    y = 0.821 * _lobe(w, 568.8, 46.9, 40.5) + 0.286 * _lobe(w, 530.9, 16.3, 31.1)
    z = 1.217 * _lobe(w, 437.0, 11.8, 36.0) + 0.681 * _lobe(w, 459.0, 26.0, 13.8)
    return np.stack([x, y, z], axis=-1)


_XYZ_TO_SRGB = np.array([[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]])
_RGB_MATRICES: dict[bytes, np.ndarray] = {}


def spectrum_to_rgb(spectrum: np.ndarray, wavelengths: np.ndarray = WAVELENGTHS) -> np.ndarray:
    """Linear sRGB of a reflectance spectrum, white-balanced so that a perfect reflector is (1, 1, 1).

    Fast and dependency-free (the studio calls it for every swatch and look-up table): the analytic CIE
    fit above under an equal-energy illuminant, then a von Kries scaling in RGB. ``km.colour`` is the
    reference; this agrees with it to within a few ΔE on cosmetic colours."""
    w = np.asarray(wavelengths, float)
    key = w.tobytes()
    m = _RGB_MATRICES.get(key)
    if m is None:
        cmf = cie_xyz_cmf(w)
        weights = np.gradient(w)[:, None] if w.size > 1 else np.ones((1, 1))
        m = (cmf * weights) @ _XYZ_TO_SRGB.T  # (n, 3): spectrum → unbalanced linear RGB
        m = m / m.sum(axis=0, keepdims=True)  # white → (1, 1, 1)
        _RGB_MATRICES[key] = m
    return np.clip(np.asarray(spectrum, float) @ m, 0.0, 1.0)


def _smooth_spectrum(rgb: tuple[float, float, float]) -> np.ndarray:
    w = WAVELENGTHS
    r, g, b = rgb
    blue = np.exp(-(((w - 450.0) / 45.0) ** 2))
    green = np.exp(-(((w - 540.0) / 45.0) ** 2))
    red = 1.0 / (1.0 + np.exp(-(w - 590.0) / 15.0))
    spec = b * blue + g * green + r * red
    return np.clip(spec, 0.02, 0.95)


@dataclass
class FallbackMaterial:
    """A cosmetic material: S and K per mm at ``wavelengths`` (nm); thicknesses in µm."""

    name: str
    category: str
    wavelengths: np.ndarray
    S: np.ndarray
    K: np.ndarray
    thickness_um: float = 10.0
    max_thickness_um: float = 40.0
    roughness: float = 0.4
    ior: float = 1.45
    measurement: Any = None
    source: str = "modelled"
    provenance: str = "modelled by the studio's stand-in library (not measured)"

    def replace(self, **changes: Any) -> FallbackMaterial:
        m = copy.deepcopy(self)
        for k, v in changes.items():
            if not hasattr(m, k):
                raise TypeError(f"Material has no field {k}")
            setattr(m, k, v)
        return m

    @classmethod
    def modelled(cls, name: str, category: str, rgb: tuple[float, float, float], s_per_mm: float,
                 default_um: float, max_um: float, roughness: float) -> FallbackMaterial:
        r_inf = _smooth_spectrum(rgb)
        ks = (1.0 - r_inf) ** 2 / (2.0 * r_inf)
        S = np.full_like(WAVELENGTHS, s_per_mm)
        return cls(name, category, WAVELENGTHS.copy(), S, ks * S, default_um, max_um, roughness)

    def r_inf(self) -> np.ndarray:
        return km_r_inf(self.S, self.K)


class FallbackLibrary:
    """A small in-memory library of modelled materials with the operations the studio uses."""

    def __init__(self, materials: list[FallbackMaterial] | None = None, path: Path | None = None) -> None:
        self._materials: dict[str, FallbackMaterial] = {m.name: m for m in materials or []}
        self.path = path

    @classmethod
    def default(cls) -> FallbackLibrary:
        m = FallbackMaterial.modelled
        return cls([
            m("Foundation Ivory", "foundation", (0.80, 0.62, 0.50), 60.0, 12.0, 40.0, 0.35),
            m("Foundation Beige", "foundation", (0.70, 0.50, 0.38), 60.0, 12.0, 40.0, 0.35),
            m("Foundation Honey", "foundation", (0.60, 0.40, 0.27), 60.0, 12.0, 40.0, 0.35),
            m("Lipstick Classic Red", "lipstick", (0.62, 0.05, 0.07), 25.0, 15.0, 40.0, 0.2),
            m("Lipstick Pink", "lipstick", (0.65, 0.25, 0.32), 25.0, 15.0, 40.0, 0.25),
            m("Lipstick Berry", "lipstick", (0.35, 0.08, 0.18), 25.0, 15.0, 40.0, 0.25),
            m("Blush Peach", "blush", (0.85, 0.45, 0.35), 30.0, 6.0, 25.0, 0.5),
            m("Blush Berry", "blush", (0.75, 0.30, 0.35), 30.0, 6.0, 25.0, 0.5),
            m("Eyeshadow Bronze", "eyeshadow", (0.45, 0.28, 0.15), 40.0, 8.0, 30.0, 0.45),
            m("Eyeshadow Plum", "eyeshadow", (0.30, 0.15, 0.25), 40.0, 8.0, 30.0, 0.45),
        ])

    def names(self) -> list[str]:
        return list(self._materials)

    def __iter__(self) -> Iterator[FallbackMaterial]:
        return iter(list(self._materials.values()))

    def __len__(self) -> int:
        return len(self._materials)

    def __contains__(self, name: object) -> bool:
        return name in self._materials

    def get(self, name: str) -> FallbackMaterial:
        try:
            return self._materials[name]
        except KeyError:
            raise FallbackLibraryError(f"no material named '{name}' in the library") from None

    def add(self, material: FallbackMaterial, *, replace: bool = False) -> FallbackMaterial:
        if replace and material.name in self._materials:
            self._materials[material.name] = material
            return material
        if material.name in self._materials:
            raise FallbackLibraryError(f"a material named '{material.name}' already exists")
        self._materials[material.name] = material
        return material

    def remove(self, name: str) -> FallbackMaterial:
        return self._materials.pop(self.get(name).name)

    def rename(self, old: str, new: str) -> FallbackMaterial:
        if new in self._materials:
            raise FallbackLibraryError(f"a material named '{new}' already exists")
        m = self.get(old).replace(name=new)
        self._materials = {(new if k == old else k): (m if k == old else v) for k, v in self._materials.items()}
        return m

    def duplicate(self, name: str, new_name: str) -> FallbackMaterial:
        m = copy.deepcopy(self.get(name))
        m.name = new_name
        self.add(m)
        return m

    def save(self, path: Path | None = None) -> Path:
        from km.atomicio import atomic_write_text

        target = Path(path or self.path or "library.json")
        data = {"schema_version": 1, "materials": [
            {"name": m.name, "category": m.category, "wavelengths_nm": m.wavelengths.tolist(),
             "S_per_mm": m.S.tolist(), "K_per_mm": m.K.tolist(), "thickness_um": m.thickness_um,
             "max_thickness_um": m.max_thickness_um, "roughness": m.roughness, "ior": m.ior}
            for m in self]}
        atomic_write_text(target, json.dumps(data, indent=1))
        return target


# ----------------------------------------------------------------------------------------- the document

@dataclass
class FallbackBrush:
    radius_mm: float = 8.0
    hardness: float = 0.5
    strength: float = 1.0
    mode: str = "add"
    mirror: bool = False


@dataclass
class FallbackLayer:
    name: str
    material: str
    thickness: np.ndarray
    visible: bool = True
    opacity: float = 1.0
    max_thickness: float = 40.0


@dataclass
class ChangeEvent:
    """What changed: ``kind`` in {"paint", "layers", "material"}; ``tiles`` (row, col) touched per layer."""

    kind: str
    layer: int | None = None
    tiles: list[tuple[int, int]] = field(default_factory=list)


def _bake_positions(head: Any, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-texel 3D positions (mesh units) and coverage, by rasterising every triangle in UV space
    (vectorised over triangles; texels within a small margin of a triangle count as covered)."""
    pos = np.zeros((size, size, 3), np.float32)
    cov = np.zeros((size, size), bool)
    uv = head.uv[head.faces] * size - 0.5  # (F, 3, 2)
    tri3 = head.vertices[head.faces]  # (F, 3, 3)
    lo = np.clip(np.floor(uv.min(axis=1)), 0, size - 1).astype(int)
    hi = np.clip(np.ceil(uv.max(axis=1)), 0, size - 1).astype(int)
    ext = (hi - lo + 1).max(axis=1)
    x0, y0 = uv[:, 0, 0], uv[:, 0, 1]
    x1, y1 = uv[:, 1, 0], uv[:, 1, 1]
    x2, y2 = uv[:, 2, 0], uv[:, 2, 1]
    den = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
    ok = np.abs(den) > 1e-12
    for k in np.unique(ext):
        sel = np.nonzero((ext == k) & ok)[0]
        if sel.size == 0:
            continue
        for chunk in np.array_split(sel, max(1, sel.size * k * k // 2_000_000 + 1)):
            g = np.arange(k)
            xs = lo[chunk, 0, None, None] + g[None, None, :]
            ys = lo[chunk, 1, None, None] + g[None, :, None]
            xs, ys = np.broadcast_arrays(xs, ys)
            c_ = chunk[:, None, None]
            a = ((y1[c_] - y2[c_]) * (xs - x2[c_]) + (x2[c_] - x1[c_]) * (ys - y2[c_])) / den[c_]
            b = ((y2[c_] - y0[c_]) * (xs - x2[c_]) + (x0[c_] - x2[c_]) * (ys - y2[c_])) / den[c_]
            c = 1.0 - a - b
            inside = (a >= -0.02) & (b >= -0.02) & (c >= -0.02) & (xs < size) & (ys < size)
            fi, gy, gx = np.nonzero(inside)
            t = tri3[chunk[fi]]
            p = a[fi, gy, gx, None] * t[:, 0] + b[fi, gy, gx, None] * t[:, 1] + c[fi, gy, gx, None] * t[:, 2]
            yy, xx = ys[fi, gy, gx], xs[fi, gy, gx]
            pos[yy, xx] = p
            cov[yy, xx] = True
    return pos, cov


class FallbackDocument:
    """Layers of thickness maps painted in 3D (see the module docstring)."""

    def __init__(self, head: Any, resolution: int = 512) -> None:
        self.head = head
        self.resolution = resolution
        self.position, self.coverage = _bake_positions(head, resolution)
        nb = resolution // BLOCK
        pos = self.position.reshape(nb, BLOCK, nb, BLOCK, 3)
        cov = self.coverage.reshape(nb, BLOCK, nb, BLOCK, 1)
        self._bmin = np.where(cov, pos, np.inf).min(axis=(1, 3))
        self._bmax = np.where(cov, pos, -np.inf).max(axis=(1, 3))
        self.layers: list[FallbackLayer] = []
        self._undo: list[tuple[str, Any]] = []
        self._redo: list[tuple[str, Any]] = []
        self._subs: list[Callable[[ChangeEvent], None]] = []

    def blocks_near(self, q: np.ndarray, r: float) -> list[tuple[slice, slice]]:
        """Slices of the BLOCK² texel blocks whose 3D bounding box is within ``r`` of ``q``."""
        gap = np.maximum(np.maximum(self._bmin - q, q - self._bmax), 0.0)
        near = np.nonzero(np.sum(gap * gap, axis=-1) <= r * r)
        return [(slice(i * BLOCK, (i + 1) * BLOCK), slice(j * BLOCK, (j + 1) * BLOCK)) for i, j in zip(*near)]

    def front_point(self, x: float, y: float, cell: float = 0.02) -> np.ndarray | None:
        """The front-most covered surface point near (x, y) seen along −Z (from the face)."""
        if not hasattr(self, "_front"):
            p = self.position[self.coverage]
            ij = np.floor(p[:, :2] / cell).astype(np.int64)
            key = (ij[:, 1] + 100_000) * 200_000 + (ij[:, 0] + 100_000)
            order = np.lexsort((p[:, 2], key))
            key_sorted = key[order]
            last = np.r_[key_sorted[1:] != key_sorted[:-1], True]
            self._front = (key_sorted[last], p[order][last])
        keys, pts = self._front
        k = (int(np.floor(y / cell)) + 100_000) * 200_000 + (int(np.floor(x / cell)) + 100_000)
        i = int(np.searchsorted(keys, k))
        if i >= len(keys) or keys[i] != k:
            return None
        return pts[i].astype(float)

    @classmethod
    def from_head(cls, path: str | Path | None = None, resolution: int = 512) -> FallbackDocument:
        from painting.head import load_head

        return cls(load_head(path), resolution)

    # events
    def subscribe(self, callback: Callable[[ChangeEvent], None]) -> Callable[[], None]:
        self._subs.append(callback)
        return lambda: self._subs.remove(callback) if callback in self._subs else None

    def _emit(self, event: ChangeEvent) -> None:
        for cb in list(self._subs):
            cb(event)

    # undoable commands
    def _push(self, kind: str, data: Any) -> None:
        self._undo.append((kind, data))
        self._redo.clear()
        if len(self._undo) > 200:
            self._undo.pop(0)

    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        return bool(self._redo)

    def add_layer(self, material: str, resolution: int | None = None, name: str | None = None,
                  max_thickness: float = 40.0) -> FallbackLayer:
        layer = FallbackLayer(name or material, material, np.zeros((self.resolution,) * 2, np.float32),
                              max_thickness=max_thickness)
        self.layers.append(layer)
        self._push("layers", self._snapshot_layers(exclude=layer))
        self._emit(ChangeEvent("layers"))
        return layer

    def _snapshot_layers(self, exclude: FallbackLayer | None = None) -> list[FallbackLayer]:
        return [lay for lay in self.layers if lay is not exclude]

    def _set_layers_state(self, state: list[tuple[FallbackLayer, dict[str, Any]]]) -> None:
        self.layers = [lay for lay, _ in state]
        for lay, attrs in state:
            for k, v in attrs.items():
                setattr(lay, k, v)

    def _layer_state(self) -> list[tuple[FallbackLayer, dict[str, Any]]]:
        keys = ("name", "material", "visible", "opacity", "max_thickness")
        return [(lay, {k: getattr(lay, k) for k in keys}) for lay in self.layers]

    def edit_layers(self, change: Callable[[], None]) -> None:
        """Run ``change`` (which edits layer order or attributes) as one undoable step."""
        before = self._layer_state()
        change()
        self._undo.append(("state", before))
        self._redo.clear()
        self._emit(ChangeEvent("layers"))

    def remove_layer(self, index: int) -> None:
        self.edit_layers(lambda: self.layers.pop(index))

    def move_layer(self, src: int, dst: int) -> None:
        def change() -> None:
            lay = self.layers.pop(src)
            self.layers.insert(dst, lay)
        self.edit_layers(change)

    def set_layer(self, index: int, **attrs: Any) -> None:
        def change() -> None:
            for k, v in attrs.items():
                setattr(self.layers[index], k, v)
        self.edit_layers(change)

    def set_thickness(self, layer: FallbackLayer, values: np.ndarray) -> None:
        """Replace the whole map (one undo step)."""
        if values.shape != layer.thickness.shape:
            raise SheerError(f"map is {values.shape}, the layer {layer.thickness.shape}")
        with self.stroke(layer, FallbackBrush()) as s:
            s._remember(slice(0, values.shape[0]), slice(0, values.shape[1]))
            layer.thickness[...] = np.clip(values, 0.0, layer.max_thickness)
        self._emit(ChangeEvent("layers"))

    def clear_history(self) -> None:
        self._undo.clear()
        self._redo.clear()

    def undo(self) -> None:
        self._swap(self._undo, self._redo)

    def redo(self) -> None:
        self._swap(self._redo, self._undo)

    def _swap(self, src: list[tuple[str, Any]], dst: list[tuple[str, Any]]) -> None:
        if not src:
            return
        kind, data = src.pop()
        if kind == "paint":
            layer, tiles = data
            swapped = []
            for (r, c), old in tiles:
                sl = np.s_[r * TILE:(r + 1) * TILE, c * TILE:(c + 1) * TILE]
                swapped.append(((r, c), layer.thickness[sl].copy()))
                layer.thickness[sl] = old
            dst.append(("paint", (layer, swapped)))
            idx = self.layers.index(layer) if layer in self.layers else None
            self._emit(ChangeEvent("paint", idx, [t for t, _ in tiles]))
            return
        if kind == "layers":
            dst.append(("layers", list(self.layers)))
            self.layers = list(data)
        else:
            dst.append(("state", self._layer_state()))
            self._set_layers_state(data)
        self._emit(ChangeEvent("layers"))

    @contextlib.contextmanager
    def stroke(self, layer: FallbackLayer, brush: FallbackBrush) -> Iterator[_Stroke]:
        s = _Stroke(self, layer, brush)
        try:
            yield s
        finally:
            s.finish()


class _Stroke:
    def __init__(self, doc: FallbackDocument, layer: FallbackLayer, brush: FallbackBrush) -> None:
        if not np.isfinite(brush.radius_mm) or brush.radius_mm <= 0:
            raise SheerError(f"brush radius must be a positive number of mm, got {brush.radius_mm}")
        self.doc, self.layer, self.brush = doc, layer, brush
        self.before: dict[tuple[int, int], np.ndarray] = {}

    def _remember(self, rows: slice, cols: slice) -> list[tuple[int, int]]:
        tiles = [(r, c) for r in range(rows.start // TILE, (rows.stop - 1) // TILE + 1)
                 for c in range(cols.start // TILE, (cols.stop - 1) // TILE + 1)]
        for r, c in tiles:
            if (r, c) not in self.before:
                sl = np.s_[r * TILE:(r + 1) * TILE, c * TILE:(c + 1) * TILE]
                self.before[(r, c)] = self.layer.thickness[sl].copy()
        return tiles

    def dab(self, point: Any, pressure: float = 1.0) -> list[tuple[int, int]]:
        doc, b = self.doc, self.brush
        p = np.asarray(point, float)
        points = [p]
        if b.mirror:
            n = np.asarray(doc.head.metadata.midplane_normal, float)
            o = np.asarray(doc.head.metadata.midplane_point, float)
            points.append(p - 2.0 * float((p - o) @ n) * n)
        r = b.radius_mm * max(min(pressure, 1.0), 0.05) / doc.head.mm_per_unit
        touched: list[tuple[int, int]] = []
        h = min(max(b.hardness, 0.0), 0.99)
        for q in points:
            for sl in doc.blocks_near(q, r):
                d = np.linalg.norm(doc.position[sl] - q.astype(np.float32), axis=-1)
                mask = (d < r) & doc.coverage[sl]
                if not mask.any():
                    continue
                touched += self._remember(sl[0], sl[1])
                x = np.clip((d / r - h) / (1.0 - h), 0.0, 1.0)
                fall = np.where(mask, 1.0 - x * x * (3.0 - 2.0 * x), 0.0).astype(np.float32)
                sub = self.layer.thickness[sl]
                amount = fall * b.strength * pressure
                if b.mode == "erase":
                    sub -= amount * self.layer.max_thickness * 0.5
                elif b.mode == "smooth":
                    from scipy.ndimage import uniform_filter

                    blurred = uniform_filter(sub, size=5)
                    sub += (blurred - sub) * np.clip(amount, 0.0, 1.0)
                else:
                    sub += amount * self.layer.max_thickness * 0.25
                np.clip(sub, 0.0, self.layer.max_thickness, out=sub)
        touched = sorted(set(touched))
        if touched:
            doc._emit(ChangeEvent("paint", doc.layers.index(self.layer), touched))
        return touched

    def finish(self) -> None:
        if self.before:
            self.doc._push("paint", (self.layer, list(self.before.items())))
