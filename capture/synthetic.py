"""Synthetic ground truth for validating the capture: the sample head rendered with known Phong
parameters under a known flash near the camera, and a mirror-ball probe made from an HDR environment plus
the same point light.

The ambient light of the photograph is the environment's mean radiance over the sphere of directions
(:func:`env_mean_radiance`) — the constant a Phong ambient term stands for (averaged over all normals,
an environment's irradiance / π is its mean radiance), and what a mirror ball shows (an equal-area map of
the directions, see :func:`capture.probe.analyse_probe`).

The ground-truth detail texture is the head's albedo (linearised) divided by its mean over the skin pixels
of the photograph (the mask :func:`capture.pipeline.compute_skin_mask` computes), so it averages 1 on skin, like a real ratio image. The photograph is the CPU render
``clip(detail ⊙ (ambient + diffuse) + specular)`` — dichromatic, as the paper assumes (§4.2): the light
scattered by the skin carries its texture, the oily surface's white reflection does not — 8-bit sRGB
quantised. (The lightweight engine modulates everything by the detail, as the paper's GL_MODULATE.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from km.srgb import srgb_decode

from .camera import Camera, look_at
from .mask import landmark_region
from .phong import Geometry, PhongParams, shade
from .pipeline import compute_skin_mask, linear_to_srgb8, pixel_data, sample_texture
from .probe import synthetic_probe


@dataclass
class SyntheticScene:
    """The synthetic inputs and the truth."""

    camera: Camera
    photo_srgb8: np.ndarray
    probe_srgb8: np.ndarray
    params: PhongParams
    light_dir_world: np.ndarray
    detail: np.ndarray

    @property
    def photo_lin(self) -> np.ndarray:
        return srgb_decode(self.photo_srgb8 / 255.0)

    @property
    def probe_lin(self) -> np.ndarray:
        return srgb_decode(self.probe_srgb8 / 255.0)


def as_photographed(linear: np.ndarray) -> np.ndarray:
    """Linear RGB as an 8-bit sRGB photograph stores it, decoded again: float64 in [0, 1], clipped like
    a sensor and quantised to the 256 sRGB code values (:func:`capture.pipeline.linear_to_srgb8`).
    """
    return srgb_decode(linear_to_srgb8(linear) / 255.0)


def read_env(path: str) -> np.ndarray:
    """An equirectangular EXR environment as float64 (H, W, 3)."""
    import OpenEXR

    return np.asarray(OpenEXR.File(str(path)).channels()["RGB"].pixels, dtype=np.float64)


def env_mean_radiance(env: np.ndarray) -> np.ndarray:
    """The mean radiance over the sphere of directions of an equirectangular environment (H, W, 3):
    rows weighted by the solid angle they cover, ∝ cos(latitude). (The plain pixel mean over-weights the
    poles: it differs from this by −18 % to +31 % on the shipped environments, and in hue — the lobby's
    pixel mean is 20 % less blue.) Returns (3,), the environment's units.
    """
    h = env.shape[0]
    lat = (0.5 - (np.arange(h) + 0.5) / h) * np.pi
    w = np.cos(lat)
    return np.einsum("h,hwc->c", w, np.asarray(env, dtype=np.float64)) / (w.sum() * env.shape[1])


def light_from_camera(camera: Camera, up_deg: float, right_deg: float) -> np.ndarray:
    """A world direction towards a light at the given angles above and to the right of the camera's
    axis, as seen from the subject (unit (3,)).
    """
    a, b = np.radians(up_deg), np.radians(right_deg)
    # Camera coordinates: x right, y down, z forward; "towards the camera" is -z.
    d = np.array([np.sin(b) * np.cos(a), -np.sin(a), -np.cos(a) * np.cos(b)])
    return camera.R.T @ (d / np.linalg.norm(d))


def make_scene(head: object, env: np.ndarray, size: int = 512, params: PhongParams | None = None,
               light_up_deg: float = 4.0, light_right_deg: float = 3.0, env_scale: float | None = None,
               probe_size: int = 256) -> SyntheticScene:
    """Render the synthetic photograph and probe (see the module docstring)."""
    cam = look_at(np.array([0.0, 1.3, 45.0]), np.array([0.0, 1.3, 0.0]), np.array([0.0, 1.0, 0.0]), 6.4,
                  size, size)
    light = light_from_camera(cam, light_up_deg, light_right_deg)
    flash = np.array([1.0, 0.96, 0.88])
    flash = flash / float(flash @ np.array([0.2126, 0.7152, 0.0722]))
    mean_radiance = env_mean_radiance(env)
    if env_scale is None:
        env_scale = 0.04 / max(float(mean_radiance.mean()), 1e-9)  # a dim room: mean radiance 0.04 of the flash
    ambient = mean_radiance * env_scale
    if params is None:
        params = PhongParams(diffuse=np.array([0.46, 0.31, 0.245]), specular=0.18, exponent=24.0,
                             ambient_scale=1.0, flash_rgb=flash, ambient_rgb=ambient)
    else:
        params.flash_rgb = flash
        params.ambient_rgb = ambient
    # Ground-truth detail from the albedo (1 on average over the face).
    alb = srgb_decode(np.asarray(head.albedo, dtype=np.float64) / 255.0)  # type: ignore[attr-defined]
    pix = pixel_data(head, cam)
    region = landmark_region(cam, head.metadata.landmarks, (size, size))  # type: ignore[attr-defined]
    face = np.ones(len(pix.rows), dtype=bool) if region is None else region[pix.rows, pix.cols]
    mean = sample_texture(alb, pix.uv)[face].mean(axis=0)
    detail = (alb / np.maximum(mean, 1e-4)).astype(np.float32)
    geo = Geometry.from_vectors(pix.normals, pix.view, light)
    specular = params.specular
    params.specular = 0.0
    body = shade(params, geo, clip=False)  # light scattered by the skin: modulated by the texture
    params.specular = specular
    surface = shade(params, geo, clip=False) - body  # the oily surface's white reflection: not modulated

    def render(det: np.ndarray) -> np.ndarray:
        out = np.zeros((size, size, 3))
        out[pix.rows, pix.cols] = np.clip(body * sample_texture(det, pix.uv) + surface, 0, 1)
        return out

    img = render(detail)
    # Renormalise so the detail averages exactly 1 over the skin pixels the capture will use (the skin
    # mask it computes from this photograph): "the diffuse colour" is then well defined.
    skin = compute_skin_mask(head, cam, as_photographed(img), pix)
    used = skin[pix.rows, pix.cols]
    detail = (detail / sample_texture(detail, pix.uv)[used].mean(axis=0)).astype(np.float32)
    img = render(detail)
    probe = synthetic_probe(env, cam.R, light, flash, size=probe_size, env_scale=env_scale)
    return SyntheticScene(camera=cam, photo_srgb8=linear_to_srgb8(img),
                          probe_srgb8=linear_to_srgb8(probe), params=params, light_dir_world=light,
                          detail=detail)
