"""An interactive view of one head: the renderer's frame kept and reused, the brush ring, before/after.

:class:`ViewRenderer` draws what the studio's viewport (and the kiosk's, and the studio's image export)
shows, around a :class:`render.renderer.Renderer`:

- the camera and the key light are copied in before each frame (the two other lights of
  :func:`render.lights.default_lights` stay), and the renderer's settings (mode, debug view,
  thickness-view layer) are set from the view's state;
- the made-up frame is kept in an offscreen target and drawn again only when something it shows changed
  (size, camera, lights, environment, layers — the KM pass's ``version`` —, settings): moving the brush
  ring alone costs a copy of that frame and one depth-tested pass of the mesh (:mod:`render.ring`);
- the before/after split renders the bare skin too and shows its left part;
- the thickness debug view maps the selected *document* layer to the renderer's *active* slot
  (:func:`debug_slot`);
- mode ``"lightweight"``: a captured face drawn by :class:`render.lightweight.LightweightRenderer`
  (Paris et al. 2003) with the same camera and lights and the physical renderer's texture-space KM
  outputs as its makeup — as ``sheer render --mode lightweight``.

The layers come from :meth:`render.renderer.Renderer.set_layers` on :attr:`ViewRenderer.r`, usually
through a :class:`render.binding.DocumentBinding` flushed before each frame. Sizes are in pixels.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable, Hashable, Sequence

    import moderngl

    from km.library import Library
    from painting import Document
    from painting.head import Head
    from painting.layout import UVLayout
    from render.binding import DocumentBinding
    from render.camera import OrbitCamera
    from render.captured import CapturedFace
    from render.km_pass import LayerInput
    from render.lights import Light
    from render.lightweight import LightweightRenderer
    from render.region_overlay import RegionOverlay
    from render.ring import BrushRing

#: The view's render modes: the physical renderer's two SSS modes, and the lightweight engine.
RENDER_MODES: tuple[str, ...] = ("fast", "reference", "lightweight")


def debug_views() -> list[str]:
    """The renderer's view names, index 0 the normal image (``render.DEBUG_VIEWS``)."""
    from render.settings import DEBUG_VIEWS

    return list(DEBUG_VIEWS)


def debug_slot(active: Sequence[int], layer_index: int) -> int | None:
    """The renderer's slot for document layer ``layer_index`` in the thickness view.

    ``settings.debug_layer`` indexes the renderer's *active* layers (``renderer.km.active``: the visible,
    non-transparent document layers, bottom first), not the document's: with a hidden layer below the
    selected one the two differ.

    Returns:
        The slot (0-based), or None when the layer is not active (hidden): it has nothing to show.
    """
    active = list(active)
    return active.index(layer_index) if layer_index in active else None


class ViewRenderer:
    """A :class:`render.renderer.Renderer` drawing one view into a framebuffer it is given (see module doc).

    Attributes:
        r: the physical renderer (its ``km`` holds the layers).
        environment: the HDR environment's name, ``"none"`` for none.
        layer_index: the document layer the thickness view shows.
        debug_hidden: the thickness view's layer is hidden (the view shows the image instead).
        frames_drawn: frames drawn by an engine (not ring-only redraws).
        face: a captured face (:class:`render.captured.CapturedFace`) for the lightweight mode, or None.
        drawn_by: the mode that drew the kept frame.
        interactive: the kept frame is an interactive one (see :meth:`render`).
        scale: the kept frame's internal scale, (0, 1] (1: full resolution).
    """

    name = "render.Renderer"

    def __init__(self, ctx: moderngl.Context, head: Head, layout: UVLayout | None = None) -> None:
        """Build the renderer for ``head`` (see :class:`render.renderer.Renderer`) and the view's programs."""
        from render.renderer import Renderer
        from render.ring import RingOverlay

        self.ctx = ctx
        self.r = Renderer(ctx, head, layout=layout)
        self.views = debug_views()
        self.ring = RingOverlay(ctx, self.r.shaders, self.r.gpu_head)
        self.copy_prog = self.r.shaders.program(ctx, "frame_copy.vert", "frame_copy.frag")
        self.copy_vao = ctx.vertex_array(self.copy_prog, [])
        self._frame: moderngl.Framebuffer | None = None  # the made-up frame (colour) + the mesh's depth
        self._low: moderngl.Framebuffer | None = None  # an interactive frame at its reduced size
        self._low_before: moderngl.Framebuffer | None = None  # its bare twin for the split
        self._before: moderngl.Framebuffer | None = None  # the bare skin, for the before/after split
        self._before_lw: moderngl.Framebuffer | None = None  # its colour with a depth buffer (lightweight)
        self._scene_key: Hashable = None
        self._depth_key: Hashable = None  # the view (size, camera) whose mesh depth _frame holds
        self._blit_ok = True
        self._env: str | None = None
        self.environment = "none"
        self.layer_index = 0
        self.debug_hidden = False
        self.frames_drawn = 0
        self.face: CapturedFace | None = None
        self._lw: LightweightRenderer | None = None  # the lightweight engine, created on first use
        self.drawn_by = ""
        self.interactive = False  # the kept frame is an interactive one (reduced scale, fast mode)
        self.scale = 1.0  # the kept frame's internal scale (1.0: full resolution)

    # ------------------------------------------------------------------ the lightweight engine
    def set_face(self, face: CapturedFace | None) -> None:
        """Use ``face`` (a ``CapturedFace`` of this head) in the lightweight mode; None removes it."""
        if self._lw is not None:
            self._lw.release()
            self._lw = None
        self.face = face
        self._scene_key = None

    def _lightweight(self) -> LightweightRenderer:
        """The lightweight engine with the physical renderer's camera, lights, environment and makeup."""
        from core.errors import SheerError

        if self.face is None:
            raise SheerError("the lightweight mode needs a captured face (File → Open Captured Face…)")
        if self._lw is None:
            from render.lightweight import LightweightRenderer

            self._lw = LightweightRenderer(self.ctx, self.r.head, self.face)
        lw = self._lw
        lw.camera, lw.lights, lw.environment = self.r.camera, list(self.r.lights), self.r.environment
        lw.makeup = self.r.km if self.r.km.active else None
        return lw

    @property
    def active(self) -> list[int]:
        """Document indices of the layers the renderer draws (visible, bottom first)."""
        return list(self.r.km.active)

    # ------------------------------------------------------------------ frames
    def _sync(self, camera: OrbitCamera, key_light: Light, debug: int, mode: str, interactive: bool = False) -> None:
        from render.lights import default_lights

        c = self.r.camera
        c.yaw, c.pitch, c.distance = float(camera.yaw), float(camera.pitch), float(camera.distance)
        c.target = np.asarray(camera.target, float)
        c.fov_y = float(camera.fov_y)
        self.r.lights = [key_light, *default_lights()[1:]]
        if self.environment != self._env:
            self.r.set_environment(None if self.environment in ("", "none") else self.environment)
            self._env = self.environment
        s = self.r.settings
        s.mode = mode if mode in ("fast", "reference") else "fast"
        s.interactive = interactive
        view = self.views[debug] if 0 <= debug < len(self.views) else "none"
        self.debug_hidden = False
        if view == "thickness":
            slot = debug_slot(self.r.km.active, self.layer_index)
            if slot is None:  # the selected layer is hidden: show the image (the viewport says why)
                self.debug_hidden, view = True, "none"
            else:
                s.debug_layer = slot
        s.debug_view = view

    def _targets(self, size: tuple[int, int], split: bool) -> tuple[moderngl.Framebuffer,
                                                                        moderngl.Framebuffer | None]:
        """The kept frame at ``size``, and the bare one if ``split`` (else None); made on first use."""
        if self._frame is not None and self._frame.size != size:
            self._release_targets()
        if self._frame is None:
            self._frame = self.ctx.framebuffer([self.ctx.texture(size, 4)], self.ctx.depth_texture(size))
            self._scene_key = None
        if split and self._before is None:
            self._before = self.ctx.framebuffer([self.ctx.texture(size, 4)])
        return self._frame, self._before if split else None

    def render(self, fbo: moderngl.Framebuffer, size: tuple[int, int], camera: OrbitCamera, key_light: Light, *,
               split: float = 0.0, debug: int = 0, mode: str = "fast", ring: BrushRing | None = None,
               interactive: bool = False, scale: float = 1.0) -> bool:
        """Draw the view into ``fbo``.

        Args:
            fbo: the target (e.g. ``ctx.detect_framebuffer(...)`` in a widget's paint); left bound.
            size: the view's width and height in pixels.
            camera: the view's camera (copied into the renderer's).
            key_light: the key light (head space); the default rig's fill and rim lights stay.
            split: the before/after split's position, a fraction of the width in [0, 1] (0 = no split).
            debug: an index into :func:`debug_views` (0 = the image).
            mode: one of :data:`RENDER_MODES`.
            ring: the brush ring to draw over the frame, or None.
            interactive: an interactive frame (progressive refinement, :mod:`render.progressive`): the
                physical renderer draws in fast mode at ``scale`` of ``size`` and the frame is upscaled
                (bilinear) to ``size``; the lightweight engine, cheap enough, always draws at full size.
            scale: the interactive frame's internal scale, in (0, 1]; ignored for a full frame.

        Returns:
            True when an engine drew a new frame, False when the kept frame was reused (only the ring moved).
        """
        from render.progressive import scaled_size

        w, h = size
        # bind the target first: creating a framebuffer makes moderngl re-bind the one it last knew, which
        # may be the widget's previous one (Qt replaces it on a resize): GL_INVALID_OPERATION
        fbo.use()
        frame, before = self._targets((w, h), split > 0.0)
        low_size = scaled_size((w, h), scale) if interactive and mode != "lightweight" else (w, h)
        reduced = low_size != (w, h)
        view_key = (w, h, float(camera.yaw), float(camera.pitch), float(camera.distance),
                    tuple(np.asarray(camera.target, float).tolist()), float(camera.fov_y))
        key = (*view_key, dataclasses.astuple(key_light), self.environment, float(split), int(debug),
               "fast" if reduced else mode, low_size, self.layer_index, self.r.km.version)
        fresh = key != self._scene_key
        if fresh:
            self._sync(camera, key_light, debug, "fast" if reduced else mode, bool(interactive))
            if mode == "lightweight":
                self._draw_lightweight(frame, before)
            elif reduced:
                self._draw_reduced(before is not None, low_size)
            else:
                self._draw_physical(frame, before)
                self._depth_key = None  # the renderer cleared the frame's depth
            self.drawn_by = mode
            self.interactive = bool(interactive)
            self.scale = low_size[1] / h if reduced else 1.0
            self._scene_key = key
            self.frames_drawn += 1
        fbo.use()
        ctx = self.ctx
        ctx.viewport = (0, 0, w, h)
        ctx.scissor = None
        ctx.disable(ctx.DEPTH_TEST | ctx.BLEND)
        self._show(fbo, frame, before, split)
        if ring is not None:
            self._draw_ring(fbo, frame, camera, ring, view_key)
        return fresh

    def _draw_physical(self, frame: moderngl.Framebuffer, before: moderngl.Framebuffer | None) -> None:
        """The kept frame, and the bare one for the split, by the physical renderer."""
        if before is not None:
            s = self.r.settings
            s.makeup = False
            try:
                self.r.render(before, (0, 0, *before.size))
            finally:
                s.makeup = True
        self.r.render(frame, (0, 0, *frame.size))

    def _draw_reduced(self, before: bool, low_size: tuple[int, int]) -> None:
        """An interactive frame: the physical renderer at ``low_size`` into the interactive targets.

        The renderer never reads outside its own targets, which are exactly ``low_size``; the frame is
        upscaled (bilinear) when it is drawn into the view (:meth:`_show`), so an interactive frame costs
        one full-resolution pass, not an upscale and a copy. The kept full frame and its depth (the
        ring's) are left as they are.
        """
        low, low_before = self._low_targets(low_size, before)
        self._draw_physical(low, low_before)

    def _low_targets(self, size: tuple[int, int], split: bool) -> tuple[moderngl.Framebuffer,
                                                                           moderngl.Framebuffer | None]:
        """The interactive frame's colour targets at ``size`` (and the bare one if ``split``)."""
        from render.glutil import release_all

        if self._low is not None and self._low.size != size:
            release_all(self.ctx, [o for fb in (self._low, self._low_before) if fb is not None
                                   for o in (*fb.color_attachments, fb)])
            self._low = self._low_before = None
        for name in ("_low", "_low_before") if split else ("_low",):
            if getattr(self, name) is None:
                tex = self.ctx.texture(size, 4)
                tex.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
                tex.repeat_x = tex.repeat_y = False
                setattr(self, name, self.ctx.framebuffer([tex]))
        assert self._low is not None
        return self._low, self._low_before if split else None

    def _draw_lightweight(self, frame: moderngl.Framebuffer, before: moderngl.Framebuffer | None) -> None:
        """The kept frame, and the bare one for the split, by the lightweight engine."""
        lw = self._lightweight()
        if before is not None:
            makeup, lw.makeup = lw.makeup, None
            lw.render(self._with_depth(before), (0, 0, *before.size))
            lw.makeup = makeup
        lw.render(frame, (0, 0, *frame.size))
        self._depth_key = None  # the engine wrote its own depth into the frame: the ring pass redoes it

    def _with_depth(self, before: moderngl.Framebuffer) -> moderngl.Framebuffer:
        """The bare frame's colour with a depth attachment (the lightweight engine depth-tests)."""
        if self._before_lw is None or self._before_lw.size != before.size:
            from render.glutil import release_all

            if self._before_lw is not None:
                release_all(self.ctx, [self._before_lw, self._before_lw.depth_attachment])
            self._before_lw = self.ctx.framebuffer(before.color_attachments, self.ctx.depth_renderbuffer(before.size))
        return self._before_lw

    def _show(self, fbo: moderngl.Framebuffer, frame: moderngl.Framebuffer, before: moderngl.Framebuffer | None,
              split: float) -> None:
        """The kept frame (upscaled if interactive), and the bare one left of the split, into ``fbo``."""
        w, h = frame.size
        if self.scale < 1.0 and self._low is not None:
            frame, before = self._low, self._low_before if before is not None else None
        if before is not None:
            self._draw_quad(frame.color_attachments[0], 1.0)
            self._draw_quad(before.color_attachments[0], float(split) * 2.0 - 1.0)
            self.ctx.scissor = (max(int(split * w) - 1, 0), 0, 2, h)
            fbo.clear(1.0, 1.0, 1.0, 1.0)
            self.ctx.scissor = None
        elif frame.size != (w, h):
            self._draw_quad(frame.color_attachments[0], 1.0)  # bilinear upscale of an interactive frame
        else:
            self._copy_frame(fbo, frame)

    def _copy_frame(self, fbo: moderngl.Framebuffer, frame: moderngl.Framebuffer) -> None:
        """The kept frame into ``fbo``.

        A framebuffer blit (≈ 1.5 ms at 1280×720 on llvmpipe), or a textured quad where the blit is refused.
        """
        if self._blit_ok:
            self.ctx.copy_framebuffer(fbo, frame)
            if self.ctx.error == "GL_NO_ERROR":
                fbo.use()
                return
            self._blit_ok = False  # e.g. a multisampled target: the quad from now on
            fbo.use()
        self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.BLEND)
        self._draw_quad(frame.color_attachments[0], 1.0)

    def _draw_ring(self, fbo: moderngl.Framebuffer, frame: moderngl.Framebuffer, camera: OrbitCamera,
                   ring: BrushRing, view_key: Hashable) -> None:
        """The brush ring against the mesh's depth (drawn into the kept frame once per view).

        The depth depends on the view (size and camera) only: painting, which changes every frame but not
        the view, reuses it.
        """
        w, h = frame.size
        view_proj, view = camera.view_projection(w / max(h, 1)), camera.view()
        if self._depth_key != view_key:
            self.ring.draw_depth(frame, view_proj, view)
            self._depth_key = view_key
            fbo.use()
            self.ctx.viewport = (0, 0, w, h)
        self.ring.draw(fbo, frame.depth_attachment, ring, view_proj, view)

    def _draw_quad(self, texture: moderngl.Texture, right: float) -> None:
        texture.use(0)
        self.copy_prog["u_src"].value = 0
        self.copy_prog["u_right"].value = right
        self.copy_vao.render(self.ctx.TRIANGLE_STRIP, vertices=4)

    # ------------------------------------------------------------------ what the app asks of the renderer
    def set_layers(self, layers: list[LayerInput]) -> None:
        """Replace the cosmetic layers and evaluate them (:meth:`render.renderer.Renderer.set_layers`)."""
        self.r.set_layers(layers)

    def bind_document(self, document: Document, library: Library | None = None,
                      on_change: Callable[[], None] | None = None) -> DocumentBinding:
        """A :class:`render.binding.DocumentBinding` of ``document`` to this view's renderer (close it when done)."""
        from render.binding import DocumentBinding

        return DocumentBinding(document, self.r, library, on_change=on_change)

    @property
    def defer_cache(self) -> bool:
        """Full frames leave an out-of-date lighting cache to :meth:`build_deferred_cache` (the settle frames).

        The renderer's :attr:`render.renderer.Renderer.defer_cache`.
        """
        return self.r.defer_cache

    @defer_cache.setter
    def defer_cache(self, on: bool) -> None:
        self.r.defer_cache = on

    def build_deferred_cache(self) -> bool:
        """Rebuild what a :attr:`defer_cache` frame left out of date (context current); True if anything was."""
        return self.r.build_deferred_cache()

    def region_overlay(self) -> RegionOverlay:
        """A :class:`render.region_overlay.RegionOverlay` drawn with this view's programs on its head."""
        from render.region_overlay import RegionOverlay

        return RegionOverlay(self.ctx, self.r.shaders, self.r.gpu_head)

    def skin_pixel_mask(self) -> np.ndarray:
        """The last frame's skin pixels, bool (H, W), top row first (the renderer's ``skin_pixel_mask``)."""
        return self.r.skin_pixel_mask()

    def invalidate(self) -> None:
        """Draw a new frame next time even if nothing the key covers changed."""
        self._scene_key = None

    def pick(self, x: int, y: int, camera: OrbitCamera | None = None) -> np.ndarray | None:
        """The surface point (mesh units) under pixel (x, y) of the last frame (origin top-left), or None.

        A lightweight frame is picked from its own depth (``camera``: the frame's camera).
        """
        if self.drawn_by != "lightweight" or self._frame is None or camera is None:
            if self._frame is None or self.scale == 1.0:
                p = self.r.pick(x, y)
                return None if p is None else np.asarray(p, float)
            # an interactive frame: the renderer's depth is at its reduced size (pixel centres mapped)
            (fw, fh), (lw, lh) = self._frame.size, self.r.last.size
            xl, yl = (x + 0.5) * lw / fw - 0.5, (y + 0.5) * lh / fh - 0.5
            z = self.r.depth_at(min(max(int(round(xl)), 0), lw - 1), min(max(int(round(yl)), 0), lh - 1))
            return None if z is None else np.asarray(self.r.unproject(xl, yl, z), float)
        from painting.hit import pixel_to_ndc, unproject
        from render.glutil import read_depth

        z = read_depth(self._frame, x, y)
        if z is None:
            return None
        w, h = self._frame.size
        inv = np.linalg.inv(camera.view_projection(w / max(h, 1)))
        return unproject(pixel_to_ndc(x, y, w, h), z, inv)

    def render_image(self, size: tuple[int, int], camera: OrbitCamera, key_light: Light,
                     mode: str = "fast") -> np.ndarray:
        """An offscreen frame of ``size`` (width, height in pixels) as uint8 (H, W, 3), top row first."""
        self._sync(camera, key_light, 0, mode)
        self._scene_key = None
        render: Callable[[tuple[int, int]], np.ndarray] = (
            self._lightweight().render_image if mode == "lightweight" else self.r.render_image)
        return render(size)

    def _release_targets(self) -> None:
        from render.glutil import release_all

        objs: list[Any] = []
        for fb in (self._frame, self._before, self._low, self._low_before):
            if fb is not None:
                objs += [*fb.color_attachments, *([fb.depth_attachment] if fb.depth_attachment else []), fb]
        if self._before_lw is not None:
            objs += [self._before_lw.depth_attachment, self._before_lw]
        release_all(self.ctx, objs)
        self._frame = self._before = self._before_lw = self._low = self._low_before = None
        self._scene_key = self._depth_key = None

    def release(self) -> None:
        """Free every GPU object (call with the context current)."""
        from render.glutil import release_all

        self._release_targets()
        if self._lw is not None:
            self._lw.release()
            self._lw = None
        self.ring.release()
        release_all(self.ctx, [self.copy_vao, self.copy_prog])
        self.r.release()


def preload_renderer(progress: object = None, cancelled: object = None) -> bool:
    """Import the renderer and load the spectral → RGB matrices it and the swatches need.

    Meant for a worker thread (the arguments are a task runner's progress and cancel callbacks, unused):
    the matrices come from km's disk cache, or (the first run on a machine) are made with colour-science,
    which takes seconds to import.

    Returns:
        True.
    """
    import importlib

    importlib.import_module("render.renderer")
    from km.cache import spectral_rgb_matrix_cached
    from km.spectra import DEFAULT_GRID
    from render.km_pass import default_wavelengths, spectral_matrix

    spectral_matrix(default_wavelengths())
    spectral_rgb_matrix_cached(DEFAULT_GRID.wavelengths)
    return True
