"""The capture pipeline: photograph + head + camera (+ probe, + mask) → a relightable face.

Steps (Paris et al. 2003, Fig. 3): rasterise the head as the camera sees it; the skin mask; the light
from the probe; the reflectance map from the skin pixels; the specular exponent; the Phong fit; the
detail texture (photograph / fitted model) baked into the head's UV space. :mod:`capture.face` writes
the result as a face folder and reads it back.
"""
from __future__ import annotations

import copy
import hashlib
import time
from collections import OrderedDict
from dataclasses import dataclass, field, replace
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import ndimage

from capture.ambient import ambient_per_normal
from capture.contour import contour_turn
from capture.errors import CaptureError
from capture.lobe import DetailSpecular, specular_from_detail
from capture.mask import landmark_region, refine_by_skin_colour
from capture.phong import (
    FitResult,
    Geometry,
    PhongParams,
    delta_e2000,
    fit_phong,
    photo_ambient_scale,
    shade,
)
from capture.pose import PoseRefinement, Surface, image_similarity_covariance, pinned, refine_rotation
from capture.raster import rasterize_uv
from capture.reflectance import ExponentEstimate, ReflectanceMap, build_reflectance_map, estimate_exponent
from capture.shadow import FlashShadow, flash_shadow
from km.srgb import srgb_decode, srgb_encode

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

    from capture.camera import Camera
    from capture.probe import ProbeAnalysis
    from capture.raster import GBuffer
    from painting.head import Head

#: The detail texture's range is [0, 2**DETAIL_DOUBLINGS].
DETAIL_DOUBLINGS = 3
#: The probe's flash-hue spread above which the capture warns. On 88 synthetic probes (6 environments
#: × 8 rotations × 2 flash positions, less the ambiguous ones) the 6 with a spread above 1.5 % had hue
#: errors of 2.8–24 %; 2 of the other 82 had 4–5 % (not caught), the rest under 3 %. It only decides
#: whether a warning is printed (no figure the capture returns depends on it), so it was left where
#: those probes put it.
FLASH_HUE_SPREAD_WARN = 0.015
#: A shaded-model value below this is replaced by it before dividing (the paper's "small value").
SHADED_FLOOR = 1e-3




def to_uint8(values: np.ndarray) -> np.ndarray:
    """Values in [0, 1] → uint8 in [0, 255] (rounded to nearest, clipped); the shape is kept."""
    return np.clip(np.round(np.asarray(values) * 255.0), 0, 255).astype(np.uint8)


def linear_to_srgb8(linear: np.ndarray) -> np.ndarray:
    """Linear RGB → 8-bit sRGB as a camera stores it, uint8 in [0, 255] of the same shape.

    Clipped to [0, 1] (the sensor), encoded with :func:`km.srgb.srgb_encode`, rounded to the nearest code.
    """
    return to_uint8(srgb_encode(np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)))


#: Refuse a photograph of more pixels than this (read as float64, 36 Mpx is 0.8 GiB), before decoding.
MAX_PHOTO_PIXELS = 36_000_000


def read_photo(path: str | Path) -> np.ndarray:
    """Read a photograph as linear RGB float64 (H, W, 3) in [0, 1] (8/16-bit sRGB images).

    A photograph of more than :data:`MAX_PHOTO_PIXELS` pixels is refused from its header, before decoding.
    """
    from PIL import Image, UnidentifiedImageError

    from core.photos import upright

    try:
        with Image.open(path) as im:
            if im.width * im.height > MAX_PHOTO_PIXELS:
                raise CaptureError(f"{path}: the photo is {im.width}×{im.height}, over the "
                                   f"{MAX_PHOTO_PIXELS:,}-pixel limit: downscale it")
            codes = np.asarray(upright(im).convert("RGB"))  # EXIF orientation applied
    except CaptureError:
        raise
    except FileNotFoundError:
        raise CaptureError(f"{path}: photo not found") from None
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError, Image.DecompressionBombError) as exc:
        raise CaptureError(f"{path}: cannot read the image: {exc}") from None
    return _SRGB8_TO_LINEAR[codes]  # the decode of each 8-bit code, looked up: no float temporaries


#: The linear value of each 8-bit sRGB code (:func:`read_photo`).
_SRGB8_TO_LINEAR = srgb_decode(np.arange(256, dtype=np.float64) / 255.0)


@dataclass
class PixelData:
    """The head as the photograph's camera sees it (covered pixels only, flattened).

    Attributes:
        rows, cols: (P,) pixel indices. normals: (P, 3) unit world normals. positions: (P, 3) mesh units.
        view: (P, 3) unit directions to the camera. uv: (P, 2). depth: (H, W) camera-space z (inf = empty).
    """

    rows: np.ndarray
    cols: np.ndarray
    normals: np.ndarray
    positions: np.ndarray
    view: np.ndarray
    uv: np.ndarray
    depth: np.ndarray


def pixel_data(head: Head, camera: Camera) -> PixelData:
    """Rasterise the head for the camera and interpolate its attributes per covered pixel.

    :class:`CaptureError` when fewer than 100 pixels are covered (the camera misses the head).
    """
    gb = camera.gbuffer(head.vertices, head.faces)
    cov = gb.covered
    if cov.sum() < 100:
        raise CaptureError("the head is (almost) not visible with this camera: check the correspondences")
    rows, cols = np.nonzero(cov)
    b = gb.bary[cov].astype(np.float64)
    f = head.faces[gb.tri[cov]]

    def interp(attr: np.ndarray) -> np.ndarray:
        return np.einsum("pk,pkc->pc", b, attr[f])

    nrm = interp(head.normals)
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)
    pos = interp(head.vertices)
    view = camera.centre[None, :] - pos
    view /= np.linalg.norm(view, axis=1, keepdims=True)
    depth = np.full(cov.shape, np.inf)
    depth[cov] = camera.to_camera(pos)[:, 2]
    return PixelData(rows=rows, cols=cols, normals=nrm, positions=pos, view=view, uv=interp(head.uv),
                     depth=depth)


def compute_skin_mask(head: Head, camera: Camera, photo_lin: np.ndarray, pix: PixelData) -> np.ndarray:
    """The computed skin mask (see :mod:`capture.mask`), bool (H, W) for the photograph (H, W, 3).

    The head's pixels facing the camera (n·v > 0.25) inside the landmarks' face region (without
    landmarks, an ellipse over the middle of the silhouette), refined by the skin-hue model;
    :class:`CaptureError` when fewer than 200 candidate pixels remain.
    """
    shape = photo_lin.shape[:2]
    front = np.zeros(shape, dtype=bool)
    facing = np.einsum("pc,pc->p", pix.normals, pix.view) > 0.25
    front[pix.rows[facing], pix.cols[facing]] = True
    region = landmark_region(camera, head.metadata.landmarks, shape)
    cand = front if region is None else front & region
    if region is None:
        # No landmarks: keep the central part of the head's silhouette (drops ears, neck and hair edge).
        rr, cc = np.nonzero(front)
        cy, cx = np.median(rr), np.median(cc)
        ry = 0.42 * (rr.max() - rr.min() + 1)
        rx = 0.38 * (cc.max() - cc.min() + 1)
        yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
        cand &= ((yy - cy) / ry) ** 2 + ((xx - cx) / rx) ** 2 <= 1.0
    if cand.sum() < 200:
        raise CaptureError("the computed skin region is too small; paint a mask and pass --mask")
    return refine_by_skin_colour(photo_lin, cand)


@dataclass
class CaptureResult:
    """Everything the capture found (:func:`capture.face.face_json` names the units).

    Attributes:
        camera, params, light_dir_world (unit, mesh coordinates), exponent, fit, rmap: what was fitted
            (``rmap``, the paper's reflectance map, is built when first read, unless the capture's progress
            lines said it).
        detail: float32 (S, S, 3) the detail texture, [0, 8]; detail_valid: bool (S, S) texels seen.
        skin_mask: bool (H, W) the skin pixels used; photo_lin: the photograph (H, W, 3), linear.
        fitted_render: (H, W, 3) the fitted Phong model alone; reproduction: Phong × detail, clipped.
        reproduction_de2000_skin: mean CIEDE2000 photo vs reproduction over the skin pixels used.
        probe: the probe analysis, or None. timings_s: seconds per step. robustness: see
        :func:`capture.phong.robustness`, or None. ambient_scale_photo: k the photograph alone prefers
        (diagnostic; like ``rmap``, fitted when first read unless the progress lines said it).
        specular_joint: i_s of the joint fit. specular_separation: i_s from the detail.
    """

    camera: Camera
    params: PhongParams
    light_dir_world: np.ndarray
    exponent: ExponentEstimate
    fit: FitResult
    detail: np.ndarray
    detail_valid: np.ndarray
    skin_mask: np.ndarray
    photo_lin: np.ndarray
    fitted_render: np.ndarray
    reproduction: np.ndarray
    reproduction_de2000_skin: float
    probe: ProbeAnalysis | None
    timings_s: dict[str, float] = field(default_factory=dict)
    robustness: dict[str, Any] | None = None
    specular_joint: float | None = None
    specular_separation: DetailSpecular | None = None
    pose: PoseRefinement | None = None
    #: ``rmap`` and ``ambient_scale_photo``: their values, and how to compute the ones not yet read.
    _values: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)
    _deferred: dict[str, Callable[[], Any]] = field(default_factory=dict, repr=False, compare=False)

    @property
    def rmap(self) -> ReflectanceMap:
        """The paper's reflectance map of the skin pixels (camera-space normals), built when first read."""
        return self._value("rmap")

    @property
    def ambient_scale_photo(self) -> float | None:
        """The ambient scale k the photograph alone prefers (diagnostic; :func:`capture.phong.photo_ambient_scale`)."""
        return self._value("ambient_scale_photo")

    def _value(self, name: str) -> Any:
        if name not in self._values:
            self._values[name] = self._deferred.pop(name)()
        return self._values[name]


def _log(progress: Callable[[str], None] | None, msg: str) -> None:
    if progress is not None:
        progress(msg)


@dataclass
class _FitPixels:
    """The pixels one pass of :func:`capture` fits the Phong model on, under the capture's light.

    Attributes:
        pix: the head's pixels; sel: bool (P,) the fit's among them (skin, facing the camera, out of the
            flash's cast shadows); colours: the photograph's linear RGB there; geo: their geometry.
        light_world: the flash's direction (unit, mesh coordinates); flash_rgb, ambient_rgb: the light's.
        shadow: the flash's cast shadows over the head's pixels.
    """

    pix: PixelData
    sel: np.ndarray
    colours: np.ndarray
    geo: Geometry
    light_world: np.ndarray
    flash_rgb: np.ndarray
    ambient_rgb: np.ndarray
    shadow: FlashShadow


def capture(head: Head, photo_lin: np.ndarray, camera: Camera, probe: ProbeAnalysis | None = None,
            mask: np.ndarray | None = None, texture_size: int = 1024,
            progress: Callable[[str], None] | None = None, robustness_starts: int = 0,
            refine_pose: bool = True, directional_ambient: bool = False) -> CaptureResult:
    """Run the whole capture.

    Args:
        head: the head (mesh units; its ``mm_per_unit`` sets the millimetre scales).
        photo_lin: (H, W, 3) linear RGB in [0, 1] (the camera's width/height must match).
        camera: the photograph's camera.
        probe: the light-probe analysis; None = a white flash on the camera's axis and no ambient light.
        mask: bool (H, W) painted skin mask, or None to compute one.
        texture_size: the detail texture's side (texels).
        progress: called with one line per step.
        robustness_starts: if > 0, also run the fit from this many random starts (paper: 200).
        refine_pose: for a camera calibrated from points (one with a ``rotation_covariance_deg2``),
            turn it to fit the photograph's specular lobe after the first (joint) Phong fit
            (:mod:`capture.pose`), then capture again from the turned camera.
        directional_ambient: fit with the probe's ambient for each pixel's normal, A(n) = E(n)/π
            (:mod:`capture.ambient`), instead of its mean A. Off by default: measured on the development scenes
            it moves D's ΔE2000 on the 45 bench scenes from 1.29 / 1.91 / 2.12 (median / p90 / worst) to
            1.28 / 1.84 / 2.11 (26 better, 17 worse; s, i_s and the light unchanged to every digit) and
            0.52 → 0.40 median on 16 development scenes, but worse where the probe's lamps clip (the studio
            sky: the softboxes hold 64 % of its light, and A(n) has their directions dark) and where the truth
            is the constant A itself; docs/CAPTURE.md.
    """
    t_all = time.perf_counter()
    timings: dict[str, float] = {}
    h, w = photo_lin.shape[:2]
    if (camera.width, camera.height) != (w, h):
        raise CaptureError(f"the camera is for {camera.width}×{camera.height} but the photo is {w}×{h}")
    fp, exp_est = _fit_pixels(head, photo_lin, camera, probe, mask, directional_ambient, timings, progress)
    t = time.perf_counter()
    fit = fit_phong(fp.colours, fp.geo, exp_est.s, fp.flash_rgb, fp.ambient_rgb)
    if refine_pose:
        again = partial(capture, head, photo_lin, probe=probe, mask=mask, texture_size=texture_size,
                        progress=progress, robustness_starts=robustness_starts, refine_pose=False,
                        directional_ambient=directional_ambient)
        turned = _capture_turned(again, head, photo_lin, camera, fp, fit.params, t_all, progress)
        if turned is not None:
            return turned
    specular_joint = fit.params.specular
    fit, exp_est, sep = _lobe_from_detail(fp, fit, exp_est, camera, (h, w), progress)
    p = fit.params
    # Two figures nothing downstream of the capture needs (face.json reports the first; the paper's reflectance
    # map is kept in the result): computed when first read, or here when the progress lines say them.
    deferred = {"ambient_scale_photo": partial(photo_ambient_scale, fp.colours, fp.geo, copy.deepcopy(p)),
                # built once the camera is final: a capture refitted from a turned camera above builds it there
                "rmap": partial(_timed, timings, "reflectance_map", build_reflectance_map,
                                (fp.pix.normals @ camera.R.T)[fp.sel], fp.colours)}
    result_values: dict[str, Any] = {}
    if progress is not None:
        result_values["ambient_scale_photo"] = k_photo = deferred.pop("ambient_scale_photo")()
    timings["phong_fit"] = time.perf_counter() - t
    if progress is not None:
        # the ambient scale is the probe's: without one there is no ambient light, and nothing to say about it
        ambient = "" if probe is None else (f", ambient scale {p.ambient_scale:.3f} (the probe's photometry"
                                            + ("" if k_photo is None else f"; the photograph alone would choose "
                                                                          f"{k_photo:.3f}")
                                            + ")")
        _log(progress, f"Phong fit: diffuse {np.round(p.diffuse, 4).tolist()}, specular {p.specular:.4f}{ambient}; "
                       f"residual {fit.rms_luv:.2f} Luv per pixel")
        result_values["rmap"] = rmap = deferred.pop("rmap")()
        _log(progress, f"reflectance map: {len(rmap.cluster_dirs)} clusters")
    rob = None if robustness_starts <= 0 else _robustness(fp, exp_est.s, robustness_starts, timings, progress)
    detail, valid, fitted, repro, de, skin_used = _reproduce(head, camera, photo_lin, fp, p, texture_size, timings,
                                                             progress)
    timings["total"] = time.perf_counter() - t_all
    _log(progress, f"reproduction: mean ΔE2000 {float(de.mean()):.2f} on skin; total {timings['total']:.1f} s")
    return CaptureResult(camera=camera, params=p, light_dir_world=fp.light_world, exponent=exp_est, fit=fit,
                         detail=detail, detail_valid=valid, skin_mask=skin_used, photo_lin=photo_lin,
                         fitted_render=fitted, reproduction=repro, reproduction_de2000_skin=float(de.mean()),
                         probe=probe, timings_s=timings, robustness=rob, specular_joint=specular_joint,
                         specular_separation=sep, _values=result_values, _deferred=deferred)


def _timed(timings: dict[str, float], name: str, func: Callable[..., Any], *args: Any) -> Any:
    """``func(*args)``, its seconds in ``timings[name]``."""
    t = time.perf_counter()
    out = func(*args)
    timings[name] = time.perf_counter() - t
    return out


def _fit_pixels(head: Head, photo_lin: np.ndarray, camera: Camera, probe: ProbeAnalysis | None,
                mask: np.ndarray | None, directional_ambient: bool, timings: dict[str, float],
                progress: Callable[[str], None] | None) -> tuple[_FitPixels, ExponentEstimate]:
    """The fit's pixels and the specular exponent: the head rasterised, the skin, the light, the flash's shadows.

    Records each step's seconds in ``timings`` (rasterise, mask, shadow, exponent).
    """
    h, w = photo_lin.shape[:2]
    t = time.perf_counter()
    pix = pixel_data(head, camera)
    timings["rasterise"] = time.perf_counter() - t
    _log(progress, f"head rasterised: {len(pix.rows)} pixels cover the head")
    t = time.perf_counter()
    sel = _skin_pixels(head, camera, photo_lin, pix, mask)
    timings["mask"] = time.perf_counter() - t
    _log(progress, f"skin mask: {int(sel.sum())} pixels")
    light_world, flash_rgb, ambient_rgb = _capture_light(camera, probe, pix, sel, progress)
    # The flash's cast shadows (capture/shadow.py): out of the fit, lifted out of the detail, drawn by the model.
    t = time.perf_counter()
    shadow = flash_shadow(head, pix.positions, pix.normals, pix.rows, pix.cols, (h, w), light_world)
    sel &= ~shadow.fit_excluded
    timings["shadow"] = time.perf_counter() - t
    _log(progress, f"flash shadow: {int(shadow.shadowed.sum())} pixels ({shadow.intersector} rays), "
                   f"{int(sel.sum())} skin pixels left")
    colours = photo_lin[pix.rows[sel], pix.cols[sel]]
    t = time.perf_counter()
    exp_est = estimate_exponent(pix.normals[sel], pix.view[sel], light_world, colours, camera.R[0],
                                flash_rgb=flash_rgb)
    _log(progress, f"specular exponent s = {exp_est.s:.1f} (Eq. 3 alone: {exp_est.s_eq3:.1f}; "
                   f"fastest saturation change at {exp_est.alpha_deg:.2f}°)")
    # With directional_ambient, the fit's ambient per pixel: the probe's irradiance for the pixel's normal
    # (capture.ambient). The detail texture, the fitted render and the reproduction below keep the constant
    # k·A: they are what the renderer draws (render.lightweight's ambient is one colour), so the detail
    # carries the rest and the photograph's own view under its own light comes back.
    ambient_px = None if not directional_ambient or probe is None or probe.ambient_sh is None else \
        ambient_per_normal(probe.ambient_sh, pix.normals[sel] @ camera.R.T)
    geo = Geometry.from_vectors(pix.normals[sel], pix.view[sel], light_world, ambient=ambient_px)
    timings["exponent"] = time.perf_counter() - t
    return _FitPixels(pix, sel, colours, geo, light_world, flash_rgb, ambient_rgb, shadow), exp_est


def _skin_pixels(head: Head, camera: Camera, photo_lin: np.ndarray, pix: PixelData,
                 mask: np.ndarray | None) -> np.ndarray:
    """Bool over ``pix``: skin (``mask``, or :func:`compute_skin_mask`) facing the camera (n·v > 0.05).

    :class:`CaptureError` when fewer than 200 remain.
    """
    h, w = photo_lin.shape[:2]
    if mask is None:
        mask = compute_skin_mask(head, camera, photo_lin, pix)
    covered = np.zeros((h, w), dtype=bool)
    covered[pix.rows, pix.cols] = True
    skin = mask & covered
    sel = skin[pix.rows, pix.cols]
    sel &= np.einsum("pc,pc->p", pix.normals, pix.view) > 0.05
    if sel.sum() < 200:
        raise CaptureError(f"only {int(sel.sum())} skin pixels on the head; check the mask and the camera")
    return sel


def _capture_light(camera: Camera, probe: ProbeAnalysis | None, pix: PixelData, sel: np.ndarray,
                   progress: Callable[[str], None] | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The flash's direction (unit, mesh coordinates), its colour and the ambient light's.

    The probe's (with warnings where its reading is doubtful), or without one a white flash on the camera's
    axis (towards the skin pixels' centroid) and no ambient light.
    """
    if probe is None:
        centroid = pix.positions[sel].mean(axis=0)
        light_world = camera.centre - centroid
        light_world /= np.linalg.norm(light_world)
        _log(progress, "no probe: a white flash on the camera axis, no ambient light")
        return light_world, np.ones(3), np.zeros(3)
    light_world = camera.R.T @ probe.light_dir_camera
    flash_rgb = probe.flash_rgb
    ambient_rgb = probe.ambient_rgb
    _log(progress, f"probe: light θ={probe.theta_deg:.2f}° φ={probe.phi_deg:.2f}°, "
                   f"flash hue {np.round(flash_rgb, 3).tolist()}, ambient {np.round(ambient_rgb, 4).tolist()}")
    if probe.flash_hue_spread > FLASH_HUE_SPREAD_WARN:
        _log(progress, f"warning: the flash's hue is uncertain: the halo's sectors disagree by "
                       f"{100 * probe.flash_hue_spread:.1f} % (a lamp or an edge of the environment "
                       f"behind the halo); the diffuse colour inherits that error")
    if probe.clipped_fraction > 0.01:
        _log(progress, f"warning: {100 * probe.clipped_fraction:.1f} % of the probe's environment is clipped "
                       f"(lamps, windows): the ambient light is a lower bound")
    return light_world, flash_rgb, ambient_rgb


def _capture_turned(again: Callable[..., CaptureResult], head: Head, photo_lin: np.ndarray, camera: Camera,
                    fp: _FitPixels, params: PhongParams, t_all: float,
                    progress: Callable[[str], None] | None) -> CaptureResult | None:
    """The capture run ``again`` from the camera turned to fit the specular lobe, or None when it does not turn.

    The pose refinement (:func:`_refine_pose`) needs D, k, A and F of the first fit's ``params`` (it fits s
    itself, i_s in closed form): the first pass stops there when the camera turns.
    """
    t_refine = time.perf_counter()
    pose = _refine_pose(head, photo_lin, camera, fp.pix, fp.sel, camera.R @ fp.light_world, params)
    t_pose = time.perf_counter() - t_refine
    if pose is None:
        return None
    _log(progress, f"camera turned {np.round(pose.turn_deg, 2).tolist()}° about its x and y axes to fit the "
                   f"specular lobe (the photograph alone: {np.round(pose.photometric_deg, 2).tolist()}°; "
                   f"± {np.round(pose.sigma_deg, 2).tolist()}°); fitting again")
    first = time.perf_counter() - t_all
    result = again(camera=pose.camera)
    result.timings_s["pose"] = t_pose
    result.timings_s["first_fit"] = first
    result.timings_s["total"] = time.perf_counter() - t_all
    result.pose = pose
    return result


def _lobe_from_detail(fp: _FitPixels, fit: FitResult, exp_est: ExponentEstimate, camera: Camera,
                      shape: tuple[int, int], progress: Callable[[str], None] | None
                      ) -> tuple[FitResult, ExponentEstimate, DetailSpecular | None]:
    """The lobe (s and i_s) fitted on the photograph high-passed at a few pixels, then D refitted with both fixed.

    There the skin's albedo variation no longer follows the lobe (the paper's saturation estimate and joint
    fit read it as part of the lobe; :func:`capture.lobe.specular_from_detail`). Returns the fit, the exponent
    (the saturation curve's kept as ``s_saturation``) and the separation; the joint fit's, and None, when the
    lobe has no unclipped core on the skin.
    """
    pix, sel = fp.pix, fp.sel
    # The lobe's registration corrects a head misplaced by a fraction of a pixel; a head pinned to the
    # photograph's own landmarks (the automatic capture) has none to correct, and the fit would cost the
    # kiosk ~1 s between the shutter and her first frame (3.65 s against 2.79 s, measured).
    vectors = None if pinned(camera) else (pix.normals[sel], pix.view[sel], fp.light_world)
    # With the landmarks' uncertainty, the lobe is also scaled and rolled within it (a camera's distance,
    # focal length and roll slightly off); a camera given directly keeps to the shift.
    similarity = None if vectors is None else image_similarity_covariance(
        camera, float(np.median(camera.to_camera(pix.positions[sel])[:, 2])))
    sep = specular_from_detail(fp.colours, fp.geo, fit.params, pix.rows[sel], pix.cols[sel], shape, vectors=vectors,
                               similarity_prior=similarity)
    if sep is None:
        _log(progress, "warning: the specular lobe has no unclipped core on the skin: s from the saturation curve "
                       "and i_s from the joint fit (both read albedo that varies under the lobe as specular)")
        return fit, exp_est, None
    specular_joint, diffuse_joint = fit.params.specular, fit.params.diffuse
    fit = fit_phong(fp.colours, fp.geo, sep.exponent, fp.flash_rgb, fp.ambient_rgb,
                    start=np.r_[fit.params.diffuse, sep.specular], fix_specular=True)
    exp_est = replace(exp_est, s=sep.exponent, s_saturation=exp_est.s)
    _log(progress, f"specular lobe on the photograph high-passed at σ = {sep.sigma_px:.1f} px: s = {sep.exponent:.2f} "
                   f"(saturation curve {exp_est.s_saturation:.2f}), i_s = {sep.specular:.4f} (joint fit "
                   f"{specular_joint:.4f}; the specular core's radius {sep.core_radius_px:.1f} px); D refitted, "
                   f"moved by ΔE2000 {float(delta_e2000(fit.params.diffuse, diffuse_joint)):.2f}")
    return fit, exp_est, sep


def _robustness(fp: _FitPixels, exponent: float, starts: int, timings: dict[str, float],
                progress: Callable[[str], None] | None) -> dict[str, Any]:
    """:func:`capture.phong.robustness` of the fit from ``starts`` random starts (its seconds in ``timings``)."""
    from capture.phong import robustness

    t = time.perf_counter()
    rob = robustness(fp.colours, fp.geo, exponent, fp.flash_rgb, fp.ambient_rgb, starts=starts)
    timings["robustness"] = time.perf_counter() - t
    _log(progress, f"robustness: {starts} random starts, max relative std {100 * rob['max_relative_std']:.3f} %")
    return rob


def _reproduce(head: Head, camera: Camera, photo_lin: np.ndarray, fp: _FitPixels, p: PhongParams,
               texture_size: int, timings: dict[str, float], progress: Callable[[str], None] | None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The detail texture, and the fitted model and its reproduction (model × detail) in the photograph's pose.

    Returns the detail texture and its seen texels, the fitted render, the reproduction, its ΔE2000 against
    the photograph on each skin pixel of the fit, and those pixels as an image mask (H, W).
    """
    pix, sel = fp.pix, fp.sel
    t = time.perf_counter()
    geo_all = Geometry.from_vectors(pix.normals, pix.view, fp.light_world)
    detail, valid = bake_detail(head, camera, fp.shadow.lift(photo_lin, pix.rows, pix.cols, p, geo_all, SHADED_FLOOR),
                                pix.depth, fitted_shading(p, fp.light_world), texture_size)
    timings["detail_texture"] = time.perf_counter() - t
    _log(progress, f"detail texture {texture_size}² baked ({100 * valid.mean():.1f} % of texels seen)")
    geo_all = fp.shadow.geometry(geo_all)
    fitted = np.zeros_like(photo_lin)
    fitted[pix.rows, pix.cols] = shade(p, geo_all)
    det_px = sample_texture(detail, pix.uv)
    repro = np.zeros_like(photo_lin)
    repro[pix.rows, pix.cols] = np.clip(shade(p, geo_all, clip=False) * det_px, 0, 1)
    de = delta_e2000(repro[pix.rows[sel], pix.cols[sel]], photo_lin[pix.rows[sel], pix.cols[sel]])
    skin_used = np.zeros(photo_lin.shape[:2], dtype=bool)
    skin_used[pix.rows[sel], pix.cols[sel]] = True
    return detail, valid, fitted, repro, de, skin_used


#: Rounds of :func:`capture.pose.refine_rotation`, each after rasterising the head again for the camera the
#: previous one turned. One: a round reads each pixel's surface where the turn moved it (first order in
#: the turn, :class:`capture.pose.Surface`), which holds for the landmarks' errors (≤ 1.5°); two rounds
#: left the rotation 0.39° off at the median on 32 development scenes, one 0.32° (capture.pose's), and on
#: a broad lobe (s 8) rounds of the earlier refinement ran away (0.5°, 1.1°, then 3.1° from 0.3°).
POSE_ROUNDS = 1
#: A round that turns the camera by less than this (degrees) ends the refinement: a tenth of the lobe's
#: own precision at best (0.2–0.5°, :mod:`capture.pose`).
POSE_SETTLED_DEG = 0.03


def _refine_pose(head: Head, photo_lin: np.ndarray, camera: Camera, pix: PixelData, sel: np.ndarray,
                 light_camera: np.ndarray, params: PhongParams) -> PoseRefinement | None:
    """:func:`capture.pose.refine_rotation` in rounds (:data:`POSE_ROUNDS`).

    The skin pixels ``sel`` of the first rasterisation ``pix`` are kept as an image mask; the flash
    towards ``light_camera`` (unit, camera coordinates); the first fit's ``params``. None when the camera
    is not refined (no covariance).
    """
    skin = np.zeros(photo_lin.shape[:2], dtype=bool)
    skin[pix.rows[sel], pix.cols[sel]] = True
    pivot = pix.positions[sel].mean(axis=0)
    # What the calibration's covariance turns about: its own correspondences' centroid (a points file need not
    # hold the head's landmarks; capture.camera.parameter_covariance).
    calibration_pivot = pivot if camera.parameter_pivot is None else camera.parameter_pivot
    pose = None
    cam = camera
    for _ in range(POSE_ROUNDS):
        if pose is not None:
            pix = pixel_data(head, cam)
            sel = skin[pix.rows, pix.cols]
        surface = Surface.from_pixels(pix.rows, pix.cols, pix.normals, pix.positions)
        # The face's outline, a third measurement of the turn (capture.contour); only where there is a
        # turn to refine (a camera given directly or pinned has none, and the kiosk's capture skips it).
        contour = None if cam.rotation_covariance_deg2 is None or pinned(cam) else contour_turn(
            photo_lin, head, cam, surface, pivot, calibration_pivot=calibration_pivot, light_camera=light_camera)
        step = refine_rotation(photo_lin, surface, cam, light_camera, params, pix.rows[sel], pix.cols[sel], pivot=pivot,
                               turned_deg=None if pose is None else pose.turn_deg, contour=contour)
        if step is None:
            return pose
        moved = float(np.linalg.norm(step.turn_deg - (0.0 if pose is None else pose.turn_deg)))
        pose, cam = step, step.camera
        if moved < POSE_SETTLED_DEG:
            break
    return pose


def sample_texture(tex: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Bilinear lookup of a UV-space texture (H, W, C) (top row first, texel centres at +0.5) at uv (P, 2)."""
    th, tw = tex.shape[:2]
    x = uv[:, 0] * tw - 0.5
    y = uv[:, 1] * th - 0.5
    return np.stack([ndimage.map_coordinates(tex[..., c], [y, x], order=1, mode="nearest")
                     for c in range(tex.shape[2])], axis=1)


#: Unseen texels: the distance (mm) over which the nearby seen detail fades to 1 (no detail: the
#: fitted diffuse colour alone); see :func:`bake_detail`.
UNSEEN_FADE_MM = 15.0


#: How many heads' UV layouts :func:`uv_layout` keeps (a 1024² one holds 28 MB, a 512² one 7 MB).
UV_LAYOUTS_KEPT = 2
_UV_LAYOUTS: OrderedDict[bytes, tuple[GBuffer, np.ndarray, np.ndarray]] = OrderedDict()


def uv_layout(uv: np.ndarray, faces: np.ndarray, size: int) -> tuple[GBuffer, np.ndarray, np.ndarray]:
    """The UV atlas rasterised at ``size``² and, for every texel, the nearest covered one.

    The rasterisation is :func:`capture.raster.rasterize_uv`'s; the nearest covered texel (row and column
    indices; itself when covered) is :func:`bake_detail`'s gutter fill. They depend on the UVs, the faces
    and the size alone — the same for every capture of a head, and for every automatic capture, whose heads
    all share the canonical topology — and cost more than the rest of the bake at 1024² (the nearest-texel
    transform alone 1.2 s), so the last :data:`UV_LAYOUTS_KEPT` are kept, keyed by their bytes; read-only.
    """
    uv = np.ascontiguousarray(uv)
    faces = np.ascontiguousarray(faces)
    digest = hashlib.blake2b(repr((uv.dtype.str, uv.shape, faces.dtype.str, faces.shape, int(size))).encode(),
                             digest_size=20)
    digest.update(uv.tobytes())
    digest.update(faces.tobytes())
    key = digest.digest()
    if key in _UV_LAYOUTS:
        _UV_LAYOUTS.move_to_end(key)
        return _UV_LAYOUTS[key]
    gb = rasterize_uv(uv, faces, (size, size))
    _, (iy, ix) = ndimage.distance_transform_edt(~gb.covered, return_indices=True)
    layout = (gb, iy, ix)
    for a in (gb.tri, gb.bary, gb.depth, iy, ix):
        a.flags.writeable = False
    _UV_LAYOUTS[key] = layout
    while len(_UV_LAYOUTS) > UV_LAYOUTS_KEPT:
        _UV_LAYOUTS.popitem(last=False)
    return layout


def _texels_per_unit_uv(head: Head) -> float:
    """UV units per mesh unit on the head, median over its triangles (√(UV area / 3D area))."""
    v = np.asarray(head.vertices)[head.faces]
    t = np.asarray(head.uv)[head.faces]
    a3 = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    a2 = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    ok = a3 > 1e-12
    return float(np.sqrt(np.median(a2[ok] / a3[ok]))) if ok.any() else 1.0


def fitted_shading(params: PhongParams, light_world: np.ndarray) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """The capture's fitted Phong model as a :func:`bake_detail` shading: (normals, view) → linear RGB, unclipped.

    ``params`` and the flash towards ``light_world`` (unit, mesh coordinates); the normals and the
    directions to the camera are unit (P, 3) in mesh coordinates.
    """
    def shading(normals: np.ndarray, view: np.ndarray) -> np.ndarray:
        return shade(params, Geometry.from_vectors(normals, view, light_world), clip=False)

    return shading


def bake_detail(head: Head, camera: Camera, photo_lin: np.ndarray, depth: np.ndarray,
                shading: Callable[[np.ndarray, np.ndarray], np.ndarray], size: int) -> tuple[np.ndarray, np.ndarray]:
    """The detail texture and the texels the photograph sees.

    Returns the photograph / shaded model per texel, float32 (size, size, 3) in [0, 8] (``size`` texels
    square, the head's UV space, top row first), and bool (size, size), the texels seen. ``shading``
    gives the model's linear RGB (P, 3) from the texels' unit normals and unit directions to the camera
    (P, 3, mesh coordinates); the capture passes :func:`fitted_shading`, the fitted Phong model
    unclipped — exactly what the lightweight engine multiplies the detail by, so the photograph's own
    view under its own light comes back. ``depth`` is the camera's depth image (:class:`PixelData`),
    mesh units.

    (Issue 14: the paper divides by the reflectance map, indexed by the camera-space normal. On a face
    turned from the camera the map also absorbs the regional albedo that correlates with the normal —
    the periphery is darker and redder — and the detail does not give that back: the reproduction of a
    face turned 15–30° was ΔE2000 2.0–2.9 on GPU-drawn photographs. Against the fitted model it is
    0.16–0.51 on all of them, turned or not; tests/capture/test_detail.py measures the gain away from
    the photograph's view.)

    Texels of the head the photograph does not see (its sides and back, under the chin) carry no
    measurement. Each takes the seen detail low-passed (a normalised Gaussian convolution over the
    seen texels, σ = 2 mm on the skin, so the skin's pores and blotches do not smear into streaks) at
    its nearest seen texel *on the head in 3D* (a k-d tree over texel positions, so a UV seam or a
    neighbouring UV island never lends it values), faded towards 1 — the fitted diffuse colour without
    detail — as e^(−d / ``UNSEEN_FADE_MM``) with d the distance in millimetres to that texel (1 beyond
    five fade lengths). (Before, each took its nearest seen texel
    *in UV*: streaks of single pores dragged across the unseen region, and values from across seams.)
    Texels outside every UV triangle (the gutter) copy the nearest covered texel in UV, so bilinear
    lookups at chart borders stay on the chart's own values. :func:`report_image` marks the unseen
    texels.
    """
    from scipy.spatial import cKDTree

    gb, iy, ix = uv_layout(head.uv, head.faces, size)
    cov = gb.covered
    b = gb.bary[cov].astype(np.float64)
    f = head.faces[gb.tri[cov]]
    pos = np.einsum("pk,pkc->pc", b, head.vertices[f])
    nrm = np.einsum("pk,pkc->pc", b, head.normals[f])
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)
    px, z = camera.project(pos)
    hh, ww = photo_lin.shape[:2]
    xi = np.floor(px[:, 0]).astype(np.int64)
    yi = np.floor(px[:, 1]).astype(np.int64)
    inb = (xi >= 0) & (yi >= 0) & (xi < ww) & (yi < hh) & (z > 0)
    vis = np.zeros(len(pos), dtype=bool)
    dz = np.full(len(pos), np.inf)
    dz[inb] = depth[yi[inb], xi[inb]]
    # Visible when the texel's depth is within a small tolerance of what the camera sees there.
    tol = 0.01 * float(np.median(z[inb])) if inb.any() else 0.0
    vis[inb] = np.abs(z[inb] - dz[inb]) <= tol
    view = camera.centre[None, :] - pos
    vis &= np.einsum("pc,pc->p", nrm, view) > 0
    if not vis.any():
        raise CaptureError("no texel of the head is visible in the photograph")
    photo = np.stack([ndimage.map_coordinates(photo_lin[..., c], [px[vis, 1] - 0.5, px[vis, 0] - 0.5], order=1,
                                              mode="nearest") for c in range(3)], axis=1)
    shaded = shading(nrm[vis], view[vis] / np.linalg.norm(view[vis], axis=1, keepdims=True))
    ratio = np.clip(photo / np.maximum(shaded, SHADED_FLOOR), 0.0, float(2 ** DETAIL_DOUBLINGS))
    detail = np.zeros((size, size, 3), dtype=np.float32)
    valid = np.zeros((size, size), dtype=bool)
    rr, cc = np.nonzero(cov)
    detail[rr[vis], cc[vis]] = ratio
    valid[rr[vis], cc[vis]] = True
    unseen = ~vis
    if unseen.any():
        # The seen detail low-passed (normalised convolution over the seen texels, σ = 2 mm on the
        # skin), read at each unseen texel's nearest seen texel in 3D, faded to 1 with the distance.
        mm_per_unit = float(head.mm_per_unit)
        sigma = max(1.0, 2.0 / mm_per_unit * size * _texels_per_unit_uv(head))
        wsum = ndimage.gaussian_filter(valid.astype(np.float64), sigma)
        low = np.stack([ndimage.gaussian_filter(detail[..., c] * valid, sigma) for c in range(3)], axis=-1)
        low = low / np.maximum(wsum, 1e-12)[..., None]
        # Beyond 5 fade lengths the weight is under 1 %: such texels are set to 1 (and the search
        # stops early, which keeps it fast on the back of the head).
        reach = 5.0 * UNSEEN_FADE_MM / mm_per_unit
        tree = cKDTree(pos[vis], balanced_tree=False, compact_nodes=False)
        dist, nb = tree.query(pos[unseen], k=1, distance_upper_bound=reach)
        near = np.isfinite(dist)
        fill = np.ones((len(dist), 3))
        w = np.exp(-dist[near] * mm_per_unit / UNSEEN_FADE_MM)[:, None]
        fill[near] = w * low[rr[vis][nb[near]], cc[vis][nb[near]]] + (1.0 - w)
        detail[rr[unseen], cc[unseen]] = fill
    detail = detail[iy, ix]  # the gutter: the nearest covered texel's value
    return detail, valid
