"""Sheer's real-time cosmetic renderer (moderngl; never Qt).

Huang et al. 2013: Kubelka–Munk cosmetic layers evaluated **spectrally in texture space**, skin lit
through the makeup (E·T), screen-space subsurface scattering (Jimenez 2009 sum of Gaussians, or the
Jimenez 2015 separable kernel), out-scatter through the makeup T/(1 − R_bottom·R_skin) plus the makeup's
own reflection R_top·E, per-layer Kelemen/Szirmay-Kalos specular, tone mapping and sRGB.

Units: mesh units as loaded (see :mod:`painting.head`), the head's ``mm_per_unit`` for SSS widths,
thickness maps in µm, S and K per mm, wavelengths in nm, angles in degrees at the API.

What render may import: ``core``, ``km``, ``painting`` and ``project`` (the layers below it), numpy,
scipy and moderngl; never Qt (PySide6) nor ``app``, ``capture`` or ``bench`` (import-linter checks this;
see ``pyproject.toml``). It takes a ``moderngl.Context`` and renders into framebuffers it is given.

Studio API::

    from render import Renderer, Light, DocumentBinding

    r = Renderer(ctx, doc.head, layout=doc.layout)   # doc: painting.Document (head, UV layout, layers)
    binding = DocumentBinding(doc, r)         # the one document → GPU path: queues doc's ChangeEvents
                                              # ("paint": the touched 64² tiles, (row, col) per layer id;
                                              # other kinds: every layer read again)
    binding.flush()                           # once per frame, before r.render: pushes exactly what changed
    binding.close()                           # stop following doc
    # or without a document: r = Renderer(ctx, head); r.set_layers([LayerInput(material, thickness_um)])
    r.settings.mode = "fast"                  # "reference" | "off"; .taps 11/17/25; .exposure; .makeup
                                              # (False = before/after); .debug_view (render.DEBUG_VIEWS:
                                              # albedo, thickness (+ .debug_layer), r_top, transmittance,
                                              # irradiance, unlit)
    r.camera.yaw, r.camera.pitch, r.camera.distance = 20.0, 5.0, 9.0   # degrees, mesh units (.target, .fov_y)
    r.lights = [Light.directional(azimuth=30, elevation=20, intensity=1.2)]   # ≤ 8, head space
    r.set_environment("studio", intensity=0.3)            # HDR EXR by name or path, or None
    r.render(fbo, (0, 0, w, h))               # fbo = ctx.detect_framebuffer(...) in paintGL; viewport px.
                                              # Leaves fbo bound; writes colour only (sRGB-encoded).
    z = r.depth_at(x, y)                      # window depth [0, 1] of the last frame at pixel (x, y),
                                              # origin top-left, or None (background)
    p = r.pick(x, y)                          # surface point (mesh units) under the pixel, or None
    m = r.inverse_view_projection()           # 4×4 float64 of the last frame (column vectors);
                                              # r.unproject(x, y, z) does the maths
    r.release()                               # frees every GPU object (call with the context current)

An interactive view (the studio's viewport, the kiosk, the studio's image export) wraps the renderer in
:class:`render.view.ViewRenderer`: the frame kept and redrawn only when something it shows changed, the
brush ring (:mod:`render.ring`), the before/after split, the thickness view of a document layer and the
lightweight engine for a captured face.

Costs to know: lights are fixed to the head, so shadow maps and the texture-space irradiance are cached
and recomputed only when a light, the environment or the normal strength changes (a few hundred ms on
llvmpipe); orbiting and painting reuse them. A dab costs the KM evaluation of its tiles (≈ 5–10 ms per
64² tile) plus one frame. ``r.render_image((w, h))`` renders offscreen and returns uint8 pixels (top
row first); ``r.skin_pixel_mask()`` gives the last frame's skin pixels.

Reusable pieces (for other engines, e.g. a lightweight Phong engine):

- :mod:`render.shaders` — ``ShaderLibrary``: ``.glsl`` files in ``resources/shaders/`` loaded by name
  with ``#include "name.glsl"`` resolved (no GPU needed); ``program(ctx, vert, frag, defines)``.
- :mod:`render.gpu_head` — ``GpuHead``: the mesh in a VBO (position, normal, uv, tangent) + albedo
  (sRGB → linear), normal and optional specular/roughness textures; ``.vertex_array(program)``.
- :mod:`render.camera` — ``OrbitCamera`` (yaw, pitch, distance, fov, target) with view/projection (the
  matrices and their conventions: :mod:`core.camera`); :mod:`render.pinhole` — a photograph's camera as one.
- :mod:`render.lights` — ``Light`` (directional or point, colour, intensity), ``ShadowMaps`` (PCF depth
  maps for up to 8 lights), ``Environment`` (equirectangular EXR → 9 SH coefficients of irradiance).
- :mod:`render.km_pass` — ``KMTextureSpace``: the spectral texture-space KM evaluation (41 wavelengths,
  380–780 nm every 10 nm; outputs as 8-bit sRGB maps for display, or half/full floats).
- :mod:`render.irradiance` — ``TextureIrradiance`` (UV-space irradiance cache, padded across seams).
- :mod:`render.sss` — ``fast_kernel`` (pre-integrated separable SSS kernel), ``SKIN_GAUSSIANS`` (d'Eon
  2007 profile), ``reference_taps``; :mod:`render.sss_passes` — the SSS passes of a frame.
- :mod:`render.lit_pass` — ``LitPass``: the frame's lit pass (the head through the makeup into the
  G-buffer), its programs specialised per frame shape.
- :mod:`render.settings` — ``RenderSettings``, ``DEBUG_VIEWS``; :mod:`render.targets` — the frame's
  offscreen targets.
- :mod:`render.glutil` — ``release_all`` (release GL objects without leaving a deleted framebuffer bound),
  ``set_uniform`` / ``write_uniform``, ``read_depth``; :func:`render.lights.upload_lights` sets
  lighting.glsl's uniforms.
- shader includes: ``common.glsl`` (sRGB, tone map, constants), ``lighting.glsl`` (lights, PCF
  shadows from the atlas, SH irradiance), ``specular.glsl`` (Beckmann / Schlick / Kelemen),
  ``km.glsl`` (KM layer and stacking), ``head_vertex.glsl`` (the head's vertex attributes and world-space
  varyings), ``irradiance_targets.glsl`` (the irradiance cache's targets), ``lightweight.glsl`` (the
  lightweight face's specialisation defaults); vertex shaders ``mesh.vert`` (world space), ``uvspace.vert``
  (the mesh unwrapped into its UV space), ``fullscreen.vert`` (a full-screen triangle).
"""

from __future__ import annotations

from core.lazy import install_lazy

#: public name -> module that defines it
_EXPORTS: dict[str, str] = {
    "RenderError": "render.errors",
    "ShaderLibrary": "render.shaders",
    "OrbitCamera": "render.camera",
    "Light": "render.lights",
    "Environment": "render.lights",
    "ShadowMaps": "render.lights",
    "GpuHead": "render.gpu_head",
    "KMTextureSpace": "render.km_pass",
    "LayerInput": "render.km_pass",
    "Renderer": "render.renderer",
    "RenderSettings": "render.settings",
    "DEBUG_VIEWS": "render.settings",
    "DocumentBinding": "render.binding",
    "ViewRenderer": "render.view",
    "BrushRing": "render.ring",
}

__getattr__, __dir__, __all__ = install_lazy(__name__, _EXPORTS)
