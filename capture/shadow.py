"""The flash's cast shadows on the captured head (issue 14).

The Phong model the capture fits (:mod:`capture.phong`) lights every pixel that faces the flash; in a
real photograph the nose, the brow and the lips cast shadows wherever the flash is away from the lens
(beside it, above it, on a bracket). Skin in such a shadow shows only the ambient light: read by the fit it
looks like darker albedo (D too dark) or like a dip of the lobe (s and i_s thrown off), and baked into the
detail texture it darkens the face under every light afterwards.

The capture knows both what casts the shadows — the head's mesh, in the photograph's calibrated pose — and
where the flash is (the probe's direction), so it casts its own shadow rays: one per covered pixel, from
the surface point towards the flash, through trimesh's ray tests (:mod:`trimesh.ray`: Intel Embree through
``embreex`` when it is installed, about 0.1 s for the 147,000 pixels of the validation's 512² photograph;
else trimesh's pure-Python intersector on an R-tree, about 4 s; :func:`intersector_name` says which). Then:

- the skin pixels in the shadow, and those next to one (the pixel straddles the shadow's edge), are left
  out of the reflectance map, the exponent and the Phong fit (:attr:`FlashShadow.fit_excluded`);
- the model the detail texture divides by leaves the flash out there: the photograph's shadowed pixels are
  lifted by the fitted model's unshadowed / shadowed ratio before they are baked
  (:meth:`FlashShadow.lift`), so the detail keeps the skin's albedo, not the shadow; a renderer that casts
  its own shadows (the lightweight engine's shadow maps) draws it again under that flash and not under
  any other;
- the capture's own fitted render and reproduction shade those pixels with the ambient light alone
  (:meth:`FlashShadow.geometry`), so the reproduction shows the shadow from the model.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from capture.phong import Geometry, PhongParams, shade

if TYPE_CHECKING:
    from painting.head import Head

#: A shadow ray starts off the surface by these fractions of the mesh's median edge e (3.4 mm on the sample
#: head): along the normal, the bound of a facet's sagitta e²/8r where the radius of curvature r is at least
#: an edge (the smooth, normal-interpolated surface the pixel sees lies up to that far from the facets);
#: towards the flash, a quarter edge more, so that where the smooth normal faces the flash but the facet
#: does not (the terminator) the ray leaves the facet's neighbours before it can hit them. Against the GPU
#: truth's shadow map (tests/capture/test_shadow.py), only the normal offset of e/4 agreed on 99.63 % of
#: the lit pixels (the ray started inside the other lip in the creases); these two on 99.88 %.
RAY_OFFSET_NORMAL_EDGES = 1.0 / 8.0
RAY_OFFSET_LIGHT_EDGES = 1.0 / 4.0
#: Pixels within this many pixels of a shadowed one are left out of the fit too: a pixel's footprint
#: straddles the shadow's edge (the ray is cast through its centre only).
EDGE_PX = 1


def intersector_name() -> str:
    """``"embree"`` when trimesh's Embree intersector is available (``embreex``), else ``"python"``."""
    from trimesh.ray import has_embree

    return "embree" if has_embree else "python"


def occluded(head: Head, points: np.ndarray, normals: np.ndarray, light: np.ndarray) -> np.ndarray:
    """Whether the head's mesh hides the flash from each surface point, bool (P,).

    Args:
        head: the head (its vertices and faces are the occluders; mesh units).
        points: (P, 3) points on the head's surface, mesh units.
        normals: (P, 3) their unit normals (the ray starts off the surface: :data:`RAY_OFFSET_NORMAL_EDGES`).
        light: (3,) unit direction towards the flash (a directional light), mesh coordinates.
    """
    import trimesh

    points = np.asarray(points, dtype=np.float64)
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    mesh = trimesh.Trimesh(np.asarray(head.vertices, dtype=np.float64), np.asarray(head.faces), process=False)
    edge = float(np.median(mesh.edges_unique_length))
    light = np.asarray(light, dtype=np.float64) / np.linalg.norm(light)
    if intersector_name() == "embree":
        from trimesh.ray.ray_pyembree import RayMeshIntersector
    else:
        from trimesh.ray.ray_triangle import RayMeshIntersector  # type: ignore[assignment]
    origins = points + edge * (RAY_OFFSET_NORMAL_EDGES * np.asarray(normals, dtype=np.float64)
                               + RAY_OFFSET_LIGHT_EDGES * light)
    return np.asarray(RayMeshIntersector(mesh).intersects_any(origins, np.broadcast_to(light, points.shape)),
                      dtype=bool)


@dataclass
class FlashShadow:
    """The flash's cast shadow over the photograph's covered pixels.

    Attributes:
        shadowed: bool (P,) per covered pixel (in the order of :class:`capture.pipeline.PixelData`):
            the flash is hidden from the pixel's centre by the head (a cast shadow; pixels facing away
            from the flash are not counted, the model already leaves the flash out there).
        fit_excluded: bool (P,): shadowed, or within :data:`EDGE_PX` of a shadowed pixel.
        intersector: which ray intersector ran (:func:`intersector_name`).
    """

    shadowed: np.ndarray
    fit_excluded: np.ndarray
    intersector: str

    def geometry(self, geo: Geometry) -> Geometry:
        """``geo`` (of all the covered pixels) with the flash hidden where shadowed (n·l → at most 0)."""
        return Geometry(np.where(self.shadowed, np.minimum(geo.n_dot_l, 0.0), geo.n_dot_l), geo.r_dot_v)

    def lift(self, photo_lin: np.ndarray, rows: np.ndarray, cols: np.ndarray, params: PhongParams,
             geo: Geometry, floor: float) -> np.ndarray:
        """The photograph with its shadowed pixels as the fitted model says they would be under the flash.

        ``photo_lin`` (H, W, 3) linear; ``rows``, ``cols``, ``geo``: the covered pixels (unshadowed
        geometry). Each shadowed pixel is multiplied by the model's unshadowed / shadowed value (both
        unclipped), so dividing it by the unshadowed model gives the skin's detail; unbounded above (a
        detail texture clips it). Where the shadowed model is below ``floor`` in every channel (no ambient
        light: the capture without a probe) the shadow shows nothing of the skin, and the pixel becomes the
        unshadowed model itself (detail 1, as for the texels the photograph does not see). A copy; the
        other pixels unchanged.
        """
        out = np.array(photo_lin, dtype=np.float64, copy=True)
        i = np.nonzero(self.shadowed)[0]
        if len(i):
            lit = shade(params, geo.subset(i), clip=False)
            dark = shade(params, self.geometry(geo).subset(i), clip=False)
            lifted = out[rows[i], cols[i]] * lit / np.maximum(dark, floor)
            out[rows[i], cols[i]] = np.where((dark < floor).all(axis=1, keepdims=True), lit, lifted)
        return out


def flash_shadow(head: Head, positions: np.ndarray, normals: np.ndarray, rows: np.ndarray, cols: np.ndarray,
                 shape: tuple[int, int], light: np.ndarray) -> FlashShadow:
    """Cast the flash's shadow rays from the covered pixels (see the module docstring).

    Args:
        head: the head (mesh units).
        positions: (P, 3) the surface point at each covered pixel's centre, mesh units.
        normals: (P, 3) the unit normals there.
        rows: (P,) the pixels' rows in the photograph.
        cols: (P,) their columns.
        shape: the photograph's (H, W), pixels.
        light: (3,) unit direction towards the flash, mesh coordinates.
    """
    from scipy import ndimage

    facing = np.einsum("pc,c->p", normals, light) > 0
    shadowed = np.zeros(len(rows), dtype=bool)
    shadowed[facing] = occluded(head, positions[facing], normals[facing], light)
    img = np.zeros(shape, dtype=bool)
    img[rows[shadowed], cols[shadowed]] = True
    near = ndimage.binary_dilation(img, iterations=EDGE_PX) if EDGE_PX > 0 and shadowed.any() else img
    return FlashShadow(shadowed=shadowed, fit_excluded=near[rows, cols], intersector=intersector_name())
