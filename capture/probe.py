"""Light-probe analysis (Paris et al. 2003, §4.1): a photograph of a mirror ball taken with the same
camera and flash as the face.

- The flash's **direction** from the highlight's position on the ball: the paper's (θ_l, φ_l) =
  (2θ_h, 2φ_h) with angles about the viewing axis. We use polar coordinates about the axis (θ the angle
  from it, φ the azimuth in the image), where the reflection is exact: θ_l = 2θ_h and φ_l = φ_h (the
  plane of incidence contains the axis). The ball is treated as seen orthographically (the paper
  measures ~2° of error from that).
- The flash's **hue** from the unsaturated halo around the saturated highlight (minus the environment
  seen in the ring, so that only the flash's own light is measured). Its intensity is set to 1 (a
  luminance of 1 in the photograph's linear units): intensities are relative to the photograph.
- The **ambient** light from a ring around the halo (mean linear radiance, hue and intensity), in the
  photograph's linear units.

Image conventions: x right, y down, top-left pixel centre at (0.5, 0.5); camera coordinates as in
:mod:`capture.camera` (x right, y down, z forward).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import ndimage

from km.errors import SheerError

#: Rec. 709 / sRGB luminance weights of linear RGB.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


class ProbeError(SheerError, ValueError):
    """A light-probe photograph that cannot be analysed (no ball, no highlight, …)."""


@dataclass
class ProbeAnalysis:
    """What the probe says about the light.

    Attributes:
        light_dir_camera: unit (3,) direction from the subject towards the flash, camera coordinates.
        theta_deg, phi_deg: the light's spherical coordinates about the camera axis (degrees).
        highlight_px: (x, y) of the highlight's centroid in the probe image (pixels).
        flash_rgb: (3,) the flash colour, linear RGB with luminance 1 (relative to the photograph).
        ambient_rgb: (3,) the ambient radiance seen in the ring, linear RGB in the photograph's units.
        classes: uint8 (H, W) 0 = outside/unused, 1 = saturated, 2 = halo, 3 = ambient ring (Fig. 7b).
    """

    light_dir_camera: np.ndarray
    theta_deg: float
    phi_deg: float
    highlight_px: tuple[float, float]
    flash_rgb: np.ndarray
    ambient_rgb: np.ndarray
    classes: np.ndarray

    def to_json(self) -> dict[str, Any]:
        return {
            "light_dir_camera": self.light_dir_camera.tolist(),
            "theta_deg": self.theta_deg, "phi_deg": self.phi_deg,
            "highlight_px": list(self.highlight_px),
            "flash_rgb": self.flash_rgb.tolist(), "ambient_rgb": self.ambient_rgb.tolist(),
        }


def light_direction_from_highlight(dx: float, dy: float) -> tuple[np.ndarray, float, float]:
    """The light direction for a highlight at normalised ball coordinates (dx, dy) (ball radius 1).

    Returns (unit direction in camera coordinates, θ_l in degrees, φ_l in degrees).
    """
    rho = float(np.hypot(dx, dy))
    if rho >= 1.0:
        raise ProbeError(f"the highlight lies outside the ball (radius {rho:.3f} ≥ 1)")
    theta_h = np.arcsin(rho)
    phi_h = np.arctan2(dy, dx)
    theta_l = 2.0 * theta_h
    phi_l = phi_h
    d = np.array([np.sin(theta_l) * np.cos(phi_l), np.sin(theta_l) * np.sin(phi_l), -np.cos(theta_l)])
    return d, float(np.degrees(theta_l)), float(np.degrees(phi_l))


def analyse_probe(image: np.ndarray, ball: tuple[float, float, float] | None = None,
                  saturation_level: float = 0.98, source: str = "probe") -> ProbeAnalysis:
    """Analyse a mirror-ball photograph.

    Args:
        image: (H, W, 3) *linear* RGB in [0, 1] (decode sRGB first; see :func:`capture.io.read_photo`).
        ball: (cx, cy, r) the ball's circle in pixels; None = the circle inscribed in the image (a probe
            photo cropped to the ball).
        saturation_level: a channel at or above this value counts as saturated (sensor clipping).
        source: names the input in error messages.
    """
    img = np.asarray(image, dtype=np.float64)
    if img.ndim != 3 or img.shape[2] != 3:
        raise ProbeError(f"{source}: expected an RGB image")
    h, w = img.shape[:2]
    if ball is None:
        ball = (w / 2.0, h / 2.0, min(w, h) / 2.0)
    cx, cy, r = ball
    if r < 8:
        raise ProbeError(f"{source}: the ball is too small ({r:.1f} px radius)")
    yy, xx = np.mgrid[0:h, 0:w]
    px = xx + 0.5
    py = yy + 0.5
    rho = np.hypot(px - cx, py - cy) / r
    inside = rho < 0.97
    sat = inside & (img.max(axis=2) >= saturation_level)
    if not sat.any():
        # No sensor clipping: the brightest 0.05 % of the ball stands in for the saturated core.
        lum = img @ LUMINANCE
        thr = np.quantile(lum[inside], 0.9995)
        sat = inside & (lum >= thr)
    labels, n = ndimage.label(sat)
    if n == 0:
        raise ProbeError(f"{source}: no highlight found on the ball")
    # The flash sits near the camera, so its highlight is the saturated blob nearest the ball's centre
    # (an environment's windows and lamps may saturate too, farther out).
    idx = np.arange(1, n + 1)
    cyx = np.asarray(ndimage.center_of_mass(np.ones_like(rho), labels, idx)).reshape(-1, 2)
    dist_c = np.hypot(cyx[:, 1] + 0.5 - cx, cyx[:, 0] + 0.5 - cy)
    core = labels == int(idx[int(np.argmin(dist_c))])
    hx = float(px[core].mean())
    hy = float(py[core].mean())
    d, theta, phi = light_direction_from_highlight((hx - cx) / r, (hy - cy) / r)
    core_r = max(1.0, float(np.sqrt(core.sum() / np.pi)))
    dist = np.hypot(px - hx, py - hy)
    halo_out = core_r + max(3.0, 2.0 * core_r)
    ring_in = halo_out + max(2.0, 0.5 * core_r)
    ring_out = ring_in + 0.2 * r
    halo = inside & ~sat & (dist > core_r + 1.0) & (dist <= halo_out)
    ring = inside & ~sat & (dist > ring_in) & (dist <= ring_out)
    if ring.sum() < 10:
        raise ProbeError(f"{source}: the ring around the highlight leaves the ball; is the ball circle right?")
    ambient = np.median(img[ring], axis=0)
    if halo.sum() < 4:
        raise ProbeError(f"{source}: no unsaturated halo around the highlight to measure the flash's hue")
    # The halo's brightest half carries most flash light; subtract the environment seen in the ring.
    hv = img[halo]
    hl = hv @ LUMINANCE
    bright = hv[hl >= np.median(hl)]
    flash = np.clip(bright.mean(axis=0) - ambient, 1e-6, None)
    flash = flash / float(flash @ LUMINANCE)
    classes = np.zeros((h, w), dtype=np.uint8)
    classes[ring] = 3
    classes[halo] = 2
    classes[sat] = 1
    return ProbeAnalysis(light_dir_camera=d, theta_deg=theta, phi_deg=phi, highlight_px=(hx, hy),
                         flash_rgb=flash, ambient_rgb=ambient, classes=classes)


def equirect_lookup(env: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Radiance of an equirectangular environment (H, W, 3) in world directions (..., 3) (Y up;
    longitude 0 at -Z, increasing towards +X; top row = +Y). Bilinear."""
    d = directions / np.linalg.norm(directions, axis=-1, keepdims=True)
    lon = np.arctan2(d[..., 0], -d[..., 2])
    lat = np.arcsin(np.clip(d[..., 1], -1, 1))
    h, w = env.shape[:2]
    x = (lon / (2 * np.pi) + 0.5) * w - 0.5
    y = (0.5 - lat / np.pi) * h - 0.5
    out = np.empty(d.shape[:-1] + (3,))
    for c in range(3):
        out[..., c] = ndimage.map_coordinates(env[..., c], [y, x], order=1, mode="wrap")
    return out


def synthetic_probe(env: np.ndarray, R: np.ndarray, light_dir_world: np.ndarray, flash_rgb: np.ndarray,
                    size: int = 256, env_scale: float = 1.0, core_deg: float = 0.6, halo_deg: float = 4.0,
                    core_gain: float = 50.0, halo_gain: float = 0.5) -> np.ndarray:
    """A mirror-ball photograph (linear RGB, clipped to [0, 1], ball inscribed in a size² image) of an HDR
    environment plus a point light, seen by a camera with world→camera rotation ``R``.

    The light's reflection is a narrow core (``core_deg``, gain ``core_gain`` × flash, saturating the
    sensor) plus a wider halo (``halo_deg``, gain ``halo_gain``) — a real ball is never an ideal mirror.
    """
    yy, xx = np.mgrid[0:size, 0:size]
    dx = (xx + 0.5 - size / 2) / (size / 2)
    dy = (yy + 0.5 - size / 2) / (size / 2)
    rr = dx ** 2 + dy ** 2
    inside = rr < 1.0
    nz = -np.sqrt(np.clip(1 - rr, 0, 1))
    n = np.stack([dx, dy, nz], axis=-1)
    view = np.array([0.0, 0.0, 1.0])
    refl = view - 2 * (n @ view)[..., None] * n  # camera coordinates
    world = refl @ R  # R^T applied to row vectors
    out = equirect_lookup(env, world) * env_scale
    lc = R @ (np.asarray(light_dir_world, dtype=float) / np.linalg.norm(light_dir_world))
    ang = np.degrees(np.arccos(np.clip(refl @ lc, -1, 1)))
    lobe = core_gain * np.exp(-0.5 * (ang / core_deg) ** 2) + halo_gain * np.exp(-0.5 * (ang / halo_deg) ** 2)
    out = out + lobe[..., None] * np.asarray(flash_rgb)[None, None, :]
    out[~inside] = 0.0
    return np.clip(out, 0.0, 1.0)
