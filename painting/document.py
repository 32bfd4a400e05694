"""The painting document: a head, its paint atlas, an ordered stack of thickness layers, undo/redo, events.

Qt-free; the studio and the renderer observe it (see :mod:`painting`).

The layers are :class:`painting.layer.Layer`; strokes are run by the stroke engine
(:class:`painting.stroke.Stroke`); every edit is one step of :class:`painting.history.History`.

Units: thickness in µm (float32 maps, ``H × W``, top row first); positions in mesh units; brush radii
in mm (through ``head.mm_per_unit``).
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING, Any, Literal, Protocol

import numpy as np

from core.errors import SheerError
from painting import kernels
from painting.atlas import Atlas, bake, check_resolution
from painting.brush import Brush, BrushError
from painting.document_masks import MaskEditing
from painting.document_materials import MaterialEditing, material_thicknesses
from painting.history import DEFAULT_BUDGET_BYTES, History, Step
from painting.layer import ChangeEvent, DocumentError, Layer, as_vec3, thickness_value
from painting.layout import build_layout
from painting.maps_io import MAX_THICKNESS_UM
from painting.stroke import Stroke

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator
    from contextlib import AbstractContextManager
    from pathlib import Path

    import trimesh
    from numpy.typing import ArrayLike

    from painting.head import Head
    from painting.hit import Hit
    from painting.layout import CleanReport, UVLayout

class MaterialLibrary(Protocol):
    """Where a document finds its materials by name (:class:`km.library.Library`, or a stand-in)."""

    def get(self, name: str) -> Any:
        """The material called ``name``.

        An object with ``name``, ``thickness_um`` (or ``default_thickness_um``) and ``max_thickness_um``
        (µm); an unknown name raises ``KeyError`` or a :class:`core.errors.SheerError`.
        """
        ...


class Document(MaskEditing, MaterialEditing):
    """Layers of cosmetic thickness painted on a head (see :mod:`painting` for an overview).

    Regions and layer masks: :class:`painting.document_masks.MaskEditing`; edits of the material library
    that the layers follow: :class:`painting.document_materials.MaterialEditing`.

    Args:
        head: a :class:`painting.head.Head`.
        layout: its paint UV layout (default: :func:`painting.layout.build_layout`).
        library: a material library with ``get(name)`` (default: ``km.default_library()``, loaded on
            first use).
        resolution: default layer resolution (texels per side, multiple of 64).
        history_budget: undo memory budget in bytes.
        progress: ``progress(stage, fraction)`` for the cleaning/check/unwrap/bake stages.
        cache: cache baked atlases on disk.
        force_unwrap: unwrap with xatlas even when the head's own UVs can be painted.
    """

    def __init__(self, head: Head, layout: UVLayout | None = None, *, library: MaterialLibrary | None = None,
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
        self._pick_mesh: trimesh.Trimesh | None = None
        self._scratches: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    @classmethod
    def from_head(cls, path: str | Path | None = None, **kwargs: Any) -> Document:
        """Load a head and make an empty document.

        Args:
            path: a ``.glb``/``.obj``/``.ply`` file, or None for the sample head.
            **kwargs: as for :class:`Document`.
        """
        from painting.head import load_head

        return cls(load_head(path), **kwargs)

    # ------------------------------------------------------------------------------------ basics
    @property
    def clean_report(self) -> CleanReport:
        """What cleaning the mesh changed (:class:`painting.layout.CleanReport`)."""
        return self.layout.clean

    @property
    def mm_per_unit(self) -> float:
        """Millimetres per mesh unit of the head."""
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

    def prepare_painting(self) -> None:
        """Load what the first dab needs (the bake, its texel index, the brush kernels) ahead of it.

        The first dab then costs what every dab does. Safe on a background thread while the document is used (the studio calls it once its window is
        up): the index loads once, under a lock; the kernels load on their own thread.
        """
        kernels.warm_up()
        _ = self.atlas.index

    def scratch_maps(self, res: int) -> tuple[np.ndarray, np.ndarray]:
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
    def library(self) -> MaterialLibrary:
        """The material library (``km.default_library()`` unless one was given; loaded on first use)."""
        if self._library is None:
            import km

            self._library = km.default_library()
        return self._library

    @property
    def layers(self) -> list[Layer]:
        """The layers, bottom (applied first, on the skin) to top (a new list)."""
        return list(self._layers)

    def layer_by_id(self, layer_id: int) -> Layer:
        """The layer with id ``layer_id`` (raises :class:`DocumentError` if there is none)."""
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
        """The position of ``layer`` in :attr:`layers` (0 = bottom)."""
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

    def emit(self, event: ChangeEvent) -> None:
        """Deliver ``event`` to every subscriber, now (the document's edits and its strokes report so)."""
        for cb in list(self._subscribers):
            cb(event)

    # ------------------------------------------------------------------------------------ materials
    def lookup_material(self, name: Any) -> tuple[str, Any, float, float]:
        """The library's material ``name``: (its name, the material, default and maximum thickness in µm).

        Raises:
            DocumentError: naming it, when ``name`` is not a library name.
        """
        if not isinstance(name, str) or not name.strip():
            raise DocumentError(f"material must be a library name, got {name!r}")
        try:
            mat = self.library.get(name)
        except SheerError as exc:
            raise DocumentError(f"unknown material {name!r}: {exc}") from None
        except (KeyError, LookupError):
            raise DocumentError(f"unknown material {name!r}") from None
        thickness, maximum = material_thicknesses(mat)
        return str(getattr(mat, "name", name)), mat, thickness, maximum

    # ------------------------------------------------------------------------------------ layer edits
    def require_idle(self, what: str) -> None:
        """Raise :class:`DocumentError` ("cannot ``what`` while a stroke is in progress") during a stroke."""
        if self._stroke is not None:
            raise DocumentError(f"cannot {what} while a stroke is in progress")

    def begin_stroke(self, stroke: Stroke) -> None:
        """Make ``stroke`` the one in progress (:class:`DocumentError` when another is)."""
        if self._stroke is not None:
            raise DocumentError("a stroke is already in progress")
        self._stroke = stroke

    def end_stroke(self) -> None:
        """No stroke is in progress any more (the stroke's ``with`` block ended)."""
        self._stroke = None

    def add_layer(self, material: str, resolution: int | None = None, name: str | None = None,
                  max_thickness: float | None = None, index: int | None = None) -> Layer:
        """Add a layer of ``material`` (library name) on top (or at ``index``); undoable.

        ``resolution`` defaults to the document's; ``max_thickness`` (µm) to the material's maximum.
        """
        self.require_idle("add a layer")
        res = self.resolution if resolution is None else self._resolution(resolution)
        mat_name, mat, default, maximum = self.lookup_material(material)
        if max_thickness is not None:
            maximum = thickness_value(max_thickness, "max_thickness", positive=True)
        if name is not None and (not isinstance(name, str) or not name.strip()):
            raise DocumentError(f"layer name must be a non-empty string, got {name!r}")
        pos = len(self._layers) if index is None else int(index)
        if not 0 <= pos <= len(self._layers):
            raise DocumentError(f"layer index {index} out of range 0..{len(self._layers)}")
        self.atlas_at(res)
        layer = Layer(next(self._ids), name or mat_name, mat_name, mat, res, maximum, default)

        def do() -> None:
            self._layers.insert(pos, layer)
            self.emit(ChangeEvent("layers", layer.id, detail="added"))

        def undo() -> None:
            self._layers.remove(layer)
            self.emit(ChangeEvent("layers", layer.id, detail="removed"))

        do()
        self.push_step(Step(f"add layer {layer.name}", undo_fn=undo, redo_fn=do, extra_bytes=layer.data.nbytes))
        return layer

    def _resolution(self, value: Any) -> int:
        try:
            return check_resolution(value)
        except SheerError as exc:
            raise DocumentError(str(exc)) from None

    def remove_layer(self, layer: Layer | int) -> None:
        """Remove a layer (undoable: its map is kept by the undo step)."""
        self.require_idle("remove a layer")
        lay = self.resolve(layer)
        pos = self.index_of(lay)

        def do() -> None:
            self._layers.remove(lay)
            self.emit(ChangeEvent("layers", lay.id, detail="removed"))

        def undo() -> None:
            self._layers.insert(pos, lay)
            self.emit(ChangeEvent("layers", lay.id, detail="added"))

        do()
        self.push_step(Step(f"remove layer {lay.name}", undo_fn=undo, redo_fn=do, extra_bytes=lay.data.nbytes))

    def move_layer(self, layer: Layer | int, index: int) -> None:
        """Move a layer to position ``index`` (0 = bottom); undoable."""
        self.require_idle("move a layer")
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
                self.emit(ChangeEvent("layers", lay.id, detail="moved"))
            return run

        move(src, dst)()
        self.push_step(Step(f"move layer {lay.name}", undo_fn=move(dst, src), redo_fn=move(src, dst)))

    def rename_layer(self, layer: Layer | int, name: str) -> None:
        """Rename a layer (one undo step); as ``set_layer(layer, name=name)``."""
        self.set_layer(layer, name=name)

    def set_layer(self, layer: Layer | int, **changes: Any) -> None:
        """Change layer fields as one undoable step (fields given their current value are left out).

        Nothing changes, and no step is recorded, when every value given is the layer's already.

        Args:
            layer: a layer of this document, or its index.
            **changes: ``name`` (str), ``visible`` (bool), ``opacity`` ([0, 1]), ``max_thickness`` (µm,
                > 0), ``material`` (library name).
        """
        self.require_idle("change a layer")
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
                v = thickness_value(value, "opacity")
                if v > 1.0:
                    raise DocumentError(f"opacity must be in [0, 1], got {value!r}")
                new["opacity"] = v
            elif key == "max_thickness":
                new["max_thickness"] = thickness_value(value, "max_thickness", positive=True)
            elif key == "material":
                mat_name, mat, default, _ = self.lookup_material(value)
                if mat_name != lay.material or mat is not lay.material_object:
                    new.update(material=mat_name, material_object=mat, default_thickness=default)
        new = {k: v for k, v in new.items() if k in ("material", "material_object", "default_thickness")
               or getattr(lay, k) != v}
        if not new:
            return
        old = {k: getattr(lay, k) for k in new}

        def apply(values: dict[str, Any]) -> Callable[[], None]:
            def run() -> None:
                for k, v in values.items():
                    setattr(lay, k, v)
                if "material" in values:
                    self.emit(ChangeEvent("material", lay.id, detail="material"))
                for k in values:
                    if k in ("name", "visible", "opacity", "max_thickness"):
                        self.emit(ChangeEvent("layers", lay.id, detail=k))
            return run

        apply(new)()
        self.push_step(Step(f"change layer {lay.name}", undo_fn=apply(old), redo_fn=apply(new)))

    def set_layer_material(self, layer: Layer | int, material: str) -> None:
        """Give a layer another material (library name; one undo step)."""
        self.set_layer(layer, material=material)

    def set_layer_visible(self, layer: Layer | int, visible: bool) -> None:
        """Show or hide a layer (one undo step)."""
        self.set_layer(layer, visible=visible)

    def set_layer_opacity(self, layer: Layer | int, opacity: float) -> None:
        """Set a layer's opacity in [0, 1] (one undo step)."""
        self.set_layer(layer, opacity=opacity)

    def set_layer_max_thickness(self, layer: Layer | int, max_thickness: float) -> None:
        """Set the most "add" builds up to on a layer (µm, > 0; one undo step)."""
        self.set_layer(layer, max_thickness=max_thickness)

    # ------------------------------------------------------------------------------------ painting
    def stroke(self, layer: Layer | int, brush: Brush, mirror: bool | None = None) -> Stroke:
        """Begin a stroke on ``layer``; use as a context manager (``with doc.stroke(...) as s:``).

        ``mirror`` overrides ``brush.mirror``. The stroke becomes one undo step when the block ends; if
        the block raises, the stroke is rolled back and the document is unchanged.
        """
        self.require_idle("start a stroke")
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
        """Set every covered texel of ``layer`` (or of one ``chart``) to ``thickness_um``; one undo step.

        ``thickness_um`` (µm) defaults to the material's default thickness and is clamped to the layer's
        maximum.
        """
        self.require_idle("fill")
        lay = self.resolve(layer)
        value = lay.default_thickness if thickness_um is None else thickness_value(thickness_um,
                                                                                           "fill thickness")
        atlas = self.atlas_at(lay.resolution)
        if chart is not None:
            charts = int(self.layout.charts)
            if not isinstance(chart, (int, np.integer)) or not 0 <= int(chart) < charts:
                raise DocumentError(f"chart must be an integer in 0..{charts - 1}, got {chart!r}")
        with Stroke(self, lay, Brush(mode="fill"), False, detail="fill") as s:
            s.fill_region(atlas, None if chart is None else int(chart), min(value, lay.max_thickness))

    def set_thickness(self, layer: Layer | int, values: np.ndarray, detail: str = "import") -> None:
        """Replace a layer's whole map (µm, finite, ≥ 0, shape (H, W) of the layer) as one undo step."""
        self.require_idle("replace a map")
        lay = self.resolve(layer)
        arr = np.asarray(values)
        if arr.shape != lay.data.shape:
            raise DocumentError(f"map is {arr.shape[1] if arr.ndim > 1 else '?'}×{arr.shape[0]}, layer "
                                f"{lay.name!r} is {lay.resolution}×{lay.resolution}")
        arr = arr.astype(np.float32)
        if not np.all(np.isfinite(arr)) or arr.min(initial=0.0) < 0 or arr.max(initial=0.0) > MAX_THICKNESS_UM:
            raise DocumentError(f"map values must be finite thickness in [0, {MAX_THICKNESS_UM:g}] µm")
        with Stroke(self, lay, Brush(mode="set"), False, detail=detail) as s:
            s.replace_all(arr)

    # ------------------------------------------------------------------------------------ history
    def push_step(self, step: Step) -> None:
        """Record a finished ``step`` on the undo history (clearing redo) and send the "history" event."""
        self.history.push(step)
        self.emit(ChangeEvent("history"))

    @property
    def can_undo(self) -> bool:
        """Whether :meth:`undo` would do something (never during a stroke)."""
        return self.history.can_undo and self._stroke is None

    @property
    def can_redo(self) -> bool:
        """Whether :meth:`redo` would do something (never during a stroke)."""
        return self.history.can_redo and self._stroke is None

    def undo(self) -> bool:
        """Undo the last step; returns False when there is none."""
        return self._undo_or_redo("undo")

    def redo(self) -> bool:
        """Redo the last undone step; returns False when there is none."""
        return self._undo_or_redo("redo")

    def _undo_or_redo(self, detail: Literal["undo", "redo"]) -> bool:
        """Undo (``detail`` "undo") or redo the step the history gives; returns False when there is none."""
        self.require_idle(detail)
        step = self.history.pop_undo() if detail == "undo" else self.history.pop_redo()
        if step is None:
            return False
        self._replay(step, detail)
        return True

    def _replay(self, step: Step, detail: str) -> None:
        self._replay_quietly(step, detail)
        self.emit(ChangeEvent("history"))

    def _replay_quietly(self, step: Step, detail: str) -> None:
        """Undo (``detail`` "undo") or redo ``step``'s edits, without the "history" event."""
        for delta in step.deltas:
            delta.swap()
            self.emit(ChangeEvent("paint", delta.layer.id, tuple(map(tuple, delta.tiles.tolist())), detail))
        fn = step.undo_fn if detail == "undo" else step.redo_fn
        if fn is not None:
            fn()

    def grouped(self, label: str) -> AbstractContextManager[None]:
        """``with doc.grouped(label):`` every step made inside becomes one undo step called ``label``.

        E.g. a look added as new layers (a step per layer and per stroke) is undone and redone at once. The
        steps are grouped when the block ends, also when it raises (what was done is one step to undo).
        """
        from contextlib import contextmanager

        @contextmanager
        def group() -> Iterator[None]:
            mark = self.history.undo_step
            try:
                yield
            finally:
                steps = self.history.take_since(mark)

                def undo() -> None:
                    for s in reversed(steps):
                        self._replay_quietly(s, "undo")

                def redo() -> None:
                    for s in steps:
                        self._replay_quietly(s, "redo")

                if steps:
                    self.push_step(Step(label, undo_fn=undo, redo_fn=redo, extra_bytes=sum(s.nbytes for s in steps)))

        return group()

    def clear_history(self) -> None:
        """Forget every undo and redo step."""
        self.history.clear()
        self.emit(ChangeEvent("history"))

    # ------------------------------------------------------------------------------------ picking
    @property
    def pick_mesh(self) -> trimesh.Trimesh:
        """The layout as a mesh, for picking (:mod:`painting.hit`).

        Built on the first pick and kept: its ray structures are reused.
        """
        if self._pick_mesh is None:
            self._pick_mesh = self.layout.trimesh()
        return self._pick_mesh

    def hit(self, origin: ArrayLike, direction: ArrayLike) -> Hit | None:
        """First surface hit of a ray (mesh units): a :class:`painting.hit.Hit` or None."""
        from painting.hit import ray_hit

        return ray_hit(self, origin, direction)

    def pick_depth(self, ndc_xy: ArrayLike, depth: float, inv_view_proj: ArrayLike) -> Hit | None:
        """Surface point from a depth-buffer value (see :func:`painting.hit.depth_hit`)."""
        from painting.hit import depth_hit

        return depth_hit(self, ndc_xy, depth, inv_view_proj)

    def mirror_point(self, point: ArrayLike) -> np.ndarray:
        """``point`` reflected about the head's midplane (mesh units)."""
        p = as_vec3(point, "point")
        meta = self.head.metadata
        c = np.asarray(meta.midplane_point, dtype=np.float64)
        n = np.asarray(meta.midplane_normal, dtype=np.float64)
        n = n / np.linalg.norm(n)
        return p - 2.0 * float(np.dot(p - c, n)) * n

    def mirror_vector(self, v: np.ndarray) -> np.ndarray:
        """Direction ``v`` reflected about the head's midplane."""
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
        values = read_thickness(path, expected_shape=lay.data.shape)
        self.set_thickness(lay, values, detail="import")

