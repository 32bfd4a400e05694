"""Texture-space Kubelka–Munk: per texel, the cosmetic stack evaluated **spectrally** on the GPU.

For every texel and every wavelength of the material grid (380–780 nm, 5 nm: 81 samples), each layer's
R0 and T (Huang 2013 Eq. 1–2, written with e^{−bSX} so it never overflows and stays exact as S → 0 or
K → 0) are stacked bottom-up with Eq. 3–4 (inter-reflections), giving R_top (the stack seen from
above, over black), T (total transmittance) and R_bottom (seen from below, from the skin). Each spectrum
is reduced to linear sRGB on the fly with a precomputed wavelength → RGB matrix (a spectrum → RGB
conversion is linear, so ``rgb = Σ_λ M[λ]·R(λ)``; M comes from ``km.colour.spectrum_to_rgb`` of the
identity, so white reflectance maps to (1, 1, 1)).

Outputs (textures in the head's UV space, same size as the thickness maps; row 0 = v 0):
``r_top`` RGBA (a = coverage of skin-smoothing layers such as foundation), ``transmittance`` RGBA (a = the
roughness of that smoothing layer), ``r_bottom`` RGBA, and ``spec0``/``spec1`` (per-layer specular
weights of layers 0–3 / 4–7: coverage × luminance transmittance of the layers above, for the
bottom-up layered specular of the lit pass).
Thickness maps are float32 µm; a layer's ``opacity`` scales its thickness. Only dirty 64² tiles are
re-evaluated by :meth:`KMTextureSpace.update_tiles`. Which layers are non-zero in each 64² tile is
tracked from the uploaded maps; tiles are drawn in groups of the same set of layers and each draw
evaluates only those (an empty tile costs no spectral work; llvmpipe cannot skip a branch).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from km.srgb import srgb_decode
from painting.tiles import TILE, tile_rects
from render.errors import RenderError

if TYPE_CHECKING:
    from collections.abc import Iterable

    import moderngl

    from km.library import Material
    from render.shaders import ShaderLibrary

MAX_LAYERS = 8

#: updates of at most this many tiles evaluate each in a scratch target across two rasteriser bins
SPLIT_TILES = 4
#: output formats of :class:`KMTextureSpace` (see its docstring)
KM_DTYPES = ("srgb8", "f2", "f4")
GL_SRGB8_ALPHA8 = 0x8C43

#: material categories whose coverage smooths the skin (their roughness replaces the skin's)
SMOOTHING_CATEGORIES = ("foundation", "primer", "concealer", "powder")
#: luminance weights of linear sRGB
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def km_defines(n: int, n_wavelengths: int, dtype: str) -> dict[str, int]:
    """The defines of ``km.frag``: ``n`` layers (1..:data:`MAX_LAYERS`) over ``n_wavelengths`` samples.

    ``dtype``: how the outputs are written (one of :data:`KM_DTYPES`).
    """
    return {"NW": n_wavelengths, "MAX_LAYERS": MAX_LAYERS, "NL": n, "SRGB_OUT": int(dtype == "srgb8")}


def layer_spec_params(material: Material) -> tuple[float, float, float, float]:
    """(Beckmann roughness, Fresnel F0 from the IOR, smooths skin 1/0, coverage scale µm) of a material.

    Coverage of a layer of thickness X is 1 − exp(−X / scale), scale = 0.3 × the material's usual
    thickness (clamped to 0.5–10 µm): a layer's gloss and smoothing fade in as it builds up.
    """
    rough = float(getattr(material, "roughness", 0.3))
    ior = float(getattr(material, "ior", 1.5))
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2
    usual = float(getattr(material, "thickness_um", getattr(material, "default_thickness_um", 10.0)) or 10.0)
    smooth = 1.0 if getattr(material, "category", "") in SMOOTHING_CATEGORIES else 0.0
    return (rough, f0, smooth, float(np.clip(0.3 * usual, 0.5, 10.0)))


@dataclass
class LayerInput:
    """One cosmetic layer for the renderer: a ``km.Material`` and its thickness map.

    Attributes:
        material: the layer's material (S and K per mm over its wavelengths, roughness, IOR, category).
        thickness: float (H, W) µm, row 0 = v 0; NaN and negative values count as 0.
        opacity: [0, 1], scales the thickness.
        visible: hidden layers keep their place (index) but are not evaluated.
        name: for messages.
    """

    material: Material
    thickness: np.ndarray
    opacity: float = 1.0
    visible: bool = True
    name: str = ""


def clean_thickness(thickness: np.ndarray) -> np.ndarray:
    """A thickness map (µm) as a new C-ordered float32 array with NaN, ±inf and negatives set to 0.

    Two passes over the map (``fmax`` copies and clears NaN and negatives, a ``max`` finds an infinity)
    where ``nan_to_num`` + ``maximum`` made six and three temporaries: 7 ms instead of 24 at 2048², and
    up to 0.5 s of a loaded start-up's first frame.
    """
    a = np.fmax(np.asarray(thickness), np.float32(0.0), dtype=np.float32, order="C")
    if a.size and not np.isfinite(a.max()):
        a[np.isinf(a)] = 0.0
    return a


def tile_presence(a: np.ndarray, tile: int = TILE) -> np.ndarray:
    """Bool (rows, columns) of ``tile``² blocks: where the (cleaned, ≥ 0) map ``a`` is non-zero."""
    h, w = a.shape
    ty, tx = -(-h // tile), -(-w // tile)
    nz = a > 0
    if (h, w) != (ty * tile, tx * tile):
        padded = np.zeros((ty * tile, tx * tile), bool)
        padded[:h, :w] = nz
        nz = padded
    return nz.reshape(ty, tile, tx, tile).any(axis=(1, 3))


#: The renderer's spectral grid: 380–780 nm every 10 nm (41 wavelengths). km's own grid is 5 nm; integrating
#: the layer stacks of the default library at 10 nm instead moves their colour by at most ΔE2000 0.008
#: (mean 0.001, 300 random three-layer stacks over skin-like backgrounds; 20 nm would give 0.06), and 10 nm is
#: the interval spectrophotometers report, so no measured feature is lost. It halves the texture-space
#: pass, whose cost is per wavelength (tests/render/test_km.py checks ΔE2000 < 0.01 over 120 such stacks,
#: composed spectrally on the CPU and from this GPU pass's outputs as the renderer composes them).
RENDER_STEP_NM = 10.0


def default_wavelengths() -> np.ndarray:
    """The renderer's wavelengths (nm), see :data:`RENDER_STEP_NM`."""
    return np.arange(380.0, 780.0 + 1e-9, RENDER_STEP_NM)


def spectral_matrix(wavelengths: np.ndarray) -> np.ndarray:
    """The (n, 3) matrix M with ``rgb = spectrum @ M`` (linear sRGB under km's default illuminant).

    km's own conversion (``km.colour.spectral_rgb_matrix``) of ``wavelengths`` (nm), so the GPU matches km
    exactly, through km's disk cache (:func:`km.cache.spectral_rgb_matrix_cached`: start-up then never
    imports colour-science).
    """
    from km.cache import spectral_rgb_matrix_cached

    return np.array(spectral_rgb_matrix_cached(np.asarray(wavelengths, dtype=np.float64)), dtype=np.float64)


def material_sk(material: Material, wavelengths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """S and K (per mm) of ``material`` on ``wavelengths`` (linear interpolation, clamped at the ends)."""
    mwl = np.asarray(material.wavelengths, dtype=np.float64)
    s = np.interp(wavelengths, mwl, np.asarray(material.S, dtype=np.float64))
    k = np.interp(wavelengths, mwl, np.asarray(material.K, dtype=np.float64))
    return s, k


class KMTextureSpace:
    """GPU evaluation of the cosmetic stack in texture space (see the module docstring).

    ``dtype`` of the outputs: ``"srgb8"`` (default, for display: R_top, T and R_bottom as 8-bit sRGB-encoded
    ``GL_SRGB8_ALPHA8``, which the sampler decodes to linear, so steps are ~0.4 % of the value down to
    1e-3 instead of 1/255 absolute; the alphas and the specular weights as linear 8-bit. llvmpipe samples
    8-bit textures about 1.5× faster than half floats, and the lit pass takes five of these fetches per
    pixel), ``"f2"`` (half float) or ``"f4"`` (exact comparisons). ``set_layers`` uploads every map and
    evaluates everything; ``update_tiles`` re-uploads and re-evaluates only the listed (row, col) tiles.
    With no visible layer the outputs are 1×1 (R 0, T 1).
    """

    def __init__(self, ctx: moderngl.Context, shaders: ShaderLibrary, dtype: str = "srgb8") -> None:
        if dtype not in KM_DTYPES:
            raise RenderError(f"KM output dtype must be one of {', '.join(KM_DTYPES)}, got {dtype!r}")
        self.ctx = ctx
        self.dtype = dtype
        self.wavelengths = default_wavelengths()
        self.matrix = spectral_matrix(self.wavelengths)
        nw = len(self.wavelengths)
        self.shaders = shaders
        self._programs: dict[int, tuple[moderngl.Program, moderngl.VertexArray]] = {}
        self.ubo = ctx.buffer(reserve=(MAX_LAYERS * nw + nw) * 16)
        self.size: tuple[int, int] = (0, 0)
        self.layers: list[LayerInput] = []
        self.active: list[int] = []  # indices of visible layers, bottom first
        self.thickness_textures: list[moderngl.Texture] = []
        # the outputs and their framebuffer (made by _alloc below)
        self.r_top: Any = None
        self.transmittance: Any = None
        self.r_bottom: Any = None
        self.spec0: Any = None
        self.spec1: Any = None
        self.fbo: Any = None
        self.layer_spec = np.zeros((MAX_LAYERS, 4), np.float32)
        self.version = 0
        #: evaluations of the whole map (set_layers); tiles re-evaluated since (consumers take them)
        self.full_version = 0
        self.dirty_tiles: list[tuple[int, int]] = []
        #: per active slot, per 64² tile (row, column): the uploaded map is non-zero somewhere in it
        self.present = np.zeros((0, 0, 0), bool)
        self._max_tiles = 16384
        self._cleaned: list[np.ndarray] = []
        self._scratch: list[moderngl.Texture] = []
        self._scratch_fbo: moderngl.Framebuffer | None = None
        self._copy: moderngl.Program | None = None
        self._copy_vao: moderngl.VertexArray | None = None
        self.vbo = ctx.buffer(reserve=self._max_tiles * 6 * 8)
        self._alloc((1, 1))
        self._clear_outputs()

    # -- resources ---------------------------------------------------------------------------------
    def _alloc(self, size: tuple[int, int]) -> None:
        if size == self.size and self.fbo is not None:
            return
        old = (self.fbo, self.r_top, self.transmittance, self.r_bottom, self.spec0, self.spec1)
        self.r_top, self.transmittance, self.r_bottom = (self._output_texture(size, srgb=True) for _ in range(3))
        self.spec0, self.spec1 = (self._output_texture(size, srgb=False) for _ in range(2))
        for t in (self.r_top, self.transmittance, self.r_bottom, self.spec0, self.spec1):
            t.repeat_x = t.repeat_y = False
        # create the new framebuffer before releasing the old one, and bind it: moderngl re-binds the
        # "current" framebuffer after creating one, which must not be a deleted object
        self.fbo = self.ctx.framebuffer([self.r_top, self.transmittance, self.r_bottom, self.spec0, self.spec1])
        self.fbo.use()
        for obj in old:
            if obj is not None:
                obj.release()
        self.size = size

    def _output_texture(self, size: tuple[int, int], srgb: bool, scratch: bool = False) -> moderngl.Texture:
        """An output map of ``size`` texels: 8-bit, or float per ``dtype``.

        8-bit colour is sRGB-encoded if ``srgb``; a ``scratch`` copy source stays plain RGBA8 so that
        copying moves the encoded bytes unchanged.
        """
        if self.dtype != "srgb8":
            return self.ctx.texture(size, 4, dtype=self.dtype)
        if srgb and not scratch:
            return self.ctx.texture(size, 4, internal_format=GL_SRGB8_ALPHA8)
        return self.ctx.texture(size, 4)

    def _clear_outputs(self) -> None:
        self.fbo.use()
        self.fbo.viewport = (0, 0, *self.size)
        self.fbo.scissor = None
        self.ctx.clear_color = (0, 0, 0, 0)
        # attachment 1 (T) must be 1: clear all, then draw the empty stack
        self._draw([])

    def _set_thickness_textures(self, n: int, size: tuple[int, int]) -> None:
        for t in self.thickness_textures[n:]:
            t.release()
        self.thickness_textures = self.thickness_textures[:n]
        for i, t in enumerate(self.thickness_textures):
            if t.size != size:
                t.release()
                self.thickness_textures[i] = self._new_thickness(size)
        while len(self.thickness_textures) < n:
            self.thickness_textures.append(self._new_thickness(size))

    def _new_thickness(self, size: tuple[int, int]) -> moderngl.Texture:
        t = self.ctx.texture(size, 1, dtype="f4")
        t.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
        t.repeat_x = t.repeat_y = False
        return t

    # -- inputs ------------------------------------------------------------------------------------
    @staticmethod
    def _check_map(layer: LayerInput, where: str) -> np.ndarray:
        a = np.asarray(layer.thickness)
        if a.ndim != 2 or a.shape[0] < 1 or a.shape[1] < 1:
            raise RenderError(f"{where}: thickness map must be a 2D array, got shape {a.shape}")
        if not np.issubdtype(a.dtype, np.floating):
            raise RenderError(f"{where}: thickness map must be float (µm), got {a.dtype}")
        return a

    def _upload_params(self) -> None:
        nw = len(self.wavelengths)
        data = np.zeros((MAX_LAYERS * nw + nw, 4), np.float32)
        self.layer_spec[:] = 0.0
        for slot, i in enumerate(self.active):
            self.layer_spec[slot] = layer_spec_params(self.layers[i].material)
            s, k = material_sk(self.layers[i].material, self.wavelengths)
            data[slot * nw:(slot + 1) * nw, 0] = s
            data[slot * nw:(slot + 1) * nw, 1] = k
            data[slot * nw:(slot + 1) * nw, 2] = np.sqrt(k * k + 2 * k * s)
        data[MAX_LAYERS * nw:, :3] = self.matrix
        data[MAX_LAYERS * nw:, 3] = self.matrix @ LUMINANCE
        self.ubo.write(data.tobytes())

    def set_layers(self, layers: list[LayerInput]) -> None:
        """Upload every layer (bottom first) and evaluate the whole map."""
        if len(layers) > MAX_LAYERS:
            raise RenderError(f"at most {MAX_LAYERS} cosmetic layers can be rendered, got {len(layers)}")
        shape: tuple[int, ...] | None = None
        for i, layer in enumerate(layers):
            where = f"layer {i} ({layer.name or getattr(layer.material, 'name', '?')})"
            a = self._check_map(layer, where)
            if shape is not None and a.shape != shape:
                raise RenderError(f"{where}: thickness map is {a.shape}, other layers are {shape}")
            shape = a.shape
            if not (math.isfinite(layer.opacity) and 0.0 <= layer.opacity <= 1.0):
                raise RenderError(f"{where}: opacity must be in [0, 1], got {layer.opacity}")
        self.layers = list(layers)
        self.active = [i for i, lay in enumerate(layers) if lay.visible and lay.opacity > 0]
        self.version += 1
        self.full_version += 1
        self.dirty_tiles = []
        if not self.active or shape is None:
            self.present = np.zeros((0, 0, 0), bool)
            self._set_thickness_textures(0, (1, 1))
            self._alloc((1, 1))
            self._clear_outputs()
            return
        size = (shape[1], shape[0])
        self._alloc(size)
        self._set_thickness_textures(len(self.active), size)
        self._cleaned = []
        for slot, i in enumerate(self.active):
            a = clean_thickness(layers[i].thickness)
            self.thickness_textures[slot].write(a)
            self._cleaned.append(a)
        self._upload_params()
        self.present = np.stack([tile_presence(self._cleaned[slot]) for slot in range(len(self.active))])
        self._cleaned = []
        self.fbo.use()
        self.fbo.viewport = (0, 0, *size)
        self.fbo.scissor = None
        rows, cols = self.present.shape[1:]
        self._draw_tiles([(r, c) for r in range(rows) for c in range(cols)])

    def _draw_tiles(self, tiles: list[tuple[int, int]]) -> None:
        """Evaluate tiles (row, col), grouped by the set of layers non-zero in them."""
        groups: dict[tuple[int, ...], list[tuple[int, int, int, int]]] = {}
        for rect in tile_rects(tiles, self.size):
            row, col = rect[1] // TILE, rect[0] // TILE
            key = tuple(int(s) for s in np.flatnonzero(self.present[:, row, col]))
            groups.setdefault(key, []).append(rect)
        for slots, rects in groups.items():
            if slots and len(tiles) <= SPLIT_TILES:
                for rect in rects:
                    self._draw_split(list(slots), rect)
                continue
            for k in range(0, len(rects), self._max_tiles):
                self._draw(list(slots), rects[k:k + self._max_tiles])

    def _draw_split(self, slots: list[int], rect: tuple[int, int, int, int]) -> None:
        """Evaluate one tile in a scratch target, then copy it into the maps.

        In the scratch target the tile straddles two of llvmpipe's 64² bins, so both rasteriser threads
        share it (a tile aligned in the maps is one bin, one thread).
        """
        ctx = self.ctx
        x0, y0, tw, th = rect
        if self._scratch_fbo is None:
            self._scratch = [self._output_texture((2 * TILE, TILE), srgb=i < 3, scratch=True) for i in range(5)]
            self._scratch_fbo = ctx.framebuffer(self._scratch)
            self._copy = self.shaders.program(ctx, "km_tiles.vert", "km_copy.frag")
            self._copy_vao = ctx.vertex_array(self._copy, [(self.vbo, "2f", "in_pos")])
        sx = TILE // 2
        self._scratch_fbo.use()
        self._scratch_fbo.viewport = (0, 0, 2 * TILE, TILE)
        self._draw(slots, [(sx, 0, tw, th)], offset=(x0 - sx, y0), target=(2 * TILE, TILE))
        self.fbo.use()
        self.fbo.viewport = (0, 0, *self.size)
        for i, tex in enumerate(self._scratch):
            tex.use(i)
        self._copy["u_src"].value = list(range(5))
        self._copy["u_offset"].value = (x0 - sx, y0)
        self._write_rects([rect], self.size)
        self._copy_vao.render(mode=ctx.TRIANGLES, vertices=6)

    def update_tiles(self, layer_index: int, thickness: np.ndarray | None, tiles: Iterable[tuple[int, int]]) -> None:
        """Re-upload and re-evaluate some tiles of one layer.

        Args:
            layer_index: the layer's index in :attr:`layers` (bottom first); a hidden layer only keeps
                the new map.
            thickness: the layer's full map (float µm, the shape given to :meth:`set_layers`), or None
                for the map given to :meth:`set_layers` (e.g. changed in place).
            tiles: (row, col) of :data:`painting.tiles.TILE`² blocks (row 0 = the map's first row);
                tiles outside the map and repeats are skipped.

        Raises:
            RenderError: no such layer, or a map of another shape.
        """
        if not 0 <= layer_index < len(self.layers):
            raise RenderError(f"no layer {layer_index} (the renderer has {len(self.layers)})")
        layer = self.layers[layer_index]
        a = layer.thickness if thickness is None else thickness
        if thickness is not None:
            layer.thickness = thickness
        if layer_index not in self.active:
            return
        slot = self.active.index(layer_index)
        w, h = self.size
        if a.shape != (h, w):
            raise RenderError(f"layer {layer_index}: thickness map is {a.shape}, expected {(h, w)}")
        tex = self.thickness_textures[slot]
        self.fbo.use()
        self.fbo.viewport = (0, 0, w, h)
        done: list[tuple[int, int]] = []
        for row, col in tiles:
            rc = (int(row), int(col))
            x0, y0 = rc[1] * TILE, rc[0] * TILE
            if x0 >= w or y0 >= h or x0 < 0 or y0 < 0 or rc in done:
                continue
            x1, y1 = min(x0 + TILE, w), min(y0 + TILE, h)
            block = clean_thickness(a[y0:y1, x0:x1])  # (as set_layers: NaN, ±inf and negatives are 0)
            tex.write(block.tobytes(), viewport=(x0, y0, x1 - x0, y1 - y0))
            done.append(rc)
            self.present[slot, rc[0], rc[1]] = bool((block > 0).any())
        self._draw_tiles(done)
        self.dirty_tiles += done
        self.fbo.viewport = (0, 0, w, h)
        self.version += 1

    def refresh_materials(self) -> None:
        """Re-read the layers' materials (e.g. edited in the library) and re-evaluate everything."""
        self.set_layers(self.layers)

    def _program(self, n: int) -> tuple[moderngl.Program, moderngl.VertexArray]:
        """The KM program specialised for ``n`` layers (loops over layers unrolled) and its quad."""
        if n not in self._programs:
            prog = self.shaders.program(self.ctx, "km_tiles.vert", "km.frag",
                                        km_defines(n, len(self.wavelengths), self.dtype))
            self._programs[n] = (prog, self.ctx.vertex_array(prog, [(self.vbo, "2f", "in_pos")]))
        return self._programs[n]

    def _write_rects(self, rects: list[tuple[int, int, int, int]] | None, size: tuple[int, int]) -> int:
        """Put two triangles per rectangle in the vertex buffer (see :func:`render.glutil.rect_vertices`)."""
        from render.glutil import rect_vertices

        verts = rect_vertices(rects, size)
        self.vbo.write(verts.tobytes())
        return len(verts)

    def _draw(self, slots: list[int], rects: list[tuple[int, int, int, int]] | None = None,
              offset: tuple[int, int] = (0, 0), target: tuple[int, int] | None = None) -> None:
        """Evaluate the active layers ``slots`` over ``rects`` of the bound target.

        ``slots`` are bottom first; the other layers must be zero there. ``rects``: (x, y, width, height)
        in pixels of the bound target, of size ``target`` (default the maps); None = all of it. Map texel
        = pixel + ``offset``.
        """
        n = len(slots)
        program, quad = self._program(n)
        for i, slot in enumerate(slots):
            self.thickness_textures[slot].use(i)
        self.ubo.bind_to_uniform_block(0)
        if "u_nlayers" in program:
            program["u_nlayers"] = n
        scales = np.zeros(MAX_LAYERS, np.float32)
        spec = np.zeros((MAX_LAYERS, 4), np.float32)
        slot_ids = np.zeros(MAX_LAYERS, np.int32)
        for i, slot in enumerate(slots):
            scales[i] = 1e-3 * self.layers[self.active[slot]].opacity  # µm → mm, opacity scales thickness
            spec[i] = self.layer_spec[slot]
            slot_ids[i] = slot
        if "u_scale" in program:
            u = program["u_scale"]
            program["u_scale"].write(scales[:max(u.array_length, 1)].tobytes())
        if "u_layer_spec" in program:
            u = program["u_layer_spec"]
            u.write(spec[:max(u.array_length, 1)].tobytes())
        if "u_slot" in program:
            u = program["u_slot"]
            u.write(slot_ids[:max(u.array_length, 1)].tobytes())
        if "u_thick" in program:
            u = program["u_thick"]
            u.value = list(range(u.array_length)) if u.array_length > 1 else 0
        if "u_offset" in program:
            program["u_offset"].value = tuple(int(v) for v in offset)
        self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.BLEND | self.ctx.CULL_FACE)
        quad.render(mode=self.ctx.TRIANGLES, vertices=self._write_rects(rects, target or self.size))

    # -- outputs -----------------------------------------------------------------------------------
    def bind(self, start_unit: int) -> None:
        """Bind r_top, transmittance, r_bottom to three consecutive texture units."""
        self.r_top.use(start_unit)
        self.transmittance.use(start_unit + 1)
        self.r_bottom.use(start_unit + 2)

    def bind_spec(self, unit0: int, unit1: int) -> None:
        """Bind the per-layer specular weights (layers 0–3, 4–7)."""
        self.spec0.use(unit0)
        self.spec1.use(unit1)

    def read(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(R_top, T, R_bottom) as float32 (H, W, 3) arrays, row 0 = v 0 (for tests and export)."""
        out = []
        for t in (self.r_top, self.transmittance, self.r_bottom):
            raw = t.read()
            dt = {"f4": np.float32, "f2": np.float16, "srgb8": np.uint8}[self.dtype]
            a = np.frombuffer(raw, dtype=dt).reshape(self.size[1], self.size[0], 4)[..., :3].astype(np.float32)
            if self.dtype == "srgb8":
                a = srgb_decode(a / 255.0)
            out.append(a)
        return out[0], out[1], out[2]

    def release(self) -> None:
        """Free every GPU object (call with the context current)."""
        from render.glutil import release_all

        progs = [o for pair in self._programs.values() for o in pair[::-1]]
        self._programs = {}
        release_all(self.ctx, (self.fbo, self.r_top, self.transmittance, self.r_bottom, self.spec0, self.spec1,
                               *progs, self.ubo, self.vbo, self._copy_vao, self._copy, self._scratch_fbo,
                               *self._scratch,
                               *self.thickness_textures))
        self.thickness_textures = []
        self.fbo = None
