"""Painting cosmetics on a 3D head: the document the studio and the renderer observe (no Qt, no GL).

Quick start::

    from painting import Document, Brush
    doc = Document.from_head(None)                     # the sample head; or a path to .glb/.obj/.ply
    layer = doc.add_layer("Foundation 1", resolution=2048)   # material by library name
    with doc.stroke(layer, Brush(radius_mm=8.0, hardness=0.5, strength=1.0, mode="add")) as s:
        s.dab((x, y, z))                               # a surface point in mesh units; pressure=1.0
    doc.undo(); doc.redo()
    layer.thickness        # float32 (H, W) µm, read-only view
    doc.atlas.position     # float32 (H, W, 3) mesh units per texel; doc.atlas.coverage bool (H, W)
    doc.head.mm_per_unit

Units: thickness µm; positions mesh units (exactly as trimesh loads the file); brush radius mm.
Texture space: row 0 is the top row and covers v ∈ [0, 1/H) (see :mod:`painting.head`).

Modules (each imports only the ones listed before it, plus ``core`` and ``km``):

- :mod:`painting.tiles` (the 64² tile), :mod:`painting.raster` (triangle rasterisation),
  :mod:`painting.head` (loading, metadata), :mod:`painting.maps_io` (PNG16/EXR thickness maps);
- :mod:`painting.layout` (mesh cleaning, UV check, xatlas unwrap: the paint UVs),
  :mod:`painting.kernels` (compiled dab kernels, numba, bit-identical to the numpy path),
  :mod:`painting.spatial` (texel grid), :mod:`painting.atlas` (the per-texel bake and its cache);
- :mod:`painting.brush` (Brush, modes), :mod:`painting.layer` (Layer, ChangeEvent, DocumentError),
  :mod:`painting.history` (undo), :mod:`painting.hit` (ray and depth picking), :mod:`painting.stroke`
  (the stroke engine: Stroke), :mod:`painting.document` (Document), :mod:`painting.looks` (named looks).

What painting may import: :mod:`core` and :mod:`km` (and numpy, scipy, trimesh, xatlas, numba, Pillow,
OpenEXR); never :mod:`project`, :mod:`render`, :mod:`capture`, :mod:`app`, Qt or GL (the import-linter
contracts in ``pyproject.toml`` check it).

Observing the document
----------------------
``unsubscribe = doc.subscribe(callback)`` calls ``callback(event)`` synchronously after every change,
with a frozen :class:`ChangeEvent`:

- ``kind="paint"``: texels of layer ``event.layer`` (a stable layer id) changed, only inside
  ``event.tiles`` — (tile row, tile column) indices of 64×64-texel tiles (texels
  ``[ty·64, ty·64+64) × [tx·64, tx·64+64)``). ``detail`` is "stroke" (one event per dab, while painting),
  "fill", "import", "undo", "redo" or "rollback". A renderer re-uploads just those tiles.
- ``kind="layers"``: the layer list or a layer field changed; ``detail`` is "added", "removed", "moved",
  "name", "visible", "opacity" or "max_thickness".
- ``kind="material"``: layer ``event.layer`` now uses another material, or its material was edited in
  the library (``detail="edited"``).
- ``kind="library"``: the document's material library was edited (``doc.replace_material``,
  ``doc.add_materials``, ``doc.remove_material``, or their undo); ``detail`` names the material to show.
- ``kind="history"``: ``doc.can_undo`` / ``doc.can_redo`` may have changed.

Callbacks must not edit the document re-entrantly during a stroke; exceptions propagate to the caller.

Layers
------
``doc.layers`` (bottom to top), ``doc.add_layer(material, resolution=None, name=None, max_thickness=None,
index=None)``, ``doc.remove_layer(layer)``, ``doc.move_layer(layer, index)``, ``doc.rename_layer``,
``doc.set_layer(layer, name=…, visible=…, opacity=…, max_thickness=…, material=…)``, ``doc.fill``,
``doc.set_thickness``, ``doc.export_layer`` / ``doc.import_layer``. A layer argument is a
:class:`Layer` or an index into ``doc.layers``; ``doc.layer_by_id(id)`` finds one by id. Every edit is one
undo step on the same stack as strokes.

Layer fields: ``id`` (stable), ``name``, ``material`` (library name), ``material_object`` (the library's
Material: what is drawn and saved; a library edit through ``doc.replace_material`` replaces it on every layer
of it, as one undo step), ``visible``, ``opacity`` ([0, 1], scales thickness: ``effective_thickness()``),
``max_thickness`` (µm, the most "add" builds up to), ``default_thickness`` (µm), ``resolution``,
``thickness``.

Strokes and undo
----------------
``with doc.stroke(layer, brush, mirror=None) as s: s.dab(point, pressure=1.0, normal=None)``. A stroke
is one undo step holding only the 64² tiles it touched (their previous values); undo/redo swap them
back bit-exactly. ``doc.history`` has ``nbytes``, ``peak_bytes``, ``budget_bytes`` (default 256 MB;
oldest steps dropped). A new edit clears redo. If the ``with`` block raises, the stroke is rolled back.
Bad input raises :class:`DocumentError` (a ``core.errors.SheerError``) and leaves the document unchanged.
See :mod:`painting.brush` for the modes (add, erase, smooth, set, fill), falloff, spacing, pressure,
mirror and back-face rejection.

Atlas
-----
``doc.layout`` (:class:`painting.layout.UVLayout`: the paint UVs — the file's own when valid, else an
xatlas unwrap — with ``vertex_map`` to the file's vertices, ``face_map``, charts, ``clean`` report and
``check`` verdict). ``doc.atlas`` / ``doc.atlas_at(res)`` (:class:`painting.atlas.Atlas`): ``position``,
``normal``, ``face`` (layout triangle), ``chart``, ``coverage`` (conservative), ``padded`` (texels
dilated beyond chart borders, copies of ``pad_src``), ``texel_mm``. Bakes are cached on disk
(:func:`painting.atlas.cache_dir`).

Picking
-------
``doc.hit(origin, direction)`` → :class:`Hit` (``face``, ``head_face``, ``barycentric``, ``point``,
``uv``, ``normal``, ``distance``) or None; ``doc.pick_depth(ndc_xy, depth, inv_view_proj)`` does the same
from a GL depth-buffer value (see :mod:`painting.hit`; both agree to well under 0.01 mm).
"""

from __future__ import annotations

from core.lazy import install_lazy

#: public name -> module that defines it
_EXPORTS: dict[str, str] = {
    "Document": "painting.document",
    "Layer": "painting.layer",
    "Stroke": "painting.stroke",
    "ChangeEvent": "painting.layer",
    "DocumentError": "painting.layer",
    "Brush": "painting.brush",
    "BrushError": "painting.brush",
    "MODES": "painting.brush",
    "Hit": "painting.hit",
    "PickError": "painting.hit",
    "Atlas": "painting.atlas",
    "AtlasError": "painting.layout",
    "UVLayout": "painting.layout",
    "CleanReport": "painting.layout",
    "Head": "painting.head",
    "HeadError": "painting.head",
    "HeadMetadata": "painting.head",
    "load_head": "painting.head",
    "LayerMask": "painting.mask",
    "RegionSet": "painting.regions",
    "RegionError": "painting.regions",
    "REGION_NAMES": "painting.regions",
}

__getattr__, __dir__, __all__ = install_lazy(__name__, _EXPORTS)
