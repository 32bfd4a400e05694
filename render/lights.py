"""Lights, shadow maps and HDR environment lighting.

- :class:`Light`: directional or point, linear RGB colour, intensity = irradiance on a surface facing the
  light (display units: a white Lambert surface facing a light of intensity 1 shows 1.0 before exposure).
  Directions are given in head space: azimuth 0° = from the front (+Z), positive towards the subject's
  left (+X); elevation positive from above (+Y).
- :class:`ShadowMaps`: one depth map per light (orthographic for directional, perspective for point
  lights) fitted to the head's bounding sphere; sampled with PCF in ``lighting.glsl``. Cached: they are
  re-rendered only when a light or the mesh changes.
- :class:`Environment`: an equirectangular HDR image (EXR via ``OpenEXR``) reduced to 9 spherical
  harmonic coefficients of radiance (Ramamoorthi & Hanrahan 2001); ``lighting.glsl`` evaluates the
  diffuse irradiance from them. ``intensity`` is the mean irradiance it delivers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from core.camera import look_at, orthographic, perspective
from core.sh import SH_COSINE, sh9_basis
from render.errors import RenderError

if TYPE_CHECKING:
    from collections.abc import Callable

    import moderngl

    from render.shaders import ShaderLibrary

MAX_LIGHTS = 8


@dataclass
class Light:
    """A light in head space.

    Attributes:
        kind: ``"directional"`` (``vector`` = direction towards the light, any length > 0) or ``"point"``
            (``vector`` = position, mesh units).
        vector: see ``kind``.
        colour: linear RGB, each ≥ 0.
        intensity: irradiance on a surface facing the light (≥ 0; for a point light, at
            ``reference_distance``).
        shadows: the light casts shadows (a shadow map).
        reference_distance: mesh units, point lights only.
    """

    kind: str = "directional"
    vector: tuple[float, float, float] = (0.0, 0.0, 1.0)
    colour: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0
    shadows: bool = True
    reference_distance: float = 10.0

    @staticmethod
    def direction_from_angles(azimuth: float, elevation: float) -> tuple[float, float, float]:
        """Unit vector towards a light at ``azimuth``, ``elevation`` degrees (head space, see module doc)."""
        az, el = math.radians(azimuth), math.radians(elevation)
        return (math.cos(el) * math.sin(az), math.sin(el), math.cos(el) * math.cos(az))

    @classmethod
    def directional(cls, azimuth: float = 0.0, elevation: float = 0.0, intensity: float = 1.0,
                    colour: tuple[float, float, float] = (1.0, 1.0, 1.0), shadows: bool = True) -> Light:
        """A directional light from ``azimuth``, ``elevation`` degrees (head space, see the module doc)."""
        return cls("directional", cls.direction_from_angles(azimuth, elevation), colour, intensity, shadows)

    @classmethod
    def point(cls, position: tuple[float, float, float], intensity: float = 1.0,
              colour: tuple[float, float, float] = (1.0, 1.0, 1.0), reference_distance: float = 10.0,
              shadows: bool = True) -> Light:
        """A point light at ``position`` (mesh units); ``intensity`` is the irradiance at ``reference_distance``."""
        return cls("point", tuple(float(x) for x in position), colour, intensity, shadows,  # type: ignore[arg-type]
                   reference_distance)

    def validate(self, where: str = "light") -> None:
        """Check the fields; ``where`` names the light in the message.

        Raises:
            RenderError: an unknown kind, a non-finite value, a negative intensity or colour, or a zero
                direction.
        """
        if self.kind not in ("directional", "point"):
            raise RenderError(f"{where}: kind must be 'directional' or 'point', got {self.kind!r}")
        vals = [*self.vector, *self.colour, self.intensity, self.reference_distance]
        if not all(math.isfinite(v) for v in vals):
            raise RenderError(f"{where}: values must be finite")
        if self.intensity < 0 or min(self.colour) < 0:
            raise RenderError(f"{where}: intensity and colour must be ≥ 0")
        if self.kind == "directional" and math.hypot(*self.vector) < 1e-9:
            raise RenderError(f"{where}: direction must not be zero")

    def key(self) -> tuple[Any, ...]:
        """What the light's shadow map depends on (kind, vector, whether it casts shadows)."""
        return (self.kind, tuple(self.vector), self.shadows)


def rig_shape(lights: list[Light]) -> tuple[int, int, int]:
    """What a light rig compiles into the programs that loop over it: (count, shadowed, point).

    ``shadowed`` and ``point`` are bit masks over the rig (bit i: light i casts shadows / is a point
    light); the lit pass, the texture-space irradiance and the shader check specialise on these three.
    """
    shadowed = sum(1 << i for i, lt in enumerate(lights) if lt.shadows)
    points = sum(1 << i for i, lt in enumerate(lights) if lt.kind != "directional")
    return len(lights), shadowed, points


def default_lights() -> list[Light]:
    """A soft portrait rig: key light high at the subject's left, a dim fill, a rim light.

    The fill casts shadows: it comes in low (5°) from the subject's right, so unshadowed it shone through
    the nose onto the other side of the face, and wherever a low key light left the shadow of the nose
    (under the left eye) the fill alone lit a flat, cool grey patch inside that shadow, with the shadow's
    hard edge (tests/render/test_raking_light.py). The rim light, from behind and above, reaches almost
    nothing it should not and stays unshadowed.
    """
    return [
        Light.directional(35.0, 25.0, 1.2, (1.0, 0.96, 0.9)),
        Light.directional(-45.0, 5.0, 0.35, (0.9, 0.95, 1.0)),
        Light.directional(150.0, 35.0, 0.4, (1.0, 1.0, 1.0), shadows=False),
    ]


# --- environment ---------------------------------------------------------------------------------------

def find_environment(name_or_path: str) -> Path:
    """An environment EXR by path or by name in the sample assets (``environments/<name>.exr``)."""
    p = Path(name_or_path)
    if p.suffix.lower() == ".exr" and p.is_file():
        return p
    if p.suffix.lower() == ".exr" or "/" in name_or_path:
        raise RenderError(f"{name_or_path}: environment file not found")
    from core.assets import find_asset

    try:
        return find_asset(f"environments/{name_or_path}.exr")
    except Exception:
        try:
            folder = find_asset("environments")
            known = ", ".join(sorted(q.stem for q in folder.glob("*.exr")))
        except Exception:
            known = "none found"
        raise RenderError(f"unknown environment '{name_or_path}' (known: {known})") from None


def read_exr_rgb(path: Path, max_side: int = 8192) -> np.ndarray:
    """float32 (H, W, 3) linear radiance of an EXR file (an HDR environment).

    The size is checked from the header before decoding (at most ``max_side`` pixels a side), and a damaged
    file is one message (:func:`painting.maps_io.read_exr_channels`). NaN or
    infinite pixels are refused with a :class:`RenderError` saying how many. Negative values — the
    ringing of lossy EXR compression (DWAA/DWAB) around bright peaks, present in the sample
    environments — are set to 0, since radiance cannot be negative.
    """
    from painting.maps_io import MapError, read_exr_channels

    try:
        chans = read_exr_channels(Path(path), max_side)
    except MapError as exc:
        raise RenderError(str(exc)) from None
    if "RGB" in chans:
        rgb = np.asarray(chans["RGB"], dtype=np.float32)
    elif all(c in chans for c in "RGB"):
        rgb = np.stack([np.asarray(chans[c], dtype=np.float32) for c in "RGB"], axis=-1)
    else:
        raise RenderError(f"{path}: EXR has no RGB channels (has {sorted(chans)})")
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise RenderError(f"{path}: unexpected EXR shape {rgb.shape}")
    bad = int((~np.isfinite(rgb)).any(axis=-1).sum())
    if bad:
        raise RenderError(f"{path}: {bad} pixel(s) are NaN or infinite; an environment must be finite")
    return np.maximum(rgb, 0.0)


def equirect_directions(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Directions (H, W, 3) of an equirectangular image's texel centres and their solid angles (H, W).

    Row 0 is straight up (+Y); column 0 is −Z (behind the head), the middle column +Z (in front), a
    quarter of the way +X: seen from inside, facing the middle column, the image's right is the
    viewer's right (−X), as a panorama is shot. (Before issue 14 the columns ran the other way, a
    mirror image; :func:`capture.probe.equirect_lookup` is this convention turned 180° about +Y.)
    """
    theta = (np.arange(h) + 0.5) / h * math.pi
    phi = (np.arange(w) + 0.5) / w * 2 * math.pi - math.pi
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    d = np.stack([-st * np.sin(phi)[None, :], np.broadcast_to(ct, (h, w)), st * np.cos(phi)[None, :]], -1)
    dw = (math.pi / h) * (2 * math.pi / w) * np.broadcast_to(st, (h, w))
    return d, dw


@dataclass
class Environment:
    """Diffuse environment lighting: 9 RGB SH coefficients of irradiance (already convolved).

    ``coefficients`` (9, 3): E(n) = Σ c_i Y_i(n), normalised so the mean irradiance over all normals is
    ``intensity``.
    """

    name: str
    coefficients: np.ndarray = field(default_factory=lambda: np.zeros((9, 3)))
    intensity: float = 1.0

    @classmethod
    def from_image(cls, rgb: np.ndarray, name: str = "environment", intensity: float = 1.0) -> Environment:
        """The SH irradiance of an equirectangular linear RGB image (H, W, 3), scaled to a mean ``intensity``.

        Raises:
            RenderError: the image is black.
        """
        h, w, _ = rgb.shape
        d, dw = equirect_directions(h, w)
        basis = sh9_basis(d)  # (H, W, 9)
        radiance_sh = np.einsum("hwk,hwc,hw->kc", basis, rgb.astype(np.float64), dw)
        irr = radiance_sh * SH_COSINE[:, None]
        mean = float(irr[0].mean() * 0.282095)  # the mean of E over the sphere is c_0·Y_0
        if mean <= 0:
            raise RenderError(f"environment '{name}' is black")
        return cls(name, irr * (intensity / mean), intensity)

    @classmethod
    def load(cls, name_or_path: str, intensity: float = 1.0) -> Environment:
        """An environment by sample name (``"studio"``, see :func:`find_environment`) or EXR path."""
        path = find_environment(name_or_path)
        return cls.from_image(read_exr_rgb(path), path.stem, intensity)

    def irradiance(self, normals: np.ndarray) -> np.ndarray:
        """Irradiance (..., 3) for unit normals (..., 3) — the CPU twin of ``lighting.glsl``."""
        return np.clip(sh9_basis(normals) @ self.coefficients, 0.0, None)


# --- shadow maps -------------------------------------------------------------------------------------

class ShadowMaps:
    """Depth maps for up to :data:`MAX_LIGHTS` lights in one atlas texture (4 × 2 tiles of ``size``²).

    Each is fitted to a bounding sphere. One sampler serves every light (llvmpipe turns a dynamically indexed
    sampler array into a switch over all of them, which made each shadow lookup 8× dearer).

    ``update(lights, centre, radius, draw)`` re-renders only when the lights' positions/directions or the
    sphere change; ``draw(program)`` must draw the scene's geometry with that program bound (uniform
    ``u_mvp``). ``matrices[i]`` maps world → light clip space; ``tile(i)`` gives the atlas tile as
    (u offset, v offset, u scale, v scale); ``texture`` is the depth atlas (compare mode on).
    """

    COLUMNS, ROWS = 4, 2

    def __init__(self, ctx: moderngl.Context, shaders: ShaderLibrary, size: int = 1024) -> None:
        self.ctx = ctx
        self.size = size
        self.program = shaders.program(ctx, "shadow.vert", "shadow.frag")
        self.texture = ctx.depth_texture((size * self.COLUMNS, size * self.ROWS))
        self.texture.compare_func = "<="
        self.texture.repeat_x = self.texture.repeat_y = False
        self.fbo = ctx.framebuffer(depth_attachment=self.texture)
        self.matrices: list[np.ndarray] = [np.eye(4)] * MAX_LIGHTS
        self.texel_world: list[float] = [0.0] * MAX_LIGHTS
        self._key: Any = None
        self.renders = 0

    def tile(self, i: int) -> tuple[float, float, float, float]:
        """Light ``i``'s tile of the atlas: (u offset, v offset, u scale, v scale) in [0, 1]."""
        c, r = i % self.COLUMNS, i // self.COLUMNS
        return (c / self.COLUMNS, r / self.ROWS, 1.0 / self.COLUMNS, 1.0 / self.ROWS)

    def update(self, lights: list[Light], centre: np.ndarray, radius: float,
               draw: Callable[[moderngl.Program], None]) -> None:
        """Re-render the maps if the lights or the bounding sphere (``centre``, ``radius``: mesh units) changed.

        ``draw(program)`` draws the scene's geometry with ``program`` (its ``u_mvp`` set here).
        """
        key = (tuple(lt.key() for lt in lights), tuple(np.round(centre, 6)), round(radius, 6))
        if key == self._key:
            return
        self._key = key
        centre = np.asarray(centre, dtype=float)
        self.fbo.use()
        self.fbo.viewport = (0, 0, *self.texture.size)
        self.ctx.scissor = None
        self.fbo.clear(depth=1.0)
        self.ctx.enable(self.ctx.DEPTH_TEST)
        self.ctx.disable(self.ctx.CULL_FACE | self.ctx.BLEND)
        for i, lt in enumerate(lights[:MAX_LIGHTS]):
            if not lt.shadows:
                continue
            if lt.kind == "directional":
                d = np.asarray(lt.vector, float) / np.linalg.norm(lt.vector)
                eye = centre + d * radius * 2.0
                up = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.95 else np.array([0.0, 0.0, 1.0])
                proj = orthographic(radius, radius, radius * 0.5, radius * 3.5)
            else:
                eye = np.asarray(lt.vector, float)
                dist = max(float(np.linalg.norm(eye - centre)), radius * 1.05)
                up = np.array([0.0, 1.0, 0.0])
                half = math.degrees(math.asin(min(radius / dist, 0.999)))
                proj = perspective(2 * half, 1.0, max(dist - radius, 1e-3), dist + radius)
            self.texel_world[i] = 2.0 * radius / self.size
            self.matrices[i] = proj @ look_at(eye, centre, up)
            c, r = i % self.COLUMNS, i // self.COLUMNS
            self.fbo.viewport = (c * self.size, r * self.size, self.size, self.size)
            self.program["u_mvp"].write(self.matrices[i].T.astype("f4").tobytes())
            draw(self.program)
        self.ctx.disable(self.ctx.DEPTH_TEST)
        self.renders += 1

    def invalidate(self) -> None:
        """Re-render at the next :meth:`update` whatever the lights (e.g. to time a relight)."""
        self._key = None

    def release(self) -> None:
        """Free every GPU object (call with the context current)."""
        from render.glutil import release_all

        release_all(self.ctx, (self.fbo, self.texture, self.program))


def upload_lights(program: moderngl.Program, lights: list[Light], shadows: ShadowMaps, pcf_radius: float,
                  environment: Environment | None, shadows_on: bool = True) -> None:
    """Set lighting.glsl's uniforms for ``lights`` (at most MAX_LIGHTS, validated by the caller).

    Directions (unit, w = 0) or positions (w = 1), colour × intensity with the point lights' reference
    distance, each shadowed light's PCF parameters (radius in shadow-map texels, bias and texel size in
    mesh units) and atlas matrix, and the environment's SH irradiance (off without one).
    """
    from render.glutil import set_uniform, write_uniform

    vec = np.zeros((MAX_LIGHTS, 4), np.float32)
    col = np.zeros((MAX_LIGHTS, 4), np.float32)
    par = np.zeros((MAX_LIGHTS, 4), np.float32)
    mats = np.zeros((MAX_LIGHTS, 16), np.float32)
    tiles = np.array([shadows.tile(i) for i in range(MAX_LIGHTS)], np.float32)
    for i, lt in enumerate(lights):
        v = np.asarray(lt.vector, float)
        vec[i] = (*(v / np.linalg.norm(v)), 0.0) if lt.kind == "directional" else (*v, 1.0)
        col[i] = (*(np.asarray(lt.colour) * lt.intensity), lt.reference_distance)
        if lt.shadows and shadows_on:
            texel = shadows.texel_world[i]
            par[i] = (1.0, pcf_radius, texel * 0.5, texel)
            mats[i] = shadows.matrices[i].T.reshape(16)
    set_uniform(program, "u_nlights", len(lights))
    write_uniform(program, "u_light_vec", vec)
    write_uniform(program, "u_light_col", col)
    write_uniform(program, "u_shadow_par", par)
    write_uniform(program, "u_light_mat", mats)
    write_uniform(program, "u_shadow_tile", tiles)
    set_uniform(program, "u_env_on", 1.0 if environment is not None else 0.0)
    write_uniform(program, "u_sh", environment.coefficients if environment is not None else np.zeros((9, 3)))
