"""Ground truth for the capture drawn by a renderer that is not the one being fitted (no tests here).

The capture fits :func:`capture.phong.shade` on the CPU rasteriser of :mod:`capture.raster`; this module
draws the synthetic flash photograph on the GPU instead (moderngl on the test session's EGL context):
its own GLSL Phong, written for this test, per fragment (the vertex stage is the renderer's pass-through
``mesh.vert``), with the GPU's rasteriser, perspective-correct interpolation and float32 arithmetic, the detail texture fetched by the GPU's trilinear filtering, and
``supersample``² samples averaged per photograph pixel (a sensor integrates over its pixel: silhouette
and highlight edges come out partial, unlike the CPU model's one sample at the pixel centre), then
clipped and quantised to 8-bit sRGB like a camera.

The model drawn is the paper's dichromatic one (§4.2), as :mod:`capture.synthetic`'s:

    I = clip(D ⊙ t ⊙ (A(n) + F·max(n·l, 0)) + i_s·F·max(r·v, 0)^s),   r = 2(n·l)n − l

with t the texture fetched at the fragment, l the flash's direction (a directional light, unit, world),
v the unit direction to the camera centre, and A(n) either the constant ambient A (the Phong model's
assumption) or the environment's irradiance E(n)/π at the fragment's normal (``sh``: what an environment
does to a matte surface, which the constant A only approximates; its 9 spherical-harmonic coefficients
are within 2 % of the integral for the sunset, and ring by up to 25 % for the studio's compact softboxes
— a smooth n-dependent ambient all the same, and the same one drawn for every pixel).

The truth of "the diffuse colour" is then D times the mean of t over the skin pixels the capture used
(the fit cannot tell D from the texture's mean): :func:`truth_diffuse` reads it from the texture image
rendered beside the photograph.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from capture.pipeline import linear_to_srgb8
from km.srgb import srgb_decode

if TYPE_CHECKING:
    import moderngl

    from capture.camera import Camera
    from painting.head import Head

#: The shading, written for this test (the vertex stage is the renderer's pass-through ``mesh.vert``:
#: world position, normal and UV out, ``u_view_proj`` the clip matrix).
FRAGMENT = """
#version 450 core
uniform sampler2D u_texture;
uniform vec3 u_camera_centre;
uniform vec3 u_light;
uniform vec3 u_diffuse;
uniform vec3 u_flash;
uniform vec3 u_ambient;
uniform float u_specular;
uniform float u_exponent;
uniform bool u_use_sh;
uniform vec3 u_sh[9];
in vec3 v_pos;
in vec3 v_normal;
in vec2 v_uv;
layout(location = 0) out vec4 out_colour;
layout(location = 1) out vec4 out_texture;

vec3 irradiance_over_pi(vec3 n) {
    // Real SH basis up to l = 2, the clamped-cosine convolution already in the coefficients.
    float b[9] = float[9](0.282095, 0.488603 * n.y, 0.488603 * n.z, 0.488603 * n.x,
                          1.092548 * n.x * n.y, 1.092548 * n.y * n.z, 0.315392 * (3.0 * n.z * n.z - 1.0),
                          1.092548 * n.x * n.z, 0.546274 * (n.x * n.x - n.y * n.y));
    vec3 e = vec3(0.0);
    for (int i = 0; i < 9; ++i) e += b[i] * u_sh[i];
    return max(e, vec3(0.0)) / 3.14159265358979;
}

void main() {
    vec3 n = normalize(v_normal);
    vec3 v = normalize(u_camera_centre - v_pos);
    float ndl = dot(n, u_light);
    vec3 r = 2.0 * ndl * n - u_light;
    float lobe = ndl > 0.0 ? pow(max(dot(r, v), 0.0), u_exponent) : 0.0;
    vec3 t = texture(u_texture, v_uv).rgb;
    vec3 ambient = u_use_sh ? irradiance_over_pi(n) : u_ambient;
    vec3 body = u_diffuse * t * (ambient + u_flash * max(ndl, 0.0));
    out_colour = vec4(body + u_specular * lobe * u_flash, 1.0);
    out_texture = vec4(t, 1.0);
}
"""


@dataclass
class GpuPhoto:
    """A photograph drawn on the GPU.

    Attributes:
        srgb8: uint8 (H, W, 3), the photograph as a camera stores it (clipped, 8-bit sRGB, top row first).
        texture: float64 (H, W, 3), the texture t averaged over each pixel's samples (0 off the head).
        coverage: float64 (H, W), the fraction of each pixel's samples on the head (0..1).
    """

    srgb8: np.ndarray
    texture: np.ndarray
    coverage: np.ndarray

    @property
    def linear(self) -> np.ndarray:
        """The photograph decoded to linear RGB, float64 (H, W, 3) in [0, 1]."""
        return srgb_decode(self.srgb8 / 255.0)


def irradiance_sh(env: np.ndarray, scale: float) -> np.ndarray:
    """Irradiance SH coefficients (9, 3) of an equirectangular environment (H, W, 3) in capture's
    convention (:func:`capture.probe.equirect_lookup`: row 0 = +Y, longitude 0 at −Z, increasing towards
    +X), times ``scale``; E(n) = Σ c_i Y_i(n) in the environment's units × ``scale``.
    """
    from render.lights import SH_COSINE, equirect_directions, sh9_basis

    h, w = env.shape[:2]
    d, dw = equirect_directions(h, w)  # render's convention: column 0 at −Z, the middle at +Z
    d = d * np.array([1.0, 1.0, -1.0])  # capture's: column 0 at +Z, the middle at −Z (±X where render's are)
    radiance = np.einsum("hwk,hwc,hw->kc", sh9_basis(d), np.asarray(env, dtype=np.float64), dw)
    return radiance * SH_COSINE[:, None] * scale


def render_photo(ctx: moderngl.Context, head: Head, texture: np.ndarray, camera: Camera,
                 diffuse: np.ndarray, specular: float, exponent: float, light: np.ndarray,
                 flash: np.ndarray, ambient: np.ndarray, sh: np.ndarray | None = None,
                 supersample: int = 3) -> GpuPhoto:
    """Draw the flash photograph of ``head`` (see the module docstring).

    Args:
        ctx: the GL context (4.5 core, EGL).
        head: the head (vertices, normals, uv, faces).
        texture: float (Ht, Wt, 3) linear texture in the head's UV space (top row first), ~1 on average.
        camera: the photograph's camera (its width × height is the photograph's size, pixels).
        diffuse: (3,) D, linear. specular: i_s, photograph units. exponent: s (dimensionless, ≥ 1).
        light: (3,) unit direction towards the flash, world. flash: (3,) F, linear, luminance 1.
        ambient: (3,) the constant A, photograph units (ignored with ``sh``).
        sh: (9, 3) irradiance SH coefficients (:func:`irradiance_sh`) for A(n) = E(n)/π, or None.
        supersample: samples per pixel along each axis (the photograph is their linear mean).
    """
    w, h = camera.width * supersample, camera.height * supersample
    # The head's v counts from the image's top row (painting.head) and GL puts the first row uploaded at
    # t = 0: the array goes up as it is and the UVs unchanged.
    tex_img = np.ascontiguousarray(np.asarray(texture, dtype=np.float32))
    uv = np.asarray(head.uv, dtype=np.float64)
    tex = ctx.texture((tex_img.shape[1], tex_img.shape[0]), 3, tex_img.tobytes(), dtype="f4")
    tex.build_mipmaps()
    tex.filter = (ctx.LINEAR_MIPMAP_LINEAR, ctx.LINEAR)
    from render.shaders import ShaderLibrary

    prog = ctx.program(vertex_shader=ShaderLibrary().source("mesh.vert"), fragment_shader=FRAGMENT)
    buffers = [ctx.buffer(np.asarray(a, dtype="f4").tobytes()) for a in (head.vertices, head.normals, uv)]
    index = ctx.buffer(np.asarray(head.faces, dtype="u4").tobytes())
    vao = ctx.vertex_array(prog, [(buffers[0], "3f", "in_position"), (buffers[1], "3f", "in_normal"),
                                  (buffers[2], "2f", "in_uv")], index)
    colour_rb = ctx.renderbuffer((w, h), 4, dtype="f4")
    texture_rb = ctx.renderbuffer((w, h), 4, dtype="f4")
    depth_rb = ctx.depth_renderbuffer((w, h))
    fbo = ctx.framebuffer(color_attachments=[colour_rb, texture_rb], depth_attachment=depth_rb)
    try:
        depths = camera.to_camera(head.vertices)[:, 2]
        near, far = 0.5 * float(depths.min()), 2.0 * float(depths.max())
        prog["u_view_proj"].write(camera.clip_from_world(near, far, supersample).T.astype("f4").tobytes())
        prog["u_camera_centre"].value = tuple(float(x) for x in camera.centre)
        prog["u_light"].value = tuple(float(x) for x in np.asarray(light) / np.linalg.norm(light))
        prog["u_diffuse"].value = tuple(float(x) for x in diffuse)
        prog["u_flash"].value = tuple(float(x) for x in flash)
        prog["u_ambient"].value = tuple(float(x) for x in ambient)
        prog["u_specular"].value = float(specular)
        prog["u_exponent"].value = float(exponent)
        prog["u_use_sh"].value = sh is not None
        prog["u_sh"].write(np.asarray(sh if sh is not None else np.zeros((9, 3)), dtype="f4").tobytes())
        prog["u_texture"].value = 0
        tex.use(0)
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.CULL_FACE | ctx.BLEND)
        vao.render()
        ctx.disable(ctx.DEPTH_TEST)

        def read(attachment: int) -> np.ndarray:
            raw = np.frombuffer(fbo.read(components=4, attachment=attachment, dtype="f4"), np.float32)
            img = raw.reshape(h, w, 4)[::-1].astype(np.float64)  # GL's row 0 is the bottom
            return img.reshape(camera.height, supersample, camera.width, supersample, 4).mean(axis=(1, 3))

        colour, texel = read(0), read(1)
    finally:
        ctx.detect_framebuffer(0).use()
        for obj in (fbo, colour_rb, texture_rb, depth_rb, vao, index, *buffers, prog, tex):
            obj.release()
    coverage = colour[..., 3]
    srgb8 = linear_to_srgb8(colour[..., :3])
    texture_px = texel[..., :3] / np.maximum(coverage, 1e-9)[..., None]
    return GpuPhoto(srgb8=srgb8, texture=np.where(coverage[..., None] > 0, texture_px, 0.0), coverage=coverage)


def truth_diffuse(diffuse: np.ndarray, photo: GpuPhoto, skin: np.ndarray) -> np.ndarray:
    """The diffuse colour the capture should find: D times the texture's mean over the ``skin`` pixels
    (bool (H, W), those the capture used). Linear RGB (3,).
    """
    return np.asarray(diffuse, dtype=np.float64) * photo.texture[skin].mean(axis=0)
