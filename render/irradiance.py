"""The texture-space irradiance cache: the lights and the environment shaded once in the head's UV space.

Lights are fixed to the head, so the diffuse irradiance E (lights with PCF shadows plus the SH
environment, normal-mapped) only changes when a light, the environment, the normal strength, the PCF
radius or the shadow-map size changes; each frame then fetches E from this cache instead of shading
lights and shadows per pixel. :class:`TextureIrradiance` owns the cache's targets and programs.

Units: irradiance in the renderer's display units (a white Lambert surface facing a light of intensity 1
receives 1.0), texture sides in texels.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from render.lights import rig_shape

if TYPE_CHECKING:
    from collections.abc import Callable, Hashable

    import moderngl

    from render.gpu_head import GpuHead
    from render.lights import Light
    from render.shaders import ShaderLibrary


def irradiance_defines(rig: tuple[int, int, int], env: bool, irr_only: bool) -> dict[str, int]:
    """The defines of ``irradiance.frag`` for a light rig (:func:`render.lights.rig_shape`).

    ``env``: an environment contributes; ``irr_only``: E alone is written (only light 0 may cast shadows).
    """
    count, shadowed, points = rig
    return {"NLIGHTS": count, "SHADOWED": shadowed, "POINT_LIGHTS": points, "ENV": int(env), "IRR_ONLY": int(irr_only)}


class TextureIrradiance:
    """Diffuse irradiance in the head's texture space, plus each light's shadow visibility.

    The irradiance (lights with PCF shadows + SH environment, normal-mapped) and the visibilities (for
    the specular term) are recomputed only when the key given to :meth:`update` changes (orbiting the
    camera or painting reuses them). ``version`` counts recomputations; ``size`` is the side in texels.

    Texels outside the UV charts are padded in one gather pass: each copies its nearest covered texel
    (Euclidean, from scipy's distance transform of the first computation's coverage; the charts depend
    only on the mesh, so the index map is made once). Before, four 3×3 dilation passes cost most of a
    relight (each texel 30 fetches per pass); now the padding is one pass of four fetches per texel and
    reaches every texel, so no sampling footprint finds background.
    """

    def __init__(self, ctx: moderngl.Context, shaders: ShaderLibrary, size: int = 1024) -> None:
        self.ctx = ctx
        self.size = size
        self.shaders = shaders
        self.programs: dict[tuple[int, ...], moderngl.Program] = {}
        # the padding pass, with all three targets or E alone (IRR_ONLY, see irradiance_targets.glsl)
        self.gathers: dict[int, tuple[moderngl.Program, moderngl.VertexArray]] = {}
        self.index: moderngl.Texture | None = None  # RG32I: source texel of every texel (class docstring)
        self.sets: list[tuple[list[moderngl.Texture], moderngl.Framebuffer]] = []
        self._irr_fbos: list[moderngl.Framebuffer] = []  # each set's E target alone
        for _ in range(2):
            texs = [ctx.texture((size, size), 4, dtype="f2"), ctx.texture((size, size), 4),
                    ctx.texture((size, size), 4)]
            for t in texs:
                t.repeat_x = t.repeat_y = False
                t.filter = (ctx.LINEAR, ctx.LINEAR)
            self.sets.append((texs, ctx.framebuffer(texs)))
            self._irr_fbos.append(ctx.framebuffer(texs[:1]))
        self.current = 0
        self._key: Hashable = None
        self.version = 0

    @property
    def textures(self) -> list[moderngl.Texture]:
        """The padded cache: irradiance (RGBA16F; alpha = light 0's visibility), visibilities 1–4, 5–7.

        The visibilities are those of the last update with a shadowed light among lights 1–7 (an update
        without one writes E alone: nothing reads them then, see ``irradiance_targets.glsl``).
        """
        return self.sets[self.current][0]

    def _index_path(self, uv_key: str) -> Any:
        from core.cache import cache_dir

        return cache_dir("render") / f"pad-index-{uv_key}-{self.size}-v1.cache"

    def _load_index(self, uv_key: str) -> moderngl.Texture | None:
        """The padding's index from the disk cache (see :meth:`_make_index`), or None."""
        from core.cache import load_array

        n = self.size
        idx = load_array(self._index_path(uv_key), 1)  # None when absent or damaged (then deleted, logged)
        if idx is None or idx.shape != (n, n, 2) or idx.dtype != np.int32 or idx.min() < 0 or idx.max() >= n:
            return None
        return self._index_texture(idx)

    def _index_texture(self, idx: np.ndarray) -> moderngl.Texture:
        n = self.size
        index = self.ctx.texture((n, n), 2, np.ascontiguousarray(idx).tobytes(), dtype="i4")
        index.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
        return index

    def _make_index(self, uv_key: str) -> moderngl.Texture:
        """The nearest covered texel of every texel, from the coverage (alpha) of the raw irradiance.

        Kept on disk per mesh footprint (``uv_key``) and size: scipy's distance transform plus the
        read-back take about 0.6 s of a start-up.
        """
        from core.cache import save_array

        n = self.size
        index = self._load_index(uv_key)
        if index is None:
            from scipy.ndimage import distance_transform_edt

            alpha = np.frombuffer(self.sets[0][0][2].read(), np.uint8).reshape(n, n, 4)[..., 3]  # irradiance.frag
            covered = alpha > 0
            if covered.any():
                iy, ix = distance_transform_edt(~covered, return_distances=False, return_indices=True)
            else:
                iy, ix = np.mgrid[0:n, 0:n]
            idx = np.ascontiguousarray(np.stack([ix, iy], axis=-1).astype(np.int32))
            save_array(self._index_path(uv_key), idx, 1)
            index = self._index_texture(idx)
        return index

    def program(self, lights: list[Light], env: bool, irr_only: bool = False) -> moderngl.Program:
        """``irradiance.frag`` specialised for a light rig (cached).

        Specialised on the light count (≤ 8), which lights cast shadows and which are point lights, and
        whether there is an environment ``env``: loops unroll, nothing is computed for what is off.
        ``irr_only``: E alone is written (``IRR_ONLY`` in ``irradiance_targets.glsl``).
        """
        key = (*rig_shape(lights), int(env), int(irr_only))
        if key not in self.programs:
            self.programs[key] = self.shaders.program(self.ctx, "uvspace.vert", "irradiance.frag",
                                                      irradiance_defines(rig_shape(lights), env, irr_only))
        return self.programs[key]

    def _gather(self, irr_only: bool) -> tuple[moderngl.Program, moderngl.VertexArray]:
        """The padding pass for three targets or E alone (compiled on first use)."""
        if irr_only not in self.gathers:
            prog = self.shaders.program(self.ctx, "fullscreen.vert", "pad_gather.frag", {"IRR_ONLY": int(irr_only)})
            self.gathers[irr_only] = (prog, self.ctx.vertex_array(prog, []))
        return self.gathers[irr_only]

    def update(self, key: Hashable, gpu_head: GpuHead, setup: Callable[[moderngl.Program], None],
               lights: list[Light], env: bool) -> bool:
        """Recompute the cache if ``key`` changed since the last call.

        Args:
            key: everything the irradiance depends on (lights, environment, normal strength, ...).
            gpu_head: the head drawn unwrapped into its UV space.
            setup: sets the lighting uniforms of the program it is given (shadow atlas, lights, SH).
            lights: the light rig (≤ 8), for the program's specialisation.
            env: whether an environment contributes.

        Returns:
            True if it recomputed, False if the cache was still valid.
        """
        if key == self._key:
            return False
        self._key = key
        ctx = self.ctx
        if self.index is None:
            self.index = self._load_index(gpu_head.uv_key)
        # E alone when only light 0 casts shadows (its visibility is E's alpha) and the padding's index is
        # at hand (else the coverage of the third target makes it): a rig of one shadowed light writes and
        # pads one target of three (the studio's, whose fill casts shadows too, writes all three)
        irr_only = self.index is not None and not any(lt.shadows for lt in lights[1:])
        texs, fbo = self.sets[0]
        fbo = self._irr_fbos[0] if irr_only else fbo
        fbo.use()
        fbo.viewport = (0, 0, self.size, self.size)
        ctx.scissor = None
        fbo.clear(0.0, 0.0, 0.0, 0.0)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        prog = self.program(lights, env, irr_only)
        setup(prog)
        gpu_head.normal.use(1)
        prog["u_normal_map"].value = 1
        gpu_head.draw(prog)
        if self.index is None:
            self.index = self._make_index(gpu_head.uv_key)
        self.index.use(3)
        gather, quad = self._gather(irr_only)
        for i, t in enumerate(texs[:1] if irr_only else texs):
            t.use(i)
            gather[f"u_src{i}"].value = i
        gather["u_index"].value = 3
        out = self._irr_fbos[1] if irr_only else self.sets[1][1]
        out.use()
        out.viewport = (0, 0, self.size, self.size)
        quad.render(vertices=3)
        self.current = 1
        self.version += 1
        return True

    def is_current(self, key: Hashable) -> bool:
        """Whether the cache holds the irradiance for ``key`` (see :meth:`update`)."""
        return key == self._key

    def invalidate(self) -> None:
        """Recompute at the next :meth:`update` whatever its key (e.g. to time a relight)."""
        self._key = None

    def release(self) -> None:
        """Free every GPU object (call with the context current)."""
        from render.glutil import release_all

        release_all(self.ctx, [*self._irr_fbos, *(o for texs, fbo in self.sets for o in (fbo, *texs)),
                               *(o for pv in self.gathers.values() for o in pv[::-1]), *self.programs.values(),
                               self.index])
        self.programs, self.gathers, self._irr_fbos = {}, {}, []

