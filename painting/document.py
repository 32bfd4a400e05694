"""The painting document: a head, its paint atlas, an ordered stack of thickness layers, strokes, undo/redo
and change events. Qt-free; the studio and the renderer observe it (see :mod:`painting`).

Units: thickness in µm (float32 maps, ``H × W``, top row first); positions in mesh units; brush radii
in mm (through ``head.mm_per_unit``).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from core.errors import SheerError
from painting import kernels
from painting.atlas import TILE, Atlas, UVLayout, bake, build_layout, check_resolution
from painting.brush import Brush, BrushError
from painting.history import DEFAULT_BUDGET_BYTES, History, Step, TileDelta

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator
    from pathlib import Path

#: A dab point must lie within this distance of the surface (mm), plus one texel.
SURFACE_TOLERANCE_MM = 2.0
#: Most cells per axis of a smoothing dab's local grid (only reached when ``smooth_radius`` is a tiny
#: fraction of a huge brush; the kernel then widens to the dab's extent / this).
SMOOTH_MAX_CELLS_PER_AXIS = 128
#: Largest thickness a layer may hold (µm).
MAX_THICKNESS_UM = 10_000.0


class DocumentError(SheerError, ValueError):
    """Bad input to the document (unknown layer or material, bad value, off-surface point…); the
    document is unchanged when it is raised.
    """


@dataclass(frozen=True)
class ChangeEvent:
    """What changed in a :class:`Document` (delivered synchronously to every subscriber).

    Attributes:
        kind: "paint" (thickness texels of ``layer`` changed inside ``tiles``), "layers" (the list or a
            layer's name/visibility/opacity/maximum changed: see ``detail``), "material" (a layer's
            material changed) or "history" (what undo/redo can do changed).
        layer: the layer's id (stable for the document's life), or None.
        tiles: (tile row, tile column) of the touched 64² tiles, for "paint".
        detail: "stroke", "undo", "redo", "fill", "import", "rollback" for paint; "added", "removed",
            "moved", "name", "visible", "opacity", "max_thickness" for layers.
    """

    kind: str
    layer: int | None = None
    tiles: tuple[tuple[int, int], ...] = ()
    detail: str = ""


class Layer:
    """One layer of cosmetic: a material and its thickness map (µm).

    Read its fields freely; change them only through the :class:`Document` (``doc.set_layer``…), which
    records undo steps and emits events. ``thickness`` is a read-only view of the map.
    """

    def __init__(self, layer_id: int, name: str, material: str, material_object: Any, resolution: int,
                 max_thickness: float, default_thickness: float) -> None:
        self.id = layer_id
        self.name = name
        self.material = material
        self.material_object = material_object
        self.visible = True
        self.opacity = 1.0
        self.max_thickness = float(max_thickness)
        self.default_thickness = float(default_thickness)
        self.resolution = resolution
        # Filled explicitly (not np.zeros, whose pages the kernel maps on first write) so the map is
        # resident from the start: measured at 4096², first-touch faults made the mean 1 cm dab on a
        # new layer 1.3 ms instead of 0.7 ms; filling costs ~30 ms once, when the layer is added.
        self._data = np.empty((resolution, resolution), dtype=np.float32)
        self._data.fill(0.0)
        self._view = self._data.view()
        self._view.flags.writeable = False

    @property
    def thickness(self) -> np.ndarray:
        """float32 (H, W) thickness in µm (read-only view; padding texels copy their source texel)."""
        return self._view

    @property
    def max_thickness_um(self) -> float:
        return self.max_thickness

    def effective_thickness(self) -> np.ndarray:
        """Thickness as rendered: × opacity, zero when hidden (a new float32 array, µm)."""
        if not self.visible:
            return np.zeros_like(self._data)
        return self._data * np.float32(self.opacity)

    def __repr__(self) -> str:
        return (f"Layer(id={self.id}, name={self.name!r}, material={self.material!r}, "
                f"resolution={self.resolution}, visible={self.visible}, opacity={self.opacity})")


def _vec3(value: Any, what: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise DocumentError(f"{what} must be 3 numbers (x, y, z), got {value!r}") from None
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise DocumentError(f"{what} must be 3 finite numbers (x, y, z), got {value!r}")
    return arr


class Document:
    """Layers of cosmetic thickness painted on a head (see :mod:`painting` for an overview).

    Args:
        head: a :class:`painting.head.Head`.
        layout: its paint UV layout (default: :func:`painting.atlas.build_layout`).
        library: a material library with ``get(name)`` (default: ``km.default_library()``, loaded on
            first use).
        resolution: default layer resolution (texels per side, multiple of 64).
        history_budget: undo memory budget in bytes.
        progress: ``progress(stage, fraction)`` for the cleaning/check/unwrap/bake stages.
        cache: cache baked atlases on disk.
    """

    def __init__(self, head: Any, layout: UVLayout | None = None, *, library: Any = None,
                 resolution: int = 2048, history_budget: int = DEFAULT_BUDGET_BYTES,
                 progress: Callable[[str, float], None] | None = None, cache: bool = True,
                 force_unwrap: bool = False) -> None:
        self.head = head
        self.resolution = check_resolution(resolution)
        self._progress = progress
        self._cache = cache
        self.layout = layout if layout is not None else build_layout(head, progress, force_unwrap=force_unwrap)
        self._library = library
        self._atlases: dict[int, Atlas] = {}
        self._layers: list[Layer] = []
        self._ids = itertools.count(1)
        self.history = History(history_budget)
        self._subscribers: list[Callable[[ChangeEvent], None]] = []
        self._stroke: Stroke | None = None
        self._mesh: Any = None
        self._scratches: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    @classmethod
    def from_head(cls, path: str | Path | None = None, **kwargs: Any) -> Document:
        """Load a head (``None`` = the sample head) and make an empty document; keyword arguments as for
        :class:`Document`.
        """
        from painting.head import load_head

        return cls(load_head(path), **kwargs)

    # ------------------------------------------------------------------------------------ basics
    @property
    def clean_report(self) -> Any:
        """What cleaning the mesh changed (:class:`painting.atlas.CleanReport`)."""
        return self.layout.clean

    @property
    def mm_per_unit(self) -> float:
        return float(self.head.mm_per_unit)

    @property
    def atlas(self) -> Atlas:
        """The bake at the document's resolution (baked on first use)."""
        return self.atlas_at(self.resolution)

    def atlas_at(self, resolution: int) -> Atlas:
        """The bake at ``resolution`` (baked on first use, cached in memory and on disk)."""
        res = check_resolution(resolution)
        if res not in self._atlases:
            self._atlases[res] = bake(self.layout, res, progress=self._progress, cache=self._cache)
        return self._atlases[res]

    def _scratch(self, res: int) -> tuple[np.ndarray, np.ndarray]:
        """(mask, base) flat float32 scratch maps for strokes at ``res`` (mask is zero between strokes).

        Filled explicitly so the pages are resident: a dab never pays for first-touch page faults.
        """
        if res not in self._scratches:
            n = res * res
            mask = np.empty(n, np.float32)
            mask.fill(0.0)
            base = np.empty(n, np.float32)
            base.fill(0.0)
            self._scratches[res] = (mask, base)
        return self._scratches[res]

    @property
    def library(self) -> Any:
        if self._library is None:
            import km

            self._library = km.default_library()
        return self._library

    @property
    def layers(self) -> list[Layer]:
        """The layers, bottom (applied first, on the skin) to top (a new list)."""
        return list(self._layers)

    def layer_by_id(self, layer_id: int) -> Layer:
        for lay in self._layers:
            if lay.id == layer_id:
                return lay
        raise DocumentError(f"no layer with id {layer_id} (ids: {[lay.id for lay in self._layers]})")

    def resolve(self, layer: Layer | int) -> Layer:
        """A layer given as a :class:`Layer` of this document or an index into :attr:`layers`."""
        if isinstance(layer, Layer):
            if any(lay is layer for lay in self._layers):
                return layer
            raise DocumentError(f"layer {layer.name!r} (id {layer.id}) is not in this document")
        if isinstance(layer, (int, np.integer)) and not isinstance(layer, bool):
            if -len(self._layers) <= int(layer) < len(self._layers):
                return self._layers[int(layer)]
            raise DocumentError(f"no layer at index {layer} (the document has {len(self._layers)})")
        raise DocumentError(f"unknown layer {layer!r}")

    def index_of(self, layer: Layer | int) -> int:
        lay = self.resolve(layer)
        return next(i for i, x in enumerate(self._layers) if x is lay)

    # ------------------------------------------------------------------------------------ events
    def subscribe(self, callback: Callable[[ChangeEvent], None]) -> Callable[[], None]:
        """Call ``callback(event)`` after every change; returns a function that unsubscribes."""
        self._subscribers.append(callback)

        def unsubscribe() -> None:
            if callback in self._subscribers:
                self._subscribers.remove(callback)

        return unsubscribe

    def _emit(self, event: ChangeEvent) -> None:
        for cb in list(self._subscribers):
            cb(event)

    # ------------------------------------------------------------------------------------ materials
    def _material(self, name: Any) -> tuple[str, Any, float, float]:
        if not isinstance(name, str) or not name.strip():
            raise DocumentError(f"material must be a library name, got {name!r}")
        try:
            mat = self.library.get(name)
        except SheerError as exc:
            raise DocumentError(f"unknown material {name!r}: {exc}") from None
        except (KeyError, LookupError):
            raise DocumentError(f"unknown material {name!r}") from None
        default = getattr(mat, "default_thickness_um", None)
        if default is None:
            default = getattr(mat, "thickness_um", 20.0)
        maximum = float(getattr(mat, "max_thickness_um", 100.0))
        return str(getattr(mat, "name", name)), mat, float(default), maximum

    # ------------------------------------------------------------------------------------ layer edits
    def _check_idle(self, what: str) -> None:
        if self._stroke is not None:
            raise DocumentError(f"cannot {what} while a stroke is in progress")

    def add_layer(self, material: str, resolution: int | None = None, name: str | None = None,
                  max_thickness: float | None = None, index: int | None = None) -> Layer:
        """Add a layer of ``material`` (library name) on top (or at ``index``); undoable.

        ``resolution`` defaults to the document's; ``max_thickness`` (µm) to the material's maximum.
        """
        self._check_idle("add a layer")
        res = self.resolution if resolution is None else self._resolution(resolution)
        mat_name, mat, default, maximum = self._material(material)
        if max_thickness is not None:
            maximum = self._thickness_value(max_thickness, "max_thickness", positive=True)
        if name is not None and (not isinstance(name, str) or not name.strip()):
            raise DocumentError(f"layer name must be a non-empty string, got {name!r}")
        pos = len(self._layers) if index is None else int(index)
        if not 0 <= pos <= len(self._layers):
            raise DocumentError(f"layer index {index} out of range 0..{len(self._layers)}")
        self.atlas_at(res)
        layer = Layer(next(self._ids), name or mat_name, mat_name, mat, res, maximum, default)

        def do() -> None:
            self._layers.insert(pos, layer)
            self._emit(ChangeEvent("layers", layer.id, detail="added"))

        def undo() -> None:
            self._layers.remove(layer)
            self._emit(ChangeEvent("layers", layer.id, detail="removed"))

        do()
        self._push(Step(f"add layer {layer.name}", undo_fn=undo, redo_fn=do, extra_bytes=layer._data.nbytes))
        return layer

    def _resolution(self, value: Any) -> int:
        try:
            return check_resolution(value)
        except SheerError as exc:
            raise DocumentError(str(exc)) from None

    def remove_layer(self, layer: Layer | int) -> None:
        """Remove a layer (undoable: its map is kept by the undo step)."""
        self._check_idle("remove a layer")
        lay = self.resolve(layer)
        pos = self.index_of(lay)

        def do() -> None:
            self._layers.remove(lay)
            self._emit(ChangeEvent("layers", lay.id, detail="removed"))

        def undo() -> None:
            self._layers.insert(pos, lay)
            self._emit(ChangeEvent("layers", lay.id, detail="added"))

        do()
        self._push(Step(f"remove layer {lay.name}", undo_fn=undo, redo_fn=do, extra_bytes=lay._data.nbytes))

    def move_layer(self, layer: Layer | int, index: int) -> None:
        """Move a layer to position ``index`` (0 = bottom); undoable."""
        self._check_idle("move a layer")
        lay = self.resolve(layer)
        src = self.index_of(lay)
        if not isinstance(index, (int, np.integer)) or not -len(self._layers) <= int(index) < len(self._layers):
            raise DocumentError(f"layer index {index!r} out of range 0..{len(self._layers) - 1}")
        dst = int(index) % len(self._layers)
        if dst == src:
            return

        def move(a: int, b: int) -> Callable[[], None]:
            def run() -> None:
                self._layers.insert(b, self._layers.pop(a))
                self._emit(ChangeEvent("layers", lay.id, detail="moved"))
            return run

        move(src, dst)()
        self._push(Step(f"move layer {lay.name}", undo_fn=move(dst, src), redo_fn=move(src, dst)))

    def rename_layer(self, layer: Layer | int, name: str) -> None:
        self.set_layer(layer, name=name)

    def set_layer(self, layer: Layer | int, **changes: Any) -> None:
        """Change layer fields as one undoable step: ``name`` (str), ``visible`` (bool), ``opacity``
        ([0, 1]), ``max_thickness`` (µm, > 0), ``material`` (library name).
        """
        self._check_idle("change a layer")
        lay = self.resolve(layer)
        allowed = {"name", "visible", "opacity", "max_thickness", "material"}
        unknown = set(changes) - allowed
        if unknown:
            raise DocumentError(f"unknown layer field(s) {sorted(unknown)} (allowed: {sorted(allowed)})")
        new: dict[str, Any] = {}
        for key, value in changes.items():
            if key == "name":
                if not isinstance(value, str) or not value.strip():
                    raise DocumentError(f"layer name must be a non-empty string, got {value!r}")
                new["name"] = value
            elif key == "visible":
                new["visible"] = bool(value)
            elif key == "opacity":
                v = self._thickness_value(value, "opacity")
                if v > 1.0:
                    raise DocumentError(f"opacity must be in [0, 1], got {value!r}")
                new["opacity"] = v
            elif key == "max_thickness":
                new["max_thickness"] = self._thickness_value(value, "max_thickness", positive=True)
            elif key == "material":
                mat_name, mat, default, _ = self._material(value)
                new.update(material=mat_name, material_object=mat, default_thickness=default)
        old = {k: getattr(lay, k) for k in new}

        def apply(values: dict[str, Any]) -> Callable[[], None]:
            def run() -> None:
                for k, v in values.items():
                    setattr(lay, k, v)
                if "material" in values:
                    self._emit(ChangeEvent("material", lay.id, detail="material"))
                for k in values:
                    if k in ("name", "visible", "opacity", "max_thickness"):
                        self._emit(ChangeEvent("layers", lay.id, detail=k))
            return run

        apply(new)()
        self._push(Step(f"change layer {lay.name}", undo_fn=apply(old), redo_fn=apply(new)))

    def set_layer_material(self, layer: Layer | int, material: str) -> None:
        self.set_layer(layer, material=material)

    def set_layer_visible(self, layer: Layer | int, visible: bool) -> None:
        self.set_layer(layer, visible=visible)

    def set_layer_opacity(self, layer: Layer | int, opacity: float) -> None:
        self.set_layer(layer, opacity=opacity)

    def set_layer_max_thickness(self, layer: Layer | int, max_thickness: float) -> None:
        self.set_layer(layer, max_thickness=max_thickness)

    @staticmethod
    def _thickness_value(value: Any, what: str, positive: bool = False) -> float:
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise DocumentError(f"{what} must be a number, got {value!r}") from None
        if not math.isfinite(v) or v < 0 or (positive and v == 0) or v > MAX_THICKNESS_UM:
            raise DocumentError(f"{what} must be a finite number in {'(' if positive else '['}0, "
                                f"{MAX_THICKNESS_UM:g}], got {value!r}")
        return v

    # ------------------------------------------------------------------------------------ painting
    def stroke(self, layer: Layer | int, brush: Brush, mirror: bool | None = None) -> Stroke:
        """Begin a stroke on ``layer``; use as a context manager (``with doc.stroke(...) as s:``).

        ``mirror`` overrides ``brush.mirror``. The stroke becomes one undo step when the block ends; if
        the block raises, the stroke is rolled back and the document is unchanged.
        """
        self._check_idle("start a stroke")
        lay = self.resolve(layer)
        if not isinstance(brush, Brush):
            raise DocumentError(f"brush must be a painting.Brush, got {type(brush).__name__}")
        try:
            brush.validate()
        except BrushError as exc:
            raise DocumentError(str(exc)) from None
        # Load (or, first time on a machine, compile) the brush kernels on a background thread; dabs take
        # the numpy path until they are ready. Only processes that paint pay for it.
        kernels.warm_up()
        return Stroke(self, lay, brush, brush.mirror if mirror is None else bool(mirror))

    def fill(self, layer: Layer | int, thickness_um: float | None = None, chart: int | None = None) -> None:
        """Set every covered texel of ``layer`` (or of one ``chart``) to ``thickness_um`` (default: the
        material's default thickness; clamped to the layer maximum); one undo step.
        """
        self._check_idle("fill")
        lay = self.resolve(layer)
        value = lay.default_thickness if thickness_um is None else self._thickness_value(thickness_um,
                                                                                           "fill thickness")
        atlas = self.atlas_at(lay.resolution)
        if chart is not None:
            charts = int(self.layout.charts)
            if not isinstance(chart, (int, np.integer)) or not 0 <= int(chart) < charts:
                raise DocumentError(f"chart must be an integer in 0..{charts - 1}, got {chart!r}")
        with Stroke(self, lay, Brush(mode="fill"), False, detail="fill") as s:
            s._fill_region(atlas, None if chart is None else int(chart), min(value, lay.max_thickness))

    def set_thickness(self, layer: Layer | int, values: np.ndarray, detail: str = "import") -> None:
        """Replace a layer's whole map (µm, finite, ≥ 0, shape (H, W) of the layer) as one undo step."""
        self._check_idle("replace a map")
        lay = self.resolve(layer)
        arr = np.asarray(values)
        if arr.shape != lay._data.shape:
            raise DocumentError(f"map is {arr.shape[1] if arr.ndim > 1 else '?'}×{arr.shape[0]}, layer "
                                f"{lay.name!r} is {lay.resolution}×{lay.resolution}")
        arr = arr.astype(np.float32)
        if not np.all(np.isfinite(arr)) or arr.min(initial=0.0) < 0 or arr.max(initial=0.0) > MAX_THICKNESS_UM:
            raise DocumentError(f"map values must be finite thickness in [0, {MAX_THICKNESS_UM:g}] µm")
        with Stroke(self, lay, Brush(mode="set"), False, detail=detail) as s:
            s._replace_all(arr)

    # ------------------------------------------------------------------------------------ history
    def _push(self, step: Step) -> None:
        self.history.push(step)
        self._emit(ChangeEvent("history"))

    @property
    def can_undo(self) -> bool:
        return self.history.can_undo and self._stroke is None

    @property
    def can_redo(self) -> bool:
        return self.history.can_redo and self._stroke is None

    def undo(self) -> bool:
        """Undo the last step; returns False when there is none."""
        self._check_idle("undo")
        step = self.history.pop_undo()
        if step is None:
            return False
        self._replay(step, "undo")
        return True

    def redo(self) -> bool:
        """Redo the last undone step; returns False when there is none."""
        self._check_idle("redo")
        step = self.history.pop_redo()
        if step is None:
            return False
        self._replay(step, "redo")
        return True

    def _replay(self, step: Step, detail: str) -> None:
        for delta in step.deltas:
            delta.swap()
            self._emit(ChangeEvent("paint", delta.layer.id, tuple(map(tuple, delta.tiles.tolist())), detail))
        fn = step.undo_fn if detail == "undo" else step.redo_fn
        if fn is not None:
            fn()
        self._emit(ChangeEvent("history"))

    def clear_history(self) -> None:
        self.history.clear()
        self._emit(ChangeEvent("history"))

    # ------------------------------------------------------------------------------------ picking
    def hit(self, origin: Any, direction: Any) -> Any:
        """First surface hit of a ray (mesh units): a :class:`painting.hit.Hit` or None."""
        from painting.hit import ray_hit

        return ray_hit(self, origin, direction)

    def pick_depth(self, ndc_xy: Any, depth: float, inv_view_proj: Any) -> Any:
        """Surface point from a depth-buffer value (see :func:`painting.hit.depth_hit`)."""
        from painting.hit import depth_hit

        return depth_hit(self, ndc_xy, depth, inv_view_proj)

    def mirror_point(self, point: Any) -> np.ndarray:
        """``point`` reflected about the head's midplane (mesh units)."""
        p = _vec3(point, "point")
        meta = self.head.metadata
        c = np.asarray(meta.midplane_point, dtype=np.float64)
        n = np.asarray(meta.midplane_normal, dtype=np.float64)
        n = n / np.linalg.norm(n)
        return p - 2.0 * float(np.dot(p - c, n)) * n

    def mirror_vector(self, v: np.ndarray) -> np.ndarray:
        n = np.asarray(self.head.metadata.midplane_normal, dtype=np.float64)
        n = n / np.linalg.norm(n)
        return v - 2.0 * float(np.dot(v, n)) * n

    # ------------------------------------------------------------------------------------ maps
    def export_layer(self, layer: Layer | int, path: str | Path, scale_um: float | None = None) -> None:
        """Write a layer's thickness to ``.png`` (16-bit, scale in metadata) or ``.exr`` (32-bit float)."""
        from painting.maps_io import write_thickness

        lay = self.resolve(layer)
        write_thickness(path, lay.thickness, scale_um=scale_um, credit=getattr(self.head, "credit", ""))

    def import_layer(self, layer: Layer | int, path: str | Path) -> None:
        """Read a thickness map (``.png`` 16-bit with scale, or ``.exr``) into a layer; one undo step."""
        from painting.maps_io import read_thickness

        lay = self.resolve(layer)
        values = read_thickness(path, expected_shape=lay._data.shape)
        self.set_thickness(lay, values, detail="import")


class Stroke:
    """A stroke in progress (from :meth:`Document.stroke`); call :meth:`dab` for each point."""

    def __init__(self, doc: Document, layer: Layer, brush: Brush, mirror: bool, detail: str = "stroke") -> None:
        self.doc = doc
        self.layer = layer
        self.brush = brush
        self.mirror = mirror
        self.detail = detail
        self.atlas = doc.atlas_at(layer.resolution)
        self.dabs = 0
        self._last: tuple[np.ndarray, np.ndarray] | None = None  # last dab (point, normal)
        self._last_mirror: tuple[np.ndarray, np.ndarray] | None = None
        self._open = False
        res = layer.resolution
        self._W = res
        self._data = layer._data.reshape(-1)
        # Scratch maps shared by the document's strokes at this resolution, reset tile-wise at the end of
        # each stroke, so a stroke costs nothing proportional to the map size. ``base`` receives a whole
        # 64² tile of the layer the first time the stroke touches the tile (the undo record and the
        # values dabs composite over); ``mask`` is the stroke's coverage.
        self._mask, self._base = doc._scratch(res)
        self._nt = res // TILE
        self._touched = np.zeros(self._nt * self._nt, dtype=bool)
        self._tile_mark = np.zeros(self._nt * self._nt, dtype=bool)
        self._amount = layer.default_thickness if brush.amount_um is None else float(brush.amount_um)
        # The falloff as the compiled kernels take it (kind, hardness, curve samples as float64).
        curve = np.zeros(2)
        xs = np.zeros(2)
        hardness = np.float32(min(max(brush.hardness, 0.0), 1.0))
        if brush.falloff_curve is not None:
            kind = kernels.FALLOFF_CURVE
            c32 = np.asarray(brush.falloff_curve, dtype=np.float32)
            curve = c32.astype(np.float64)
            xs = np.linspace(0.0, 1.0, len(c32), dtype=np.float32).astype(np.float64)
        elif hardness >= 1.0:
            kind = kernels.FALLOFF_HARD
        else:
            kind = kernels.FALLOFF_SMOOTH
        self._falloff_args = (kind, hardness, xs, curve)

    # ---- context manager
    def __enter__(self) -> Stroke:
        if self.doc._stroke is not None:
            raise DocumentError("a stroke is already in progress")
        self.doc._stroke = self
        self._open = True
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        self._open = False
        self.doc._stroke = None
        if exc_type is not None:
            self._rollback()
            return
        self._commit()

    def _tiles(self) -> np.ndarray:
        ids = np.flatnonzero(self._touched)
        return np.stack([ids // self._nt, ids % self._nt], axis=1).astype(np.int32)

    def _view(self, a: np.ndarray) -> np.ndarray:
        return a.reshape(self._nt, TILE, self._nt, TILE)

    def _reset_scratch(self, tiles: np.ndarray) -> None:
        self._view(self._mask)[tiles[:, 0], :, tiles[:, 1], :] = 0.0

    def _commit(self) -> None:
        tiles = self._tiles()
        if len(tiles) == 0:
            return
        old = self._view(self._base)[tiles[:, 0], :, tiles[:, 1], :]  # a copy (fancy indexing)
        self._reset_scratch(tiles)
        label = f"{self.detail} on {self.layer.name}"
        self.doc._push(Step(label, deltas=[TileDelta(self.layer, tiles, old)]))

    def _rollback(self) -> None:
        tiles = self._tiles()
        if len(tiles) == 0:
            return
        ty, tx = tiles[:, 0], tiles[:, 1]
        self._view(self._data)[ty, :, tx, :] = self._view(self._base)[ty, :, tx, :]
        self._reset_scratch(tiles)
        self.doc._emit(ChangeEvent("paint", self.layer.id, tuple(map(tuple, tiles.tolist())), "rollback"))

    # ---- texel writes
    def _prepare(self, flat: np.ndarray, sidx: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray, tuple[tuple[int, int], ...]]:
        """Before writing covered texels ``flat`` (``sidx``: their spatial-index entries, a shortcut):
        the padding texels they feed (dst, src), and the touched tiles, whose old values are saved in
        ``base`` if this stroke had not touched them yet.
        """
        index = self.atlas.index if sidx is not None else None
        dst, src = self.atlas.pads_of(flat, None if index is None else index.has_pad[sidx])
        res = self._W
        nt = self._nt
        # Mark tiles in a small boolean table instead of np.unique (no sort of the texel list).
        mark = self._tile_mark
        if index is not None:
            mark[index.tile[sidx]] = True
        else:
            mark[(flat // (res * TILE)) * nt + (flat % res) // TILE] = True
        if len(dst):
            mark[(dst // (res * TILE)) * nt + (dst % res) // TILE] = True
        ids = np.flatnonzero(mark)
        mark[ids] = False
        new = ids[~self._touched[ids]]
        if len(new):
            ty, tx = new // nt, new % nt
            self._view(self._base)[ty, :, tx, :] = self._view(self._data)[ty, :, tx, :]
            self._touched[new] = True
        return dst, src, tuple(zip((ids // nt).tolist(), (ids % nt).tolist()))

    def _store(self, flat: np.ndarray, values: np.ndarray, dst: np.ndarray, src: np.ndarray) -> None:
        self._data[flat] = values
        if len(dst):
            self._data[dst] = self._data[src]

    def _write(self, flat: np.ndarray, values: np.ndarray) -> tuple[tuple[int, int], ...]:
        """Write covered texels and the padding texels they feed; returns the touched tiles."""
        dst, src, tiles = self._prepare(flat)
        self._store(flat, values, dst, src)
        return tiles

    # ---- dabs
    def dab(self, point: Any, pressure: float = 1.0, normal: Any = None) -> tuple[tuple[int, int], ...]:
        """Paint at a surface point (mesh units). ``pressure`` in [0, 1]; ``normal`` (optional) is the
        direction the brush faces from (default: the surface normal at the point); texels facing more
        than ``brush.max_angle_deg`` away from it are not painted. Returns the touched tiles.

        Raises :class:`DocumentError` (document unchanged) for a non-finite point or pressure, or a point
        farther than :data:`SURFACE_TOLERANCE_MM` (plus one texel) from the surface.
        """
        if not self._open:
            raise DocumentError("dab() outside the stroke's 'with' block")
        p = _vec3(point, "dab point")
        try:
            pr = float(pressure)
        except (TypeError, ValueError):
            raise DocumentError(f"pressure must be a number in [0, 1], got {pressure!r}") from None
        if not math.isfinite(pr) or not 0.0 <= pr <= 1.0:
            raise DocumentError(f"pressure must be a number in [0, 1], got {pressure!r}")
        n_user = None
        if normal is not None:
            n_user = _vec3(normal, "dab normal")
            norm = float(np.linalg.norm(n_user))
            if norm == 0:
                raise DocumentError("dab normal must not be zero")
            n_user = n_user / norm
        brush = self.brush
        mpu = self.doc.mm_per_unit
        index = self.atlas.index
        tol = (SURFACE_TOLERANCE_MM + 1.5 * self.atlas.texel_mm) / mpu
        k, _ = index.nearest(p, tol)
        if k < 0:
            raise DocumentError(f"dab point ({p[0]:.4g}, {p[1]:.4g}, {p[2]:.4g}) is more than "
                                f"{tol * mpu:.2f} mm from the surface of layer {self.layer.name!r}'s head")
        r = brush.radius_mm * (pr if brush.pressure_radius else 1.0) / mpu
        if r <= 0:
            return ()
        alpha = brush.flow * (pr if brush.pressure_strength else 1.0)
        n0 = n_user if n_user is not None else index.normal(k)
        if self._last is not None and brush.mode != "fill" \
                and float(np.linalg.norm(p - self._last[0])) < brush.spacing * r:
            return ()
        pieces = self._path(self._last, p, n0, r, index)
        if self.mirror:
            pm = self.doc.mirror_point(p)
            km_, _ = index.nearest(pm, max(tol, r))
            if km_ >= 0:
                pm = index.point(km_)
                nm = self.doc.mirror_vector(n0) if n_user is not None else index.normal(km_)
                pieces += self._path(self._last_mirror, pm, nm, r, index)
                self._last_mirror = (pm, nm)
        self._last = (p, n0)
        self.dabs += 1
        if brush.mode == "fill":
            chart = int(self.atlas.chart.reshape(-1)[index.flat[k]])
            amount = min(brush.strength * self._amount, self.layer.max_thickness)
            tiles = self._fill_region(self.atlas, chart, amount, emit=False)
        else:
            fast = kernels.active()  # compiled kernels, bit-identical to the numpy reference
            flat, w, sidx = (self._weights_fast if fast else self._weights)(pieces, r, index)
            if len(flat) == 0:
                return ()
            a32 = np.float32(alpha)
            if brush.mode == "smooth":
                tiles = self._smooth(flat, w * a32, sidx, r, index)
            elif fast:
                tiles = self._composite_fast(sidx, w, a32, index)
            else:
                tiles = self._composite(flat, w * a32, sidx)
        if tiles:
            self.doc._emit(ChangeEvent("paint", self.layer.id, tiles, self.detail))
        return tiles

    def _path(self, last: tuple[np.ndarray, np.ndarray] | None, p: np.ndarray, n: np.ndarray, r: float,
              index: Any) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Capsules (a, b, normal) from the last dab (point, normal) to ``p``: one sphere for the first
        dab; long gaps are split into pieces no longer than the radius with the joints snapped to the
        surface. A piece faces the mean of its end normals (so a quick stroke round the nose keeps the
        texels facing either end).
        """
        if last is None:
            return [(p, p, n)]
        q0, n_last = last
        length = float(np.linalg.norm(p - q0))
        pieces = max(1, int(math.ceil(length / r)))
        pts = [q0]
        normals = [n_last]
        for i in range(1, pieces):
            q = q0 + (p - q0) * (i / pieces)
            k, _ = index.nearest(q, max(r, 0.5 * length))
            pts.append(index.point(k) if k >= 0 else q)
            normals.append(index.normal(k) if k >= 0 else n)
        pts.append(p)
        normals.append(n)
        out = []
        for i in range(pieces):
            m = normals[i] + normals[i + 1]
            norm = float(np.linalg.norm(m))
            out.append((pts[i], pts[i + 1], m / norm if norm > 1e-9 else normals[i + 1]))
        return out

    def _weights(self, pieces: list[tuple[np.ndarray, np.ndarray, np.ndarray]], r: float,
                 index: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Texels within ``r`` of any capsule and facing its normal: (flat, weight, sorted index), the
        weight of a texel reached by several capsules being the largest.
        """
        cos_max = np.float32(math.cos(math.radians(self.brush.max_angle_deg)))
        r2 = np.float32(r * r)
        out_idx, out_w = [], []
        f32 = np.float32
        for a, b, n in pieces:
            idx = index.query_sphere((a + b) / 2.0, r + float(np.linalg.norm(b - a)) / 2.0)
            if len(idx) == 0:
                continue
            # Separate x/y/z arrays: far faster in numpy than (N, 3) rows.
            dx = index.x[idx] - f32(a[0])
            dy = index.y[idx] - f32(a[1])
            dz = index.z[idx] - f32(a[2])
            if not np.array_equal(a, b):
                ab = (b - a).astype(np.float32)
                abab = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2]  # float32, summed left to right
                t = (dx * ab[0] + dy * ab[1] + dz * ab[2]) / abab
                np.clip(t, 0.0, 1.0, out=t)
                dx -= t * ab[0]
                dy -= t * ab[1]
                dz -= t * ab[2]
            d2 = dx * dx + dy * dy + dz * dz
            inside = np.flatnonzero(d2 < r2)
            idx = idx[inside]
            d2 = d2[inside]
            if self.brush.max_angle_deg < 180.0:
                facing = (index.nx[idx] * f32(n[0]) + index.ny[idx] * f32(n[1])
                          + index.nz[idx] * f32(n[2])) >= cos_max
                idx = idx[facing]
                d2 = d2[facing]
            out_idx.append(idx)
            out_w.append(self.brush.falloff(np.sqrt(d2) / f32(r)))
        if not out_idx:
            empty = np.zeros(0, dtype=np.int64)
            return empty, np.zeros(0, dtype=np.float32), empty
        idx = np.concatenate(out_idx)
        w = np.concatenate(out_w)
        if len(out_idx) > 1:
            order = np.lexsort((-w, idx))
            idx, w = idx[order], w[order]
            first = np.ones(len(idx), dtype=bool)
            first[1:] = idx[1:] != idx[:-1]
            idx, w = idx[first], w[first]
        return index.flat[idx], w, idx

    def _weights_fast(self, pieces: list[tuple[np.ndarray, np.ndarray, np.ndarray]], r: float,
                      index: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`_weights` through the compiled kernel (same texels, bit-identical weights; with
        several capsules the indices come out ascending, as in the reference).
        """
        a = np.array([piece[0] for piece in pieces], dtype=np.float64)
        b = np.array([piece[1] for piece in pieces], dtype=np.float64)
        n = np.array([piece[2] for piece in pieces], dtype=np.float64)
        kind, hardness, xs, curve = self._falloff_args
        cos_max = np.float32(math.cos(math.radians(self.brush.max_angle_deg)))
        sidx, w = kernels.weights(index.pn, index.origin, float(index.cell), index.dims_array, index.cell_start,
                                  a, b, n, float(r), cos_max, bool(self.brush.max_angle_deg < 180.0), kind,
                                  hardness, xs, curve)
        return index.flat[sidx], w, sidx

    def _composite_fast(self, sidx: np.ndarray, w: np.ndarray, alpha: np.float32,
                        index: Any) -> tuple[tuple[int, int], ...]:
        """:meth:`_composite` through the compiled kernel (``w`` the falloff weights, ``alpha`` the
        dab's flow × pressure): bit-identical map, coverage, saved tiles and returned tiles.
        """
        atlas = self.atlas
        ids = kernels.composite(sidx, w, alpha, index.flat, index.tile, index.has_pad, atlas.pad_src,
                                atlas.pad_dst, self._data, self._mask, self._base, self._touched,
                                self._tile_mark, self._W, kernels.MODE_CODES[self.brush.mode],
                                np.float32(self.brush.strength), np.float32(self._amount),
                                np.float32(self.layer.max_thickness))
        nt = self._nt
        return tuple(zip((ids // nt).tolist(), (ids % nt).tolist()))

    def _composite(self, flat: np.ndarray, alpha: np.ndarray,
                   sidx: np.ndarray | None = None) -> tuple[tuple[int, int], ...]:
        dst, src, tiles = self._prepare(flat, sidx)
        m = self._mask[flat]
        m += (np.float32(1.0) - m) * alpha
        self._mask[flat] = m
        base = self._base[flat]
        s = np.float32(self.brush.strength)
        mode = self.brush.mode
        if mode == "add":
            top = np.float32(self.layer.max_thickness)
            values = np.minimum(base + (s * np.float32(self._amount)) * m, top)
            values = np.where(base > top, base, values)
        elif mode == "erase":
            values = base * (np.float32(1.0) - s * m)
        else:  # set
            target = np.float32(min(self._amount, self.layer.max_thickness))
            values = base + (target - base) * (s * m)
        self._store(flat, values.astype(np.float32, copy=False), dst, src)
        return tiles

    def _smooth(self, flat: np.ndarray, alpha: np.ndarray, sidx: np.ndarray, r: float,
                index: Any) -> tuple[tuple[int, int], ...]:
        """One conservative diffusion step over the dab's texels, in 3D, with no neighbour cap.

        The kernel is ``K_ij = Σ_c φ_c(p_i) φ_c(p_j)``, ``φ_c`` the trilinear hat functions of a local
        grid of spacing ``h = smooth_radius · r`` (at least one texel): symmetric, non-negative, reaching
        texels up to 2h apart (per axis). With ``s_i = √alpha_i`` the step is
        ``Δt_i = β Σ_j s_i s_j K_ij (t_j − t_i)``: antisymmetric, so the sum of thickness is conserved
        (up to float rounding), and with ``β = strength / max_i(s_i Σ_j K_ij s_j)`` every new value is a
        convex combination of the old ones (no overshoot, never negative). It costs O(texels · 8) through
        splatting to and gathering from the grid nodes — a few ms on the finest maps, where the pair list
        of a uniform ball had to be capped.
        """
        cols = [a[sidx].astype(np.float64) for a in (index.x, index.y, index.z)]
        texel = self.atlas.texel_mm / self.doc.mm_per_unit
        lo = [float(col.min()) for col in cols]
        extent = max(float(col.max()) - low for col, low in zip(cols, lo))
        h = max(self.brush.smooth_radius * r, texel, extent / SMOOTH_MAX_CELLS_PER_AXIS)
        n = len(flat)
        cells, hats = [], []
        for col, low in zip(cols, lo):
            u = (col - low) / h
            i = np.floor(u)
            frac = u - i
            cells.append(i.astype(np.int64))
            hats.append(np.stack([1.0 - frac, frac], axis=1))  # the two hat weights along this axis
        dims = [int(c.max()) + 2 for c in cells]
        # Node (cx, cy, cz) ∈ {0, 1}³ of each texel's cell, x slowest: its key and trilinear weight.
        offs = np.array([cx + dims[0] * (cy + dims[1] * cz) for cx in (0, 1) for cy in (0, 1) for cz in (0, 1)])
        keys = (cells[0] + dims[0] * (cells[1] + dims[1] * cells[2]))[:, None] + offs[None, :]
        phi = (hats[0][:, :, None, None] * hats[1][:, None, :, None] * hats[2][:, None, None, :]).reshape(n, 8)
        ncell = int(dims[0] * dims[1] * dims[2])
        s = np.sqrt(alpha.astype(np.float64))
        t = self._data[flat].astype(np.float64)
        ps = phi * s[:, None]
        node_w = np.bincount(keys.ravel(), ps.ravel(), minlength=ncell)  # Σ_j φ_c(p_j) s_j
        node_t = np.bincount(keys.ravel(), (ps * t[:, None]).ravel(), minlength=ncell)  # … · t_j
        gather_w = (phi * node_w[keys]).sum(axis=1)  # Σ_j K_ij s_j
        gather_t = (phi * node_t[keys]).sum(axis=1)  # Σ_j K_ij s_j t_j
        rate = s * gather_w
        top = float(rate.max(initial=0.0))
        if top <= 0.0:
            return ()
        beta = float(self.brush.strength) / top
        new = t + beta * s * (gather_t - t * gather_w)
        return self._write(flat, np.maximum(new, 0.0).astype(np.float32))

    def _fill_region(self, atlas: Atlas, chart: int | None, value: float,
                     emit: bool = True) -> tuple[tuple[int, int], ...]:
        cov = atlas.coverage.reshape(-1)
        if chart is None:
            flat = np.flatnonzero(cov)
        else:
            flat = np.flatnonzero(cov & (atlas.chart.reshape(-1) == chart))
        if len(flat) == 0:
            return ()
        tiles = self._write(flat, np.full(len(flat), value, dtype=np.float32))
        if emit and tiles:
            self.doc._emit(ChangeEvent("paint", self.layer.id, tiles, self.detail))
        return tiles

    def _replace_all(self, values: np.ndarray) -> None:
        """Replace the whole map (import); only tiles that really change are recorded."""
        new = values.reshape(-1)
        c = np.flatnonzero(self._data != new)
        if len(c) == 0:
            return
        _, _, tiles = self._prepare(c)
        self._data[c] = new[c]
        self.doc._emit(ChangeEvent("paint", self.layer.id, tiles, self.detail))


def iter_layers(doc: Document) -> Iterator[Layer]:
    """The visible layers, bottom to top."""
    return (lay for lay in doc.layers if lay.visible)
