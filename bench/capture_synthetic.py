"""Synthetic ground truth for validating the capture.

The sample head rendered with known Phong parameters under a known flash near the camera, and a
mirror-ball probe made from an HDR environment plus the same point light.

The ambient light of the photograph is the environment's mean radiance over the sphere of directions
(:func:`env_mean_radiance`) — the constant a Phong ambient term stands for (averaged over all normals,
an environment's irradiance / π is its mean radiance), and what a mirror ball shows (an equal-area map of
the directions, see :func:`capture.probe.analyse_probe`).

The ground-truth detail texture is the head's albedo (linearised) divided by its mean over the skin pixels
of the photograph (the mask :func:`capture.pipeline.compute_skin_mask` computes), so it averages 1 on
skin, like a real ratio image. The photograph is the CPU render
``clip(detail ⊙ (ambient + diffuse) + specular)`` — dichromatic, as the paper assumes (§4.2): the light
scattered by the skin carries its texture, the oily surface's white reflection does not — 8-bit sRGB
quantised. (The lightweight engine modulates everything by the detail, as the paper's GL_MODULATE.)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from capture.camera import Camera
from capture.mask import landmark_region
from capture.phong import Geometry, PhongParams, shade
from capture.pipeline import compute_skin_mask, linear_to_srgb8, pixel_data, sample_texture
from capture.probe import LUMINANCE, synthetic_probe
from km.srgb import srgb_decode

if TYPE_CHECKING:
    from painting.head import Head


@dataclass
class SyntheticScene:
    """The synthetic inputs and the truth.

    Attributes:
        camera: the photograph's camera (and the probe's rotation).
        photo_srgb8, probe_srgb8: uint8 sRGB (H, W, 3) and (P, P, 3), as a camera stores them.
        params: the true Phong parameters (linear RGB, photograph units).
        light_dir_world: unit (3,) towards the flash, mesh coordinates.
        detail: float32 (Ht, Wt, 3) the true detail texture (UV space), mean 1 over the skin used.
    """

    camera: Camera
    photo_srgb8: np.ndarray
    probe_srgb8: np.ndarray
    params: PhongParams
    light_dir_world: np.ndarray
    detail: np.ndarray

    @property
    def photo_lin(self) -> np.ndarray:
        """The photograph decoded to linear RGB, float64 (H, W, 3) in [0, 1]."""
        return srgb_decode(self.photo_srgb8 / 255.0)

    @property
    def probe_lin(self) -> np.ndarray:
        """The probe decoded to linear RGB, float64 (size, size, 3) in [0, 1]."""
        return srgb_decode(self.probe_srgb8 / 255.0)


#: The synthetic flash's colour: a slightly warm white, linear RGB of luminance 1.
FLASH_RGB = np.array([1.0, 0.96, 0.88]) / float(np.array([1.0, 0.96, 0.88]) @ LUMINANCE)
#: The synthetic room's mean radiance relative to the flash (a dim room), dimensionless.
DIM_ROOM = 0.04


def validation_camera(size: int = 512) -> Camera:
    """The validation's camera: 2.36 m from the sample head's face (45 units), 6.4° vertical field, size².

    It looks along −Z at (0, 1.3, 0) (mesh units), Y up.
    """
    return Camera.looking_at(np.array([0.0, 1.3, 45.0]), np.array([0.0, 1.3, 0.0]), np.array([0.0, 1.0, 0.0]),
                             6.4, size, size)


def as_photographed(linear: np.ndarray) -> np.ndarray:
    """Linear RGB as an 8-bit sRGB photograph stores it, decoded again: float64 in [0, 1].

    Clipped like a sensor and quantised to the 256 sRGB code values (:func:`capture.pipeline.linear_to_srgb8`).
    """
    return srgb_decode(linear_to_srgb8(linear) / 255.0)


def read_env(path: str) -> np.ndarray:
    """An equirectangular EXR environment as float64 (H, W, 3)."""
    import OpenEXR

    return np.asarray(OpenEXR.File(str(path)).channels()["RGB"].pixels, dtype=np.float64)


def env_mean_radiance(env: np.ndarray) -> np.ndarray:
    """The mean radiance over the sphere of directions of an equirectangular environment (H, W, 3).

    Rows weighted by the solid angle they cover, ∝ cos(latitude). (The plain pixel mean over-weights the
    poles: it differs from this by −18 % to +31 % on the shipped environments, and in hue — the lobby's
    pixel mean is 20 % less blue.) Returns (3,), the environment's units.
    """
    h = env.shape[0]
    lat = (0.5 - (np.arange(h) + 0.5) / h) * np.pi
    w = np.cos(lat)
    return np.einsum("h,hwc->c", w, np.asarray(env, dtype=np.float64)) / (w.sum() * env.shape[1])


def light_from_camera(camera: Camera, up_deg: float, right_deg: float) -> np.ndarray:
    """The unit world direction (3,) towards a light ``up_deg`` above and ``right_deg`` right of the lens.

    The angles (degrees) are between the light and the camera's axis, seen from the subject; right is
    the camera's (the image's) right.
    """
    a, b = np.radians(up_deg), np.radians(right_deg)
    # Camera coordinates: x right, y down, z forward; "towards the camera" is -z.
    d = np.array([np.sin(b) * np.cos(a), -np.sin(a), -np.cos(a) * np.cos(b)])
    return camera.R.T @ (d / np.linalg.norm(d))


def make_scene(head: Head, env: np.ndarray, size: int = 512, params: PhongParams | None = None,
               light_up_deg: float = 4.0, light_right_deg: float = 3.0, env_scale: float | None = None,
               probe_size: int = 256) -> SyntheticScene:
    """Render the synthetic photograph (size², :func:`validation_camera`) and probe (see the module docstring).

    ``params`` (default: D (0.46, 0.31, 0.245), i_s 0.18, s 24, k 1) get the flash :data:`FLASH_RGB` and
    the environment's mean radiance × ``env_scale`` (default: :data:`DIM_ROOM` of the flash) as their
    F and A. The flash is ``light_up_deg`` above and ``light_right_deg`` right of the lens (degrees).
    """
    cam = validation_camera(size)
    light = light_from_camera(cam, light_up_deg, light_right_deg)
    flash = FLASH_RGB.copy()
    mean_radiance = env_mean_radiance(env)
    if env_scale is None:
        env_scale = DIM_ROOM / max(float(mean_radiance.mean()), 1e-9)
    ambient = mean_radiance * env_scale
    if params is None:
        params = PhongParams(diffuse=np.array([0.46, 0.31, 0.245]), specular=0.18, exponent=24.0,
                             ambient_scale=1.0, flash_rgb=flash, ambient_rgb=ambient)
    else:
        params.flash_rgb = flash
        params.ambient_rgb = ambient
    # Ground-truth detail from the albedo (1 on average over the face).
    alb = srgb_decode(np.asarray(head.albedo, dtype=np.float64) / 255.0)
    pix = pixel_data(head, cam)
    region = landmark_region(cam, head.metadata.landmarks, (size, size))
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
