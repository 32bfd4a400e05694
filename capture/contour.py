"""The head's pose from its occluding contour: a third measurement of the camera's turn (issue 14).

The landmarks sit on the face, near the pivot :func:`capture.pose.refine_rotation` turns about (the skin's
centroid; :meth:`Camera.turned` keeps the pivot's image fixed), so a small turn of the camera hardly moves
them: that is why they leave the rotation about the camera's x and y axes uncertain by 0.4–1.5°. The face's
outline — its occluding contour, where the surface turns away from the view — lies behind the pivot (the
far cheek and the jaw's side, 15–40 mm behind it on the sample head): a turn E moves a contour point X by
E × (X − pivot) in camera space, ≈ 0.5–1.5 px per degree at the bench's framing (0.5 mm per pixel), and
an edge is located to a fraction of a pixel along its normal over a few hundred pixels of outline.

**The prediction.** The mesh's contour generator: the edges shared by a triangle facing the camera and one
facing away (the mesh's own boundary — the neck's cut, a hole — is never one: it has a single triangle,
and a person has none). Each such edge is sampled every image pixel; its image normal ν points away from
the facing triangle. A sample is kept only where it is the surface the camera sees (the first
rasterisation, :class:`capture.pose.Surface`: the point seen :data:`PROBE_PX` inside it lies within
:data:`SAME_SURFACE_FOOTPRINTS` of it) and where nothing of the head lies beyond it out to
:data:`PROFILE_PX` (the face against the background: internal contours — the nose over the cheek, the jaw
over the neck — have the other surface's shading and the flash's cast shadow right beside the edge, which
a level beyond it does not model; on the development scenes the jaw over the neck read 0.4–1.8 px off from
the true camera). Only contours a real photograph shows are used: the face's, between the brows and
:data:`BELOW_CHIN_EYES` below the gnathion, at most :data:`BEHIND_EYES` behind the outer eye corners
(:func:`face_contour_region`) — never the skull's top (hair), the ears (hair), nor the neck (a collar,
and the scan's cut). Near a frontal view the ears stand beyond most of the cheek's outline, so little is
left there (~100 samples at ±10°; ≥ 250 at ±20° and more).

**The measurement.** The pixels whose centres lie within half a pixel of each sample's normal line,
±:data:`PROFILE_PX` along it, are fitted by a level beyond the edge plus a step, a ramp and a bend inside
it, each as a pixel's square integrates it (:func:`measure_edges`): near a contour lit from near the camera
the skin darkens towards the edge (n·l → 0), and the midpoint between the two sides' levels lies 0.4–0.6
px inside the edge on the bench's photographs. Given the flash's direction (the first fit's), the bend
gives way to the flash's own shading across the limb, max(0, n·l) with n turning from the limb's outward
normal towards the camera over the limb's radius of curvature (:func:`limb_shading`, the geometry read
from the rasterisation by :func:`limb_geometry`): a flash beside the lens leaves the limb's last
fraction of a pixel on its far side in the attached shadow, which the step + ramp + bend read as an edge
inside the outline (on 16 development scenes, from the true cameras, the edge sat 0.13 px inside on
average and the outline read +0.18° of pitch, RMS 0.24°; with the limb's shading 0.10 px, +0.14°, RMS
0.18°; what remains is not this shading: the flash's shadow map's soft edge, the skin's texture). The offset e_i of the fitted edge from the prediction is,
to first order, ν_i · J_i a with J_i the sample's image motion per degree of turn a about the camera's x
and y axes (the contour slides over the surface as the head turns, but along the view ray, which
projects to a point: the second-order error is R·θ²/2, 0.02 mm for 1° on a 100 mm radius): a least-squares
fit of a (2 unknowns), samples beyond :data:`OUTLIER_MADS` robust standard deviations dropped, in
Gauss–Newton rounds that measure the edges again where the turned camera puts them. Its covariance is
cluster-robust (:func:`capture.covariance.cluster_covariance`, blocks of 16 px along the contour: the
skin's texture and the shading's error correlate neighbouring samples) times
:data:`CONTOUR_BIAS_VARIANCE`, the mean squared ratio measured on development scenes (the edge model's
own bias, the skin's texture at the outline).

**The landmarks' other errors.** The outline moves not only with a turn: an error of the landmark
calibration in the focal length and distance (perspective: a point 30 mm behind the pivot, seen from 0.56
of the true distance with a focal length 44 % short, moves 1.7 px relative to the face), in the image's
scale or roll, or in the translation moves it too, and an outline seen on one side cannot tell them
apart. So the contour is a measurement of A·δ, δ the calibration's whole error (rotation, translation,
log f) and A = (JᵀJ)⁻¹ Jᵀ J₇ the turn the fit reads per unit of each (``ContourTurn.alias``, J₇ the
samples' motion per parameter); :func:`capture.pose.refine_rotation` fuses it with the landmarks'
whole covariance (:attr:`Camera.parameter_covariance`) and the lobe's turn over all seven parameters.
Fused as a turn alone, the outline read a turn 9 of its σ off on such a scene (the focal length fitted
from the landmarks) and turned the camera the wrong way. On 47 development scenes the outline fixes the
turn about y to ~0.15° (RMS; the landmarks 0.47°) and about x to ~0.42° (the landmarks 0.48°): about x its
few horizontal parts (the cheek's ends) leave it loose, and from the true camera it read +0.21° on average
(RMS 0.26°; about y −0.01°, RMS 0.07°), within its σ.

**What a photograph needs.** Contrast at the outline: a sample is used only where the luminance beyond
the edge differs from the skin's inside by at least :data:`MIN_CONTRAST` of the brighter of the two. The
bench draws a black background (every face silhouette qualifies); a real photograph needs a background
darker (or brighter) than the skin by that much — a plain dark or light wall, a flash falling off behind
the sitter. Without it the samples drop out; with fewer than :data:`MIN_SAMPLES`, or a turn beyond
:data:`MAX_CONTOUR_TURN_DEG`, the cue is absent (None) and the pose rests on the other two measurements.
A background with edges of its own near the outline shows as outliers or as a wide residual, which widen
the cue's covariance rather than bias it; hair over the cheek's outline is not modelled (a real capture
with hair there should leave the cue out).

**Cost.** ~0.3 s per pose round on the bench's 512 px photographs (the edge fit tries 41 positions × 4
sign patterns for each of 250–550 samples, in 2–4 Gauss–Newton rounds).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING

import numpy as np

from capture.covariance import cluster_covariance

if TYPE_CHECKING:
    from capture.camera import Camera
    from capture.pose import Surface
    from painting.head import Head

#: Where a sample is checked against the rasterisation: the surface seen this far inside the predicted
#: edge (pixels) must be the contour's own, and beyond it the background or a farther surface.
PROBE_PX = 1.5
#: The surface seen :data:`PROBE_PX` inside a limb of curvature radius R lies √(2 R · 1.5 px) from the
#: contour point: 27 pixel footprints for R = 250 footprints (125 mm at the bench's 0.5 mm per pixel,
#: flatter than any part of a head's side). A surface farther than 40 footprints (20 mm) is another one
#: (the nose over the cheek, the chin over the neck).
SAME_SURFACE_FOOTPRINTS = 40.0
#: The profile read along each normal (± pixels) and the edge positions tried (± pixels): the Gauss–Newton
#: rounds of :func:`contour_turn` bring the edge within a pixel of the prediction, and the fit's bases
#: need ~3 px either side of it.
PROFILE_PX = 5.0
SEARCH_PX = 2.0
#: The smallest step in luminance across an edge, as a fraction of the brighter side, for a sample to
#: count (see the module docstring: what a photograph needs).
MIN_CONTRAST = 0.3
#: How far below the gnathion a face's contour reaches, in eye distances (the jaw's underside; below it
#: the neck's own outline, which a collar may hide and the scan cuts).
BELOW_CHIN_EYES = 0.1
#: How far behind the outer eye corners a face's contour reaches, in eye distances (the ears begin behind).
BEHIND_EYES = 0.8
#: Samples whose offset lies this many robust standard deviations (1.4826 × MAD) from the fit are
#: dropped (once) and the turn fitted again: a Gaussian sample lies beyond 3.5 σ 1 time in 2,000.
OUTLIER_MADS = 3.5
#: Fewer samples than this leave the cue out: at 1 px spacing that is 3 cm of outline, less than one
#: side of the jaw.
MIN_SAMPLES = 60
#: The contour's squared error (its turn less A·δ, δ the calibration's true error; the module docstring)
#: over its cluster-robust variance, averaged over 47 development scenes (s 10–50, the head turned ±10°
#: to ±35°, their own landmark noise and sensor; none the bench's or the tests'): 6.5 about x, 4.4 about
#: y with the flash's shading across the limb in the edge model (9.0 and 4.2 without it: the edge then
#: sat inside the outline and read +0.18° of pitch from the true cameras); this is their mean. (Read as
#: a turn alone, without A·δ, the ratio was 31 and 29: the calibration's other errors.)
CONTOUR_BIAS_VARIANCE = 5.5
#: Gauss–Newton rounds at most, and the step (degrees) under which the turn has settled: a tenth of the
#: best σ the other two measurements reach (0.2°).
ROUNDS = 4
SETTLED_DEG = 0.02
#: A contour turn beyond this (degrees) is no first-order correction of the landmarks' camera: four of
#: their σ at their loosest (1.5°), as :data:`capture.pose.MAX_TURN_DEG`.
MAX_CONTOUR_TURN_DEG = 6.0
#: The finite-difference step of a sample's image motion per degree (degrees; the motion is linear in
#: the turn to 10⁻⁴ px at that size).
GAIN_STEP_DEG = 0.1


@dataclass
class ContourSamples:
    """The predicted occluding contour: points sampled every pixel along it.

    Attributes:
        points: (N, 3) mesh-unit points on the contour generator.
        tangents: (N, 3) the contour's direction there (mesh units, the edge's length).
        outward: (N, 3) a direction on the surface away from the occluding side (mesh units): what
            orients the image normal.
        pixels: (N, 2) their image positions (x, y; pixel j covers [j, j + 1)) in the camera predicted for.
        normals: (N, 2) unit image normals pointing away from the occluding surface, in that camera.
    """

    points: np.ndarray
    tangents: np.ndarray
    outward: np.ndarray
    pixels: np.ndarray
    normals: np.ndarray

    def seen_by(self, camera: Camera) -> ContourSamples:
        """The same contour points as ``camera`` (a slightly turned one) sees them.

        The contour generator slides along the view rays as the head turns, so its image moves as its
        points' images do, to first order; the second-order error is R·θ²/2, 0.02 mm for a 1° turn of a
        100 mm radius.
        """
        pixels, normals = _image_normals(camera, self.points, self.tangents, self.outward)
        return ContourSamples(points=self.points, tangents=self.tangents, outward=self.outward, pixels=pixels,
                              normals=normals)


def _image_normals(camera: Camera, points: np.ndarray, tangents: np.ndarray,
                   outward: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(pixels (N, 2), unit image normals (N, 2)) of contour points in ``camera`` (see :class:`ContourSamples`)."""
    pixels, _ = camera.project(points)
    ahead, _ = camera.project(points + tangents)
    away, _ = camera.project(points + outward)
    along = ahead - pixels
    normals = np.stack([along[:, 1], -along[:, 0]], axis=1)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    flip = np.einsum("nc,nc->n", normals, away - pixels) < 0
    normals[flip] *= -1.0
    return pixels, normals


@dataclass
class ContourTurn:
    """The turn the occluding contour measures (see the module docstring).

    Attributes:
        turn_deg: (2,) the camera's turn about its x and y axes that the photograph's outline asks for
            (degrees; :meth:`Camera.turned` about the pivot given).
        covariance_deg2: (2, 2) its cluster-robust covariance (degrees²).
        samples: contour samples used (after outliers). dropped: samples dropped as outliers.
        rms_px: the residual's RMS along the normals (pixels).
        alias: (2, 7) the turn the fit reads per unit of each of the landmark calibration's parameters
            (:attr:`Camera.parameter_covariance`'s order: rotation vector in degrees, translation in mesh
            units, log f), or None for a camera without that covariance: an error of the calibration in
            the focal length and distance (perspective), the image's scale or the translation moves the
            outline as well as a turn does.
    """

    turn_deg: np.ndarray
    covariance_deg2: np.ndarray
    samples: int
    dropped: int
    rms_px: float
    alias: np.ndarray | None = None


def face_contour_region(head: Head, points: np.ndarray) -> np.ndarray:
    """Bool (N,): whether mesh points lie on the face's part of the head (see the module docstring).

    The face: between the brows' height and :data:`BELOW_CHIN_EYES` eye distances below the gnathion,
    and in front of the ears — forward of the outer eye corners' depth by more than −1.5 eye distances
    (the jaw's angle lies ~1 eye distance behind them, the ear ~1.8). The head's up axis and forward
    axis are read from its landmarks (the brows above the gnathion; the nose tip in front of the eyes).
    """
    lm = {k: np.asarray(v, dtype=float) for k, v in head.metadata.landmarks.items()}
    eyes = lm["left_eye"] - lm["right_eye"]
    eye_dist = float(np.linalg.norm(eyes))
    brow = 0.5 * (lm.get("left_brow", lm["left_eye"]) + lm.get("right_brow", lm["right_eye"]))
    chin = lm.get("gnathion", lm.get("chin"))
    if chin is None:
        raise KeyError("the head's landmarks name neither a gnathion nor a chin")
    up = brow - chin
    up -= eyes * (up @ eyes) / (eyes @ eyes)
    up /= np.linalg.norm(up)
    forward = np.cross(eyes / eye_dist, up)
    if forward @ (lm["nose_tip"] - 0.5 * (lm["left_eye"] + lm["right_eye"])) < 0:
        forward = -forward
    corners = 0.5 * (lm.get("left_eye_outer", lm["left_eye"]) + lm.get("right_eye_outer", lm["right_eye"]))
    height = (points - chin) @ up
    depth = (points - corners) @ forward
    return (height <= float((brow - chin) @ up)) & (height >= -BELOW_CHIN_EYES * eye_dist) & (depth >= -BEHIND_EYES * eye_dist)


def predict_contour(head: Head, camera: Camera, surface: Surface) -> ContourSamples | None:
    """The occluding contour ``camera`` sees of ``head`` on its face, checked against ``surface`` (its rasterisation).

    None when no sample remains.
    """
    verts = np.asarray(head.vertices, dtype=float)
    faces = np.asarray(head.faces)
    mesh = head.trimesh()  # its edge adjacency
    adj, edges = mesh.face_adjacency, mesh.face_adjacency_edges
    corner = verts[faces[:, 0]]
    facing = np.einsum("fc,fc->f", mesh.face_normals, camera.centre[None, :] - corner) > 0
    rim = facing[adj[:, 0]] != facing[adj[:, 1]]
    if not rim.any():
        return None
    front_face = np.where(facing[adj[rim, 0]], adj[rim, 0], adj[rim, 1])
    a, b = verts[edges[rim, 0]], verts[edges[rim, 1]]
    pa, _ = camera.project(a)
    pb, _ = camera.project(b)
    count = np.maximum(np.ceil(np.linalg.norm(pb - pa, axis=1)).astype(int), 1)
    which = np.repeat(np.arange(len(a)), count)
    frac = (np.arange(len(which)) - np.repeat(np.cumsum(count) - count, count) + 0.5) / count[which]
    points = a[which] + frac[:, None] * (b[which] - a[which])
    tangents = (b - a)[which]
    outward = points - verts[faces[front_face]].mean(axis=1)[which]
    pixels, normals = _image_normals(camera, points, tangents, outward)
    _, depth = camera.project(points)
    keep = face_contour_region(head, points) & (depth > 0)
    footprint = depth / float(camera.K[0, 0])
    reach = SAME_SURFACE_FOOTPRINTS * footprint
    inside = pixels - PROBE_PX * normals
    _, seen_in = surface.sample(inside[:, 0], inside[:, 1])
    keep &= np.linalg.norm(seen_in - points, axis=1) < reach
    for reach_px in (PROBE_PX, 0.5 * (PROBE_PX + PROFILE_PX), PROFILE_PX):
        keep &= ~_covered(surface, pixels + reach_px * normals)
    if not keep.any():
        return None
    return ContourSamples(points=points[keep], tangents=tangents[keep], outward=outward[keep], pixels=pixels[keep],
                          normals=normals[keep])


def _covered(surface: Surface, xy: np.ndarray) -> np.ndarray:
    """Bool (N,): whether the pixels holding image positions ``xy`` ((N, 2), x, y) are covered in ``surface``."""
    r = np.floor(xy[:, 1]).astype(int) - surface.row0
    c = np.floor(xy[:, 0]).astype(int) - surface.col0
    h, w = surface.covered.shape
    ok = (r >= 0) & (r < h) & (c >= 0) & (c < w)
    out = np.zeros(len(xy), dtype=bool)
    out[ok] = surface.covered[r[ok], c[ok]] > 0
    return out


#: The edge positions tried along each normal (pixels from the prediction, 0.1 apart; refined by a
#: parabola through the best three), the fine grid the edge's bases are tabulated on (pixels) and the
#: edge angles they are tabulated for (degrees, folded into 0–45°).
_E = np.arange(-SEARCH_PX, SEARCH_PX + 1e-9, 0.1)
_GRID = np.arange(-PROFILE_PX - SEARCH_PX - 2.0, PROFILE_PX + SEARCH_PX + 2.0 + 1e-9, 0.02)
_ANGLES = np.linspace(0.0, 45.0, 10)


@cache
def _edge_tables() -> np.ndarray:
    """(len(_ANGLES), 3, len(_GRID)): a step, a ramp and a bend leaving the edge inwards, as one pixel sees them.

    At u (the pixel's centre's distance from the edge along its normal, pixels, positive outwards) the
    inside is H(−u), (−u)₊ and (−u)₊²; a pixel integrates them over its square, whose extent along the
    normal is the trapezoid box(|cos θ|) ⊛ box(|sin θ|) for an edge at θ to the pixel grid (exact for a
    straight edge, whatever its sub-pixel phase).
    """
    inner = np.maximum(-_GRID, 0.0)
    raw = np.stack([(_GRID < 0).astype(float), inner, inner**2])
    out = np.empty((len(_ANGLES), 3, len(_GRID)))
    for a, angle in enumerate(_ANGLES):
        kern = _footprint(angle)
        out[a] = [np.convolve(r, kern, mode="same") for r in raw]
    return out


def _footprint(angle_deg: float) -> np.ndarray:
    """A pixel's square's extent along an edge's normal at ``angle_deg`` to the grid, on :data:`_GRID`'s step.

    The trapezoid box(|cos θ|) ⊛ box(|sin θ|), unit sum.
    """
    step = _GRID[1] - _GRID[0]
    kern = np.ones(1)
    for width in (np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))):
        n = max(int(round(width / step)), 1)
        kern = np.convolve(kern, np.ones(n) / n)
    return kern


def _signed_fit(x: np.ndarray, y: np.ndarray, sign: np.ndarray) -> np.ndarray:
    """(N,): the least squared residual of y (N, P) on the bases x (N, P, B; the level last).

    The bases: a step, a ramp or the flash's shading across the limb, then free ones. The first two take the sign ``sign`` (N,) of the inside's contrast, or are absent.
    Free signs would let a negative step cancel a ramp in the pixel the edge crosses, and place the edge
    anywhere between two pixel centres; the skin is brighter (or darker) than what lies beyond it on both
    counts, at once.
    """
    best = np.full(len(y), np.inf)
    free = tuple(range(2, x.shape[-1]))
    for cols in ((0, 1, *free), (1, *free), (0, *free), free):
        xs = x[..., list(cols)]
        gram = np.einsum("npa,npb->nab", xs, xs) + 1e-12 * np.eye(len(cols))
        coef = np.linalg.solve(gram, np.einsum("npa,np->na", xs, y)[..., None])[..., 0]
        res = y - np.einsum("npa,na->np", xs, coef)
        sse = np.einsum("np,np->n", res, res)
        ok = np.all(coef[:, [i for i, c in enumerate(cols) if c < 2]] * sign[:, None] >= 0.0, axis=1)
        best = np.where(ok & (sse < best), sse, best)
    return best


def limb_geometry(samples: ContourSamples, camera: Camera, surface: Surface, light_camera: np.ndarray) -> np.ndarray:
    """(N, 3): what the flash's shading across each sample's limb depends on (see :func:`limb_shading`).

    Columns: ν·l and c·l, with ν the surface's outward normal at the limb (perpendicular to the view ray,
    in the plane of the image normal), c the unit direction towards the camera and l the flash's direction
    (``light_camera``, unit, camera coordinates); and R, the limb's radius of curvature across the edge in
    pixels, from the rasterised normal :data:`PROBE_PX` inside the edge: a circular section has
    n·c = sin φ at 1 − cos φ = d / R from the limb.
    """
    light = camera.R.T @ np.asarray(light_camera, dtype=float)
    n_in, _ = surface.sample(*(samples.pixels - PROBE_PX * samples.normals).T)
    towards = camera.centre[None, :] - samples.points
    towards /= np.linalg.norm(towards, axis=1, keepdims=True)
    sin_in = np.clip(np.einsum("nc,nc->n", n_in, towards), 1e-3, 0.999)
    nu = n_in - sin_in[:, None] * towards
    nu /= np.maximum(np.linalg.norm(nu, axis=1, keepdims=True), 1e-12)
    radius = PROBE_PX / (1.0 - np.sqrt(1.0 - sin_in**2))
    return np.stack([nu @ light, towards @ light, radius], axis=1)


def limb_shading(limb: np.ndarray, angle_bins: np.ndarray) -> np.ndarray:
    """The flash's diffuse shading max(0, n·l) across each sample's limb as a pixel integrates it: (N, G).

    Tabulated on :data:`_GRID` (u, a pixel's centre's distance from the edge along its normal, pixels,
    positive outwards); ``limb`` (N, 3) from :func:`limb_geometry`; ``angle_bins`` (N,) the index in
    :data:`_ANGLES` of each edge's angle to the pixel grid (the pixel's footprint, :func:`_footprint`). At
    d = −u inside the limb n = cos φ ν + sin φ c with cos φ = 1 − d / R: with the flash off the lens's
    axis on the far side of the limb (ν·l < 0) the last sliver, 1 − cos φ_t = d_t / R with
    tan φ_t = −ν·l / c·l, lies in the attached shadow and only the ambient lights it (0.4–0.6 px wide for
    a flash 8° beside the lens on the bench's cheeks).
    """
    from scipy.signal import fftconvolve  # noqa: PLC0415 - many rows, one kernel per angle

    d = np.maximum(-_GRID, 0.0)[None, :]
    cos_phi = np.clip(1.0 - d / limb[:, 2, None], -1.0, 1.0)
    sin_phi = np.sqrt(1.0 - cos_phi**2)
    lit = np.maximum(cos_phi * limb[:, 0, None] + sin_phi * limb[:, 1, None], 0.0) * (d > 0)
    out = np.empty_like(lit)
    for a in np.unique(angle_bins):
        rows = angle_bins == a
        out[rows] = fftconvolve(lit[rows], _footprint(float(_ANGLES[a]))[None, :], mode="same", axes=1)
    return out


def measure_edges(photo_lin: np.ndarray, samples: ContourSamples,
                  limb: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The photograph's edge along each sample's normal: (offsets (N,) pixels, usable (N,) bool).

    The pixels whose centres lie within half a pixel of the sample's normal line, ±:data:`PROFILE_PX`
    along it, are fitted (least squares, their luminance), for each edge position within
    ±:data:`SEARCH_PX`, by a level beyond the edge plus a step, a ramp and a bend inside it as each pixel
    integrates them (:func:`_edge_tables`: near an occluding contour lit from near the camera the skin
    darkens towards the edge, n·l → 0, so the midpoint between the two sides' levels lies 0.4–0.6 px
    inside it on the bench's photographs); the offset is the position of least squared residual, measured
    from the predicted edge along the normal (positive: farther out). With ``limb`` ((N, 3),
    :func:`limb_geometry`) the bend is replaced by the flash's shading across the limb
    (:func:`limb_shading`): the ambient's step, the flash's shading (both of the contrast's sign), a ramp
    (the albedo's trend) and the level beyond. Unusable: a step below
    :data:`MIN_CONTRAST` between the two sides, or a best position at the search's end.
    """
    tables = _edge_tables()
    lum = np.asarray(photo_lin, dtype=float).sum(axis=2)
    h, w = lum.shape
    reach = int(np.ceil(PROFILE_PX)) + 1
    dy, dx = np.mgrid[-reach:reach + 1, -reach:reach + 1]
    base = np.floor(samples.pixels).astype(int)
    cx = base[:, 0, None] + dx.ravel()[None, :]
    cy = base[:, 1, None] + dy.ravel()[None, :]
    rel_x = cx + 0.5 - samples.pixels[:, 0, None]
    rel_y = cy + 0.5 - samples.pixels[:, 1, None]
    nx, ny = samples.normals[:, 0, None], samples.normals[:, 1, None]
    u = rel_x * nx + rel_y * ny
    v = -rel_x * ny + rel_y * nx
    inside_image = (cx >= 0) & (cx < w) & (cy >= 0) & (cy < h)
    weight = ((np.abs(v) <= 0.5) & (np.abs(u) <= PROFILE_PX) & inside_image).astype(float)
    y = np.where(inside_image, lum[np.clip(cy, 0, h - 1), np.clip(cx, 0, w - 1)], 0.0) * weight
    # Only the strip's pixels (~2·PROFILE_PX of the (2·reach + 1)² around each sample) enter the fit.
    strip = np.argsort(-weight, axis=1, kind="stable")[:, :int(weight.sum(axis=1).max())]
    u, weight, y = (np.take_along_axis(a, strip, axis=1) for a in (u, weight, y))
    folded = np.degrees(np.arctan2(np.abs(ny), np.abs(nx)))[:, 0]
    folded = np.minimum(folded, 90.0 - folded)
    bins = np.rint(folded / (_ANGLES[1] - _ANGLES[0])).astype(int)
    table = tables[bins]  # (N, 3, G)
    # The flash's shading across each sample's limb, on the same grid (N, G).
    flash = None if limb is None else limb_shading(limb, bins)
    near_in = weight * ((u >= -3.0) & (u <= -1.0))
    near_out = weight * ((u >= 1.0) & (u <= 3.0))
    inner = (y * near_in).sum(axis=1) / np.maximum(near_in.sum(axis=1), 1.0)
    outer = (y * near_out).sum(axis=1) / np.maximum(near_out.sum(axis=1), 1.0)
    sign = np.where(inner >= outer, 1.0, -1.0)
    step = _GRID[1] - _GRID[0]
    sse = np.empty((len(u), len(_E)))
    rows = np.arange(len(u))[:, None]
    for k, e in enumerate(_E):
        at = np.clip(np.rint((u - e - _GRID[0]) / step).astype(int), 0, len(_GRID) - 1)
        if flash is None:
            bases = [table[rows, b, at] for b in range(3)]
        else:  # the ambient's step, the flash's shading across the limb, a ramp (the albedo's trend)
            bases = [table[rows, 0, at], flash[rows, at], table[rows, 1, at]]
        x = np.concatenate([np.stack(bases, axis=2), np.ones((*u.shape, 1))], axis=2) * weight[..., None]
        sse[:, k] = _signed_fit(x, y, sign)
    best = np.argmin(sse, axis=1)
    usable = (np.abs(inner - outer) >= MIN_CONTRAST * np.maximum(np.maximum(inner, outer), 1e-12))
    usable &= (best > 0) & (best < len(_E) - 1) & (near_in.sum(axis=1) > 0) & (near_out.sum(axis=1) > 0)
    k = np.clip(best, 1, len(_E) - 2)
    lo, mid, hi = sse[rows[:, 0], k - 1], sse[rows[:, 0], k], sse[rows[:, 0], k + 1]
    curve = lo - 2.0 * mid + hi
    frac = np.where(curve > 0, 0.5 * (lo - hi) / np.where(curve > 0, curve, 1.0), 0.0)
    offsets = _E[k] + np.clip(frac, -1.0, 1.0) * (_E[1] - _E[0])
    return offsets, usable


def contour_turn(photo_lin: np.ndarray, head: Head, camera: Camera, surface: Surface, pivot: np.ndarray,
                 calibration_pivot: np.ndarray | None = None,
                 light_camera: np.ndarray | None = None) -> ContourTurn | None:
    """The camera's turn about ``pivot`` (mesh units) that the photograph's occluding contour asks for.

    ``surface``: ``camera``'s rasterisation of ``head``. Gauss–Newton: the edges are measured again where
    the turned camera puts them (the search window follows the edge), at most :data:`ROUNDS` times.
    ``calibration_pivot``: the point the landmark calibration's rotation is about (mesh units; its points'
    centroid, :func:`capture.camera.parameter_covariance`); with it and a camera that has that covariance,
    the result's ``alias`` says how each calibration parameter's error reads as a turn. ``light_camera``:
    the flash's direction (unit, ``camera``'s coordinates; the first fit's), for the edge model's shading
    across the limb (:func:`measure_edges`); without it the generic step + ramp + bend. None when the cue
    is absent (see the module docstring).
    """
    first = predict_contour(head, camera, surface)
    if first is None or len(first.points) < MIN_SAMPLES:
        return None
    limb = None if light_camera is None else limb_geometry(first, camera, surface, light_camera)
    turn = np.zeros(2)
    for _ in range(ROUNDS):
        cam = camera.turned(np.radians([turn[0], turn[1], 0.0]), pivot)
        samples = first.seen_by(cam)
        offsets, usable = measure_edges(photo_lin, samples, limb)
        if usable.sum() < MIN_SAMPLES:
            return None
        gain = _turn_gain(cam, samples, pivot)[usable]
        e = offsets[usable]
        keep = _inliers(gain, e)
        if keep.sum() < MIN_SAMPLES:
            return None
        step, *_ = np.linalg.lstsq(gain[keep], e[keep], rcond=None)
        turn = turn + step
        if np.any(np.abs(turn) > MAX_CONTOUR_TURN_DEG):
            return None
        if float(np.abs(step).max()) < SETTLED_DEG:
            break
    res = e[keep] - gain[keep] @ step
    pix = samples.pixels[usable][keep]
    try:
        cov = CONTOUR_BIAS_VARIANCE * cluster_covariance(gain[keep], res, np.floor(pix[:, 1]).astype(int),
                                                         np.floor(pix[:, 0]).astype(int))
    except np.linalg.LinAlgError:
        return None
    alias = None
    if calibration_pivot is not None and camera.parameter_covariance is not None:
        moved = _calibration_gain(cam, samples, np.asarray(calibration_pivot, dtype=float))[usable][keep]
        alias, *_ = np.linalg.lstsq(gain[keep], moved, rcond=None)
    return ContourTurn(turn_deg=turn, covariance_deg2=cov, samples=int(keep.sum()), dropped=int((~keep).sum()),
                       rms_px=float(np.sqrt(np.mean(res**2))), alias=alias)


def _turn_gain(camera: Camera, samples: ContourSamples, pivot: np.ndarray) -> np.ndarray:
    """(N, 2): each sample's image motion along its normal per degree of turn about the camera's x and y axes."""
    gain = np.zeros((len(samples.points), 2))
    for k in range(2):
        rot = np.zeros(3)
        rot[k] = np.radians(GAIN_STEP_DEG)
        moved, _ = camera.turned(rot, pivot).project(samples.points)
        gain[:, k] = np.einsum("nc,nc->n", moved - samples.pixels, samples.normals) / GAIN_STEP_DEG
    return gain


def _calibration_gain(camera: Camera, samples: ContourSamples, pivot: np.ndarray) -> np.ndarray:
    """(N, 7): each sample's image motion along its normal per unit of the landmark calibration's parameters.

    The order and units of :attr:`Camera.parameter_covariance` (rotation vector about ``pivot`` in camera
    coordinates, per degree; the translation added to t, per mesh unit; log f), by central differences.
    """
    out = np.zeros((len(samples.points), 7))
    steps = np.array([*(np.radians(GAIN_STEP_DEG),) * 3, *(1e-3,) * 3, 1e-4])
    per = np.array([*(GAIN_STEP_DEG,) * 3, 1e-3, 1e-3, 1e-3, 1e-4])
    for k in range(7):
        moved = []
        for sign in (1.0, -1.0):
            e = np.zeros(7)
            e[k] = sign * steps[k]
            cam = camera.turned(e[:3], pivot)
            cam.t = cam.t + e[3:6]
            cam.K = cam.K.copy()
            cam.K[0, 0] *= np.exp(e[6])
            cam.K[1, 1] *= np.exp(e[6])
            moved.append(cam.project(samples.points)[0])
        out[:, k] = np.einsum("nc,nc->n", moved[0] - moved[1], samples.normals) / (2.0 * per[k])
    return out


def _inliers(gain: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Bool (N,): the samples within :data:`OUTLIER_MADS` robust standard deviations of a least-squares fit."""
    keep = np.ones(len(offsets), dtype=bool)
    for _ in range(3):
        fit, *_ = np.linalg.lstsq(gain[keep], offsets[keep], rcond=None)
        res = offsets - gain @ fit
        spread = 1.4826 * float(np.median(np.abs(res[keep] - np.median(res[keep]))))
        new = np.abs(res) <= OUTLIER_MADS * max(spread, 1e-3)
        if np.array_equal(new, keep) or new.sum() < MIN_SAMPLES:
            break
        keep = new
    return keep
