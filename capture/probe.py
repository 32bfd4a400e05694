"""Light-probe analysis (Paris et al. 2003, §4.1): the flash and the ambient light from a mirror ball.

The probe is a photograph of a mirror ball taken with the same camera and flash as the face.

- The flash's **direction** from the highlight's position on the ball: the paper's (θ_l, φ_l) =
  (2θ_h, 2φ_h) with angles about the viewing axis. We use polar coordinates about the axis (θ the angle
  from it, φ the azimuth in the image), where the reflection is exact: θ_l = 2θ_h and φ_l = φ_h (the
  plane of incidence contains the axis). The ball is treated as seen orthographically (the paper
  measures ~2° of error from that).
- The flash's **hue** from the unsaturated halo around the saturated highlight (regressed along rays
  from the highlight, so that the environment behind the halo cancels). Its intensity is set to 1 (a
  luminance of 1 in the photograph's linear units): intensities are relative to the photograph. Given a
  second photograph of the ball taken without the flash at the same exposure, the hue is that of the
  halo in the difference of the two (:func:`_flash_hue_difference`): the room's texture under the halo,
  which one flash photograph cannot tell from the flash (2–4 % off per channel in the lobby and the
  night, tests/capture/test_probe_hue.py), is then gone.
- The **ambient** light: the mean radiance of the whole ball outside the flash's core and halo (the
  environment's mean radiance, hue and intensity), in the photograph's linear units; see
  :func:`analyse_probe` for why not the paper's ring around the halo.

Image conventions: x right, y down, top-left pixel centre at (0.5, 0.5); camera coordinates as in
:mod:`capture.camera` (x right, y down, z forward).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import ndimage

from capture.ambient import ball_reflections, probe_irradiance_sh
from core.errors import SheerError

#: Rec. 709 / sRGB luminance weights of linear RGB.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


#: A clipped spot larger than this times the area of its inscribed disc is not the flash's reflection
#: alone. The inscribed radius is the largest distance from a spot pixel's centre to the nearest pixel
#: centre outside it (a Euclidean distance transform) plus half a pixel: the distance between centres
#: falls short of the radius of the disc a digitised spot stands for by half a pixel to half a diagonal
#: (0.71 px), a tolerance that matters only for small spots. Without it the flash on the lens's axis —
#: a 12-pixel spot on a pixel corner, a 4 × 4 square less its corners — measured 1.91 and was refused;
#: now 1.04. Measured on synthetic probes (6 environments × 8 rotations × 2 flash positions × 1 and 3×
#: the environment's level): the flash alone 0.88–1.11, merged with the night's horizon glow 1.25 and
#: 2.71 (the light 2.8° and 1.4° off if taken as is). 1.2 sits between the two.
MERGED_FULLNESS = 1.2
#: A spot whose inscribed radius (pixels, with the half pixel) is below this — at most about 4 px across
#: — has no measurable shape: whether a partly covered pixel at its rim clips decides its axis ratio and
#: its fullness, so the shape tests leave it alone (a rival spot is still refused).
MIN_SHAPE_RADIUS_PX = 2.0


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
        ambient_rgb: (3,) the ambient light: the mean radiance over the ball (all directions) outside
            the flash's core and halo, linear RGB in the photograph's units.
        classes: uint8 (H, W) 0 = outside/unused, 1 = the flash's saturated core, 2 = halo, 3 = the
            environment averaged for the ambient light (Fig. 7b, with the whole ball for the ring).
        clipped_fraction: the fraction of those environment pixels with a clipped channel (the ambient
            light is then a lower bound).
        flash_hue_spread: the flash hue's spread between the halo's sectors (median relative deviation,
            worst channel; see :func:`_flash_hue`).
        reflectance: the ball's reflectance the ambient light was divided by (0..1; 1 = a perfect mirror).
        ambient_sh: (9, 3) the environment's irradiance E(n) as spherical-harmonic coefficients in
            camera coordinates (:func:`capture.ambient.probe_irradiance_sh`; A(n) = E(n)/π, photograph
            units, averages ``ambient_rgb`` over all normals), or None (a probe known only by its mean).
        hue_from_difference: the flash's hue read from the flash photograph minus one taken without the
            flash (:func:`_flash_hue_difference`), rather than from the flash photograph alone.
    """

    light_dir_camera: np.ndarray
    theta_deg: float
    phi_deg: float
    highlight_px: tuple[float, float]
    flash_rgb: np.ndarray
    ambient_rgb: np.ndarray
    classes: np.ndarray
    clipped_fraction: float = 0.0
    flash_hue_spread: float = 0.0
    reflectance: float = 1.0
    ambient_sh: np.ndarray | None = None
    hue_from_difference: bool = False

    def to_json(self) -> dict[str, Any]:
        """The analysis as JSON numbers and lists (face.json's ``probe``; the classes image left out)."""
        return {
            "light_dir_camera": self.light_dir_camera.tolist(),
            "theta_deg": self.theta_deg, "phi_deg": self.phi_deg,
            "highlight_px": list(self.highlight_px),
            "flash_rgb": self.flash_rgb.tolist(), "ambient_rgb": self.ambient_rgb.tolist(),
            "clipped_fraction": self.clipped_fraction, "flash_hue_spread": self.flash_hue_spread,
            "reflectance": self.reflectance,
            "ambient_sh": None if self.ambient_sh is None else self.ambient_sh.tolist(),
            "flash_hue_from_difference": self.hue_from_difference,
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


def _blob_shape(xs: np.ndarray, ys: np.ndarray) -> float:
    """Elongation of a pixel blob, in (0, 1]: 1 for a disc, → 0 for a line.

    √(λ_min/λ_max) of the covariance of its pixel centres ``xs``, ``ys`` (pixels); 1 for blobs of fewer
    than 3 pixels.
    """
    if len(xs) < 3:
        return 1.0
    ev = np.linalg.eigvalsh(np.cov(np.stack([xs, ys])) + np.eye(2) / 12.0)  # + a pixel's own spread
    return float(np.sqrt(ev[0] / ev[1]))


def _find_flash_core(img: np.ndarray, inside: np.ndarray, px: np.ndarray, py: np.ndarray, cx: float,
                     cy: float, r: float, level: float, max_flash_deg: float, source: str) -> np.ndarray:
    """The flash's saturated core on the ball, bool (H, W) (see :func:`analyse_probe`)."""
    lum = img @ LUMINANCE
    tiers = (("every channel", inside & (img.min(axis=2) >= level)),
             ("some channel", inside & (img.max(axis=2) >= level)))
    found = [(name, sat) for name, sat in tiers if sat.any()]
    if found:
        kind = found[0][0]
        labels, n = ndimage.label(found[0][1])
    else:
        # No sensor clipping: the brightest 0.05 % of the ball stands in for the saturated core.
        kind = "the brightest 0.05 %"
        labels, n = ndimage.label(inside & (lum >= np.quantile(lum[inside], 0.9995)))
    if n == 0:
        raise ProbeError(f"{source}: no highlight found on the ball")
    idx = np.arange(1, n + 1)
    cyx = np.asarray(ndimage.center_of_mass(np.ones_like(lum), labels, idx)).reshape(-1, 2)
    rho_b = np.hypot(cyx[:, 1] + 0.5 - cx, cyx[:, 0] + 0.5 - cy) / r
    theta_b = np.degrees(2 * np.arcsin(np.clip(rho_b, 0, 1)))
    order = np.argsort(rho_b)
    near = order[theta_b[order] <= max_flash_deg]
    if len(near) == 0:
        rho_px = np.hypot(px - cx, py - cy) / r
        window = rho_px <= np.sin(np.radians(max_flash_deg) / 2)
        if np.any((labels > 0) & window):
            raise ProbeError(
                f"{source}: ambiguous highlight: a clipped region ({kind} clipped) covers the ball's centre "
                f"but is centred {theta_b[order[0]]:.1f}° off the camera axis: the flash's reflection merges "
                f"with a large bright part of the environment — retake the probe with less exposure or "
                f"against a darker background")
        raise ProbeError(
            f"{source}: no saturated highlight ({kind} clipped) within {max_flash_deg:g}° of the camera axis; "
            f"the nearest is at {theta_b[order[0]]:.1f}° — is the flash on the camera, the ball centred "
            f"in the crop?")
    best = int(near[0])
    core = labels == best + 1
    ys, xs = np.nonzero(core)
    where = f"({float(xs.mean()) + 0.5:.1f}, {float(ys.mean()) + 0.5:.1f}) px"
    areas = np.bincount(labels.ravel(), minlength=n + 1)[1:]
    rivals = [int(o) for o in near[1:]
              if rho_b[o] < 2.0 * rho_b[best] + 3.0 / r and areas[o] >= 0.5 * areas[best]]
    if rivals:
        o = rivals[0]
        raise ProbeError(
            f"{source}: ambiguous highlight: two saturated spots ({kind} clipped) near the ball's centre, "
            f"at {where} (light {theta_b[best]:.1f}° off the camera axis) and at "
            f"({cyx[o, 1] + 0.5:.1f}, {cyx[o, 0] + 0.5:.1f}) px ({theta_b[o]:.1f}°); the flash cannot be "
            f"told from a lamp of the environment — retake the probe with less exposure or with the ball "
            f"turned so that no lamp reflects near the flash")
    rim = inside & ~ndimage.binary_erosion(inside)
    if np.any(core & ndimage.binary_dilation(rim)):
        raise ProbeError(
            f"{source}: ambiguous highlight: the saturated spot nearest the ball's centre, at {where} "
            f"({int(core.sum())} px), touches the ball's rim, so its centre is unknown — is the ball circle "
            f"right, the probe cropped to the ball?")
    elong = _blob_shape(xs + 0.5, ys + 0.5)
    inscribed = float(ndimage.distance_transform_edt(np.pad(core, 1)).max()) + 0.5
    fullness = float(core.sum()) / (np.pi * inscribed ** 2)
    if inscribed < MIN_SHAPE_RADIUS_PX:
        return core
    if fullness > MERGED_FULLNESS:
        raise ProbeError(
            f"{source}: ambiguous highlight: the saturated spot nearest the ball's centre, at {where} "
            f"({int(core.sum())} px), is {fullness:.2f}× the area of its inscribed disc (a flash's own "
            f"reflection is a disc): it merges with a bright part of the environment, so its centre is "
            f"unknown — retake the probe with less exposure or against a darker background")
    if elong < 0.4:
        raise ProbeError(
            f"{source}: ambiguous highlight: the saturated spot nearest the ball's centre, at {where} "
            f"({int(core.sum())} px), is elongated (axis ratio {elong:.2f}): the flash's reflection merges "
            f"with a bright part of the environment, so its centre is unknown — retake the probe with less "
            f"exposure or against a darker background")
    return core


def _halo_radius(img: np.ndarray, usable: np.ndarray, dist: np.ndarray, first: float,
                 background_lum: float) -> float | None:
    """The halo's outer radius in pixels from the core's centre, or None when no annulus is usable.

    The radius where the median luminance of 1-pixel annuli around the core (``dist``: each pixel's
    distance to it, from ``first`` out; ``usable`` pixels only) has fallen to a tenth of its first
    excess over ``background_lum`` (at least four annuli out).
    """
    lum = img @ LUMINANCE
    excess0 = None
    radius = None
    count = 0
    for d0 in np.arange(np.floor(first), np.floor(first) + 64.0):
        m = usable & (dist >= d0) & (dist < d0 + 1)
        if m.sum() < 8:
            if radius is not None:
                break
            continue
        excess = float(np.median(lum[m])) - background_lum
        excess0 = excess if excess0 is None else excess0
        radius = d0 + 1.0
        count += 1
        if count >= 4 and excess < 0.1 * excess0:
            break
    return radius


def _flash_hue(img: np.ndarray, halo: np.ndarray, px: np.ndarray, py: np.ndarray, hx: float, hy: float,
               sectors: int = 16) -> tuple[np.ndarray, float] | None:
    """The flash's colour (linear, luminance 1) from its ``halo`` pixels, and the estimate's spread.

    The halo: unclipped pixels around the core at (hx, hy) (pixels); the spread: the median relative
    deviation of the sectors used, worst channel (0.01 = 1 %).

    Along a ray from the highlight the flash adds F·h(d) (a hue times the halo's radial profile) to an
    environment that varies little along the ray: in each of ``sectors`` angular sectors, each channel is
    regressed linearly on the luminance, v_c = b_c + (F_c / F_Y)·Y, so the slope is the flash's hue
    whatever the environment's level behind the halo. The half of the sectors whose fit is best
    (residual RMS relative to the luminance span) give the median hue: the sectors crossing a horizon or
    a lamp fit badly and are dropped. (The paper's mean over the halo minus a ring further out mistook
    the lobby's wall gradient for flash light, 5 % too little blue; sunset's horizon through the halo
    gave 7 %.) None when fewer than three sectors have a usable fit.
    """
    az = np.arctan2(py - hy, px - hx)
    sec = np.floor((az + np.pi) / (2 * np.pi) * sectors).astype(np.int64) % sectors
    slopes = []
    quality = []
    for k in range(sectors):
        m = halo & (sec == k)
        if m.sum() < 6:
            continue
        v = img[m]
        y = v @ LUMINANCE
        span = float(y.max() - y.min())
        if span < 1e-3:
            continue
        a = np.stack([y, np.ones(len(y))], axis=1)
        coef = np.linalg.lstsq(a, v, rcond=None)[0]
        slopes.append(coef[0])
        quality.append(float(np.sqrt(np.mean((v - a @ coef) ** 2))) / span)
    if len(slopes) < 3:
        return None
    q = np.asarray(quality)
    good = np.asarray(slopes)[q <= np.median(q)]
    hue = np.median(good, axis=0)
    if float(hue @ LUMINANCE) <= 0 or np.any(hue <= 0):
        return None
    hue = hue / float(hue @ LUMINANCE)
    rel = good / np.maximum(good @ LUMINANCE, 1e-12)[:, None] / hue[None, :] - 1.0
    return hue, float(np.median(np.abs(rel), axis=0).max())


def _flash_hue_difference(diff: np.ndarray, halo: np.ndarray, px: np.ndarray, py: np.ndarray, hx: float,
                          hy: float, sectors: int = 16) -> tuple[np.ndarray, float] | None:
    """The flash's colour (linear, luminance 1) from the flash photograph minus one without it, and its spread.

    ``diff``: (H, W, 3) the flash probe minus the flash-less one (linear); ``halo``: bool (H, W), the halo's
    pixels unclipped in both photographs, around the core at (hx, hy) (pixels). The room is gone from the
    difference, so the halo there is the flash's colour times its radial profile alone: the hue is the
    halo's summed colour (the brightest pixels, the least quantised, weigh most). The spread: the median
    relative deviation of the hue summed over each of ``sectors`` angular sectors, worst channel (0.01 =
    1 %). On the lobby's and the night's probes (tests/capture/test_probe_hue.py) the sum reads within
    0.19 %, :func:`_flash_hue`'s regression on the difference within 0.32 %; in an even room, whose
    flash-less photograph is one 8-bit code, that code's rounding biases the halo's faint rim (+0.62 % in
    one channel, tests/app/kiosk/test_kiosk_light.py). None when the halo's sum is not positive.
    """
    v = diff[halo]
    total = v.sum(axis=0)
    if float(total @ LUMINANCE) <= 0 or np.any(total <= 0):
        return None
    hue = total / float(total @ LUMINANCE)
    az = np.arctan2(py[halo] - hy, px[halo] - hx)
    sec = np.floor((az + np.pi) / (2 * np.pi) * sectors).astype(np.int64) % sectors
    rel = []
    for k in range(sectors):
        part = v[sec == k].sum(axis=0)
        if int(np.count_nonzero(sec == k)) >= 6 and float(part @ LUMINANCE) > 0:
            rel.append(part / float(part @ LUMINANCE) / hue - 1.0)
    spread = float(np.median(np.abs(np.asarray(rel)), axis=0).max()) if rel else 0.0
    return hue, spread


#: The flash-less probe's room may read at most this much brighter than the flash probe's (a flash never
#: darkens the room: more is another exposure) ...
ROOM_RATIO_MAX = 1.1
#: ... and at least this fraction of it (the flash lights the room too, the more the nearer the walls: less
#: is another exposure). Ratio of the two photographs' luminance summed over the room's pixels unclipped in
#: both; the synthetic probes, whose flash lights nothing but the ball, read 0.99–1.00.
ROOM_RATIO_MIN = 0.5


def _checked_without_flash(without_flash: np.ndarray, shape: tuple[int, ...], source: str) -> np.ndarray:
    """The flash-less probe as float64 (H, W, 3), refused in one line unless it is a finite RGB image of ``shape``."""
    dark = np.asarray(without_flash, dtype=np.float64)
    if dark.ndim != 3 or dark.shape[2] != 3:
        raise ProbeError(f"{source}: expected an RGB image")
    if dark.shape != shape:
        raise ProbeError(f"{source}: the photograph without the flash is {dark.shape[1]}×{dark.shape[0]} px, the "
                         f"probe with it {shape[1]}×{shape[0]}: take both with the same camera and crop")
    if not np.all(np.isfinite(dark)):
        raise ProbeError(f"{source}: the image has NaN or infinite values")
    return dark


def analyse_probe(image: np.ndarray, ball: tuple[float, float, float] | None = None,
                  saturation_level: float = 0.98, max_flash_deg: float = 20.0,
                  source: str = "probe", reflectance: float = 1.0, without_flash: np.ndarray | None = None,
                  without_flash_source: str = "probe without the flash") -> ProbeAnalysis:
    """Analyse a mirror-ball photograph.

    - **The flash's core**: the connected pixels whose *every* channel clips (a flash many times brighter
      than the scene clips all three; coloured lamps and windows of the environment often clip only
      one or two, so this separates the flash from an orange street lamp beside it); failing that, any
      channel; failing that, the brightest 0.05 %. The flash is on the camera, so its core is the
      clipped spot nearest the ball's centre, and it must lie within ``max_flash_deg`` of the camera
      axis. When another clipped spot at least half as large lies within twice that distance (+ 3 px),
      or the nearest spot is not a disc (axis ratio < 0.4, or more than ``MERGED_FULLNESS`` × the area
      of its inscribed disc: the flash merged with a bright part of the environment), the highlight is
      ambiguous and a :class:`ProbeError` says so rather than returning a guess.
    - **The flash's hue**: from the halo around the core, by regressing each channel on the luminance
      along rays from the highlight (:func:`_flash_hue`), so the environment behind the halo cancels where
      it is even along each ray; its texture under the halo does not (2–4 % per channel in the lobby and
      the night). With ``without_flash``, from the halo in ``image`` − ``without_flash`` instead
      (:func:`_flash_hue_difference`: within 0.19 % on both). The direction, the halo's extent and the
      ambient light are read from ``image`` alone either way.
    - **The ambient light**: the mean radiance of the whole ball outside the flash's core and halo. An
      orthographic mirror ball is an *equal-area* map of the sphere of directions (a pixel at
      normalised radius ρ reflects the direction at θ = 2·arcsin ρ from the viewer; dω = sin θ dθ dφ =
      4 ρ dρ dφ), so the plain pixel mean is the mean radiance over all directions — which is the
      ambient a constant term must stand for: averaged over all normals n, the irradiance E(n)/π
      of an environment equals its mean radiance. (The paper's ring around the halo sees only the
      directions behind the camera; in a lobby or at a sunset that has another hue and a tenth of the
      level, and the fitted diffuse colour absorbed the difference — ΔE2000 up to 2.7.) The ball's
      outer 3 % of radius (the 6 % of directions behind the ball) is left out, and clipped pixels of
      the environment count at their clipped value (a lower bound).
    - **The ambient light per surface direction**: the same radiance projected on nine spherical
      harmonics and convolved with the clamped cosine (``ambient_sh``, :mod:`capture.ambient`): the
      irradiance E(n) a surface with normal n receives, whose mean over all normals is that mean.

    Args:
        image: (H, W, 3) *linear* RGB in [0, 1] (decode sRGB first; see :func:`capture.pipeline.read_photo`).
        ball: (cx, cy, r) the ball's circle in pixels; None = the circle inscribed in the image (a probe
            photo cropped to the ball).
        saturation_level: a channel at or above this value counts as saturated (sensor clipping).
        max_flash_deg: the flash's highest angle from the camera axis (degrees).
        source: names the input in error messages.
        reflectance: the ball's reflectance, 0 < reflectance ≤ 1 (dimensionless; default 1, a perfect
            mirror, as the synthetic probes). A chrome ball reflects about 0.5–0.7 of the light: the
            environment it shows is that much darker than the room, so the ambient light is the ball's
            mean divided by it. The flash's direction and hue do not depend on it (its intensity is
            set to 1 whatever the ball shows).
        without_flash: None (the flash's hue from ``image`` alone), or (H, W, 3) linear RGB in [0, 1], the
            same ball photographed without the flash at the same exposure, camera and crop: its size must
            match ``image``'s, and its room must read :data:`ROOM_RATIO_MIN`–:data:`ROOM_RATIO_MAX` of
            ``image``'s (else a :class:`ProbeError` names ``without_flash_source``).
        without_flash_source: names the flash-less photograph in error messages.
    """
    if not (np.isfinite(reflectance) and 0.0 < reflectance <= 1.0):
        raise ProbeError(f"{source}: the ball's reflectance must be in (0, 1], got {reflectance!r}")
    img = np.asarray(image, dtype=np.float64)
    if img.ndim != 3 or img.shape[2] != 3:
        raise ProbeError(f"{source}: expected an RGB image")
    if not np.all(np.isfinite(img)):
        raise ProbeError(f"{source}: the image has NaN or infinite values")
    dark = None if without_flash is None else _checked_without_flash(without_flash, img.shape, without_flash_source)
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
    core = _find_flash_core(img, inside, px, py, cx, cy, r, saturation_level, max_flash_deg, source)
    hx = float(px[core].mean())
    hy = float(py[core].mean())
    d, theta, phi = light_direction_from_highlight((hx - cx) / r, (hy - cy) / r)
    core_r = max(1.0, float(np.sqrt(core.sum() / np.pi)))
    dist = np.hypot(px - hx, py - hy)
    halo_out = core_r + max(3.0, 2.0 * core_r)
    ring_in = halo_out + max(2.0, 0.5 * core_r)
    ring_out = ring_in + 0.2 * r
    clipped = img.max(axis=2) >= saturation_level
    ring = inside & ~clipped & (dist > ring_in) & (dist <= ring_out)
    if ring.sum() < 10:
        raise ProbeError(f"{source}: the ring around the highlight leaves the ball; is the ball circle right?")
    background = np.median(img[ring], axis=0)
    usable = inside & ~clipped
    halo_r = _halo_radius(img, usable, dist, core_r + 1.0, float(background @ LUMINANCE))
    halo = usable & (dist > core_r + 1.0) & (dist <= max(halo_r or 0.0, halo_out))
    env = inside & (dist > max(ring_in, halo_r or 0.0))
    if dark is None:
        measured = _flash_hue(img, halo, px, py, hx, hy)
    else:
        lit = env & ~clipped & (dark.max(axis=2) < saturation_level)
        room = float((img[lit] @ LUMINANCE).sum())
        ratio = float((dark[lit] @ LUMINANCE).sum()) / room if room > 0 else 1.0
        if not ROOM_RATIO_MIN <= ratio <= ROOM_RATIO_MAX:
            raise ProbeError(f"{without_flash_source}: the room reads {ratio:.2f}× as bright as in {source} (expected "
                             f"{ROOM_RATIO_MIN:g}–{ROOM_RATIO_MAX:g}): take the photograph without the flash at the "
                             f"same exposure (shutter, aperture, ISO) as the one with it")
        measured = _flash_hue_difference(img - dark, halo & (dark.max(axis=2) < saturation_level), px, py, hx, hy)
    if measured is None:
        raise ProbeError(f"{source}: the halo around the highlight is no brighter than the environment; "
                         f"cannot measure the flash's hue")
    flash, spread = measured
    ambient = img[env].mean(axis=0) / reflectance
    ambient_sh = probe_irradiance_sh(img, (cx, cy, r), env, inside & ~env, background, reflectance)
    classes = np.zeros((h, w), dtype=np.uint8)
    classes[env] = 3
    classes[halo] = 2
    classes[core] = 1
    return ProbeAnalysis(light_dir_camera=d, theta_deg=theta, phi_deg=phi, highlight_px=(hx, hy),
                         flash_rgb=flash, ambient_rgb=ambient, classes=classes,
                         clipped_fraction=float(clipped[env].mean()), flash_hue_spread=spread,
                         reflectance=float(reflectance), ambient_sh=ambient_sh, hue_from_difference=dark is not None)


def equirect_lookup(env: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Radiance of an equirectangular environment (H, W, 3) in world directions (..., 3), bilinear.

    Y up; longitude 0 at −Z (the middle column), increasing towards +X; top row = +Y. Returns (..., 3)
    in the environment's units.
    """
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


def probe_environment(env: np.ndarray, R: np.ndarray, size: int = 256, env_scale: float = 1.0) -> np.ndarray:
    """A mirror ball reflecting an equirectangular environment (unclipped, pixel centres sampled).

    The ball is inscribed in a ``size``² image and seen orthographically by a camera with world→camera
    rotation ``R``: linear RGB (size, size, 3) in the environment's units × ``env_scale``, 0 off the ball.
    """
    c = (np.arange(size) + 0.5 - size / 2) / (size / 2)
    refl, inside = ball_reflections(c[None, :], c[:, None])
    out = equirect_lookup(env, refl @ R) * env_scale  # R^T applied to row vectors
    out[~inside] = 0.0
    return out


def flash_reflection(size: int, R: np.ndarray, light_dir_world: np.ndarray, core_deg: float = 0.6,
                     halo_deg: float = 4.0, core_gain: float = 50.0, halo_gain: float = 0.5,
                     supersample: int = 1) -> np.ndarray:
    """The flash's reflection in a ``size``² mirror-ball image (see :func:`probe_environment`).

    Float (size, size) in units of the flash's colour: a narrow core (Gaussian of ``core_deg`` in the reflected
    direction, gain ``core_gain``) plus a wide halo (``halo_deg``, ``halo_gain``). With ``supersample``
    > 1 the core is averaged over ``supersample``² points per pixel near the spot (a sensor integrates
    its pixel: the spot's rim pixels are partly covered); elsewhere, and for the halo, pixel centres.
    """
    lc = R @ (np.asarray(light_dir_world, dtype=float) / np.linalg.norm(light_dir_world))
    c = (np.arange(size) + 0.5 - size / 2) / (size / 2)
    refl, inside = ball_reflections(c[None, :], c[:, None])
    ang = np.degrees(np.arccos(np.clip(refl @ lc, -1, 1)))
    halo = halo_gain * np.exp(-0.5 * (ang / halo_deg) ** 2)
    core = core_gain * np.exp(-0.5 * (ang / core_deg) ** 2)
    if supersample > 1:
        # Near the spot: 5 σ of the core plus 4 pixels (a pixel spans 2/r radians of reflected
        # direction at the ball's centre, more towards its rim).
        near = inside & (ang < 5 * core_deg + np.degrees(8.0 / size) / np.sqrt(np.clip(1 - c[None, :] ** 2
                                                                                   - c[:, None] ** 2, 1e-6, 1)))
        yy, xx = np.nonzero(near)
        sub = (np.arange(supersample) + 0.5) / supersample
        sx = ((xx[:, None, None] + sub[None, None, :]) - size / 2) / (size / 2)
        sy = ((yy[:, None, None] + sub[None, :, None]) - size / 2) / (size / 2)
        sx, sy = np.broadcast_arrays(sx, sy)
        r_sub, in_sub = ball_reflections(sx, sy)
        a_sub = np.degrees(np.arccos(np.clip(r_sub @ lc, -1, 1)))
        core[yy, xx] = np.where(in_sub, core_gain * np.exp(-0.5 * (a_sub / core_deg) ** 2), 0.0).mean(axis=(1, 2))
    return np.where(inside, core + halo, 0.0)


def synthetic_probe(env: np.ndarray, R: np.ndarray, light_dir_world: np.ndarray, flash_rgb: np.ndarray,
                    size: int = 256, env_scale: float = 1.0, core_deg: float = 0.6, halo_deg: float = 4.0,
                    core_gain: float = 50.0, halo_gain: float = 0.5, supersample: int = 1) -> np.ndarray:
    """A mirror-ball photograph of an HDR environment plus a point light (the probe's synthetic truth).

    Linear RGB (size, size, 3) clipped to [0, 1], the ball inscribed, seen orthographically by a camera
    with world→camera rotation ``R``; the environment's radiance times ``env_scale``; the light towards
    ``light_dir_world`` (unit, world) with colour ``flash_rgb``; angles in degrees.

    The light's reflection is a narrow core (``core_deg``, gain ``core_gain`` × flash, saturating the
    sensor) plus a wider halo (``halo_deg``, gain ``halo_gain``) — a real ball is never an ideal mirror;
    ``supersample``: see :func:`flash_reflection`.
    """
    lobe = flash_reflection(size, R, light_dir_world, core_deg, halo_deg, core_gain, halo_gain, supersample)
    out = probe_environment(env, R, size, env_scale) + lobe[..., None] * np.asarray(flash_rgb)[None, None, :]
    return np.clip(out, 0.0, 1.0)
