"""Two views of a captured shopper (issue 15): the *mirror* and the *relight* view.

**Mirror** (:class:`MirrorView`): her photograph in its own pose, size and light, with the makeup
composited physically on the face. The head the capture fitted is drawn with the photograph's camera
(:func:`render.pinhole.pinhole_camera`); per pixel the capture's fitted Phong model (Paris et al. 2003,
:mod:`capture.phong`) gives the diffuse irradiance E = k·A + F·max(n·l, 0) and the specular
S = i_s·F·max(r·v, 0)^s; the skin's albedo is a = (photograph − S) / E; the document's cosmetic layers —
the physical renderer's texture-space Kubelka–Munk pass (:class:`render.km_pass.KMTextureSpace`, the
same spectral evaluation) — go over it as the physical renderer composes them (``km_compose.glsl``);
the result is shaded again with E and S (the skin's highlight through the layers, T², plus the layers'
own Kelemen lobes under the flash). It is written as the photograph plus the difference the makeup
makes, so where there is no makeup the photograph comes back byte for byte; the difference fades out
over :data:`EDGE_FEATHER_MM` at the mesh's open boundary and towards its silhouette. Outside the face
the photograph is untouched. See ``mirror_face.frag.glsl``.

Her lips (:mod:`render.mirror_lips`): where the face has her detected landmarks (the automatic capture),
the lip layers (lipstick, gloss, liner) show only within her lips' own outer contour, a smooth curve
through the landmarks rasterised antialiased at the photograph's resolution (the atlas's lip region, seen
through the camera, is the mesh's faceted polygon, feathered outwards); outside it the other layers
alone make the difference (a second KM pass without the lip layers). On her lips her own micro-shading
(the photograph's luminance over its low-pass there) shades the made-up colour as it shades the bare
lip, so a full-coverage lipstick keeps her lips' texture. :attr:`MirrorView.clip_lips` False draws
without both (as a face without landmarks).

**Relight** (:class:`RelightView`): the lightweight engine (:class:`render.lightweight.LightweightRenderer`,
Phong × the detail texture) on the captured head, from the photograph's camera orbited by up to
:data:`MAX_TURN_DEG` about the neck (:func:`render.pinhole.turn_pivot`), under the captured flash or a
kiosk light preset (:meth:`RelightView.set_preset`), with the same layers. How far it turns each way is
what her photograph supports (:func:`turn_limits`): a face photographed turned away from the camera
turns less towards the side the photograph saw at a grazing angle.

Both hold a ``km`` (:class:`KMTextureSpace`) and ``set_layers``, so a
:class:`render.binding.DocumentBinding` keeps either in sync with a document. The document's paint maps
must be in the head's own UVs (a head whose layout is not ``"mesh"`` is not supported here).

render/ may not import capture/: the face is a :class:`render.captured.CapturedFace` (``capture.face.Face``:
its fitted ``params``, ``detail``, ``camera()`` and ``light_dir()``), as in :mod:`render.lightweight`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from render.errors import RenderError
from render.glutil import set_uniform, write_uniform
from render.km_pass import KMTextureSpace, LayerInput
from render.lights import Light
from render.lightweight import upload_layer_lobes
from render.pinhole import pinhole_camera, turn_matrix, turn_pivot
from render.settings import RenderSettings
from render.shaders import ShaderLibrary

if TYPE_CHECKING:
    import moderngl

    from core.camera import Pinhole
    from km.library import Library
    from painting import Document
    from painting.head import Head
    from render.binding import DocumentBinding
    from render.camera import OrbitCamera
    from render.captured import CapturedFace

#: The relight view's largest turn from the photograph's view, degrees (yaw and pitch each).
MAX_TURN_DEG = 25.0
#: The relight view turns no further than where this share of her face's on-screen area is still texels
#: her photograph saw well (:func:`turn_limits`), 0..1. Measured on Grace Hopper's landmarks (stretch 2):
#: photographed head-on, the share at ±25° of yaw is 0.96–0.98 (full head) and 0.98–1.00 (face mesh);
#: photographed from 15° to one side, it falls to 0.89–0.90 at 25° the other way, 0.93–0.95 at 15°.
TURN_MIN_SHARE = 0.95
#: A texel is seen well when the photograph saw it at least 1/this as squarely as the turned view shows
#: it (cosines of the surface against the direction to each camera): a photograph pixel stretched over at
#: most this many screen pixels' worth of surface.
TURN_MAX_STRETCH = 2.0
#: Her face, for :func:`turn_limits`, in multiples of the outer eye corners' distance: the half width of
#: the ellipse (x, about the corners' middle) and how deep behind the nose tip (−z) it reaches; the
#: ellipse runs from the gnathion to 10 % above the forehead landmark. (On Grace Hopper's face mesh this
#: is 418 of its 468 vertices; its width is 1.6 × her eye corners' distance.)
FACE_HALF_WIDTH = 0.8
FACE_DEPTH = 0.7
#: The landmarks :func:`turn_limits` needs (a head without them turns ±:data:`MAX_TURN_DEG`).
FACE_LANDMARKS = ("left_eye_outer", "right_eye_outer", "gnathion", "forehead", "nose_tip")
#: Over how many millimetres from the mesh's open boundary the makeup fades in (mirror view).
EDGE_FEATHER_MM = 4.0
#: n·v below which the makeup fades out towards the silhouette (mirror view).
EDGE_NV = 0.2


def edge_weights(vertices: np.ndarray, faces: np.ndarray, mm_per_unit: float,
                 feather_mm: float = EDGE_FEATHER_MM) -> np.ndarray:
    """Per vertex, 0 on the mesh's open boundary rising smoothly to 1 at ``feather_mm`` from it (N,).

    Vertices at the same position (UV seams split them) are merged first, so a seam is not a boundary;
    a closed mesh gives 1 everywhere. Distances are straight-line, to the nearest boundary vertex.
    """
    from scipy.spatial import cKDTree

    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    scale = max(float(np.ptp(v, axis=0).max()), 1e-12)
    _, ids = np.unique(np.round(v / scale * 1e6).astype(np.int64), axis=0, return_inverse=True)
    ids = ids.ravel()
    e = np.sort(np.concatenate([ids[f[:, [0, 1]]], ids[f[:, [1, 2]]], ids[f[:, [2, 0]]]]), axis=1)
    e = e[e[:, 0] != e[:, 1]]
    uniq, counts = np.unique(e, axis=0, return_counts=True)
    boundary_ids = np.unique(uniq[counts == 1])
    if len(boundary_ids) == 0:
        return np.ones(len(v))
    boundary = np.isin(ids, boundary_ids)
    dist, _ = cKDTree(v[boundary]).query(v, k=1)
    x = np.clip(dist * float(mm_per_unit) / feather_mm, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


@dataclass(frozen=True)
class TurnLimits:
    """How far the relight view turns from the photograph's view, degrees (each within ±:data:`MAX_TURN_DEG`).

    ``yaw`` (least, most): negative shows more of her right cheek, positive more of her left; ``pitch``
    (least, most): positive looks from above. ``share``: the measured share of her face's on-screen area
    that her photograph saw well at each of the four limits (yaw least, yaw most, pitch least, pitch most).
    """

    yaw: tuple[float, float] = (-MAX_TURN_DEG, MAX_TURN_DEG)
    pitch: tuple[float, float] = (-MAX_TURN_DEG, MAX_TURN_DEG)
    share: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)

    def clamp(self, yaw: float, pitch: float) -> tuple[float, float]:
        """``yaw``, ``pitch`` (degrees) clamped into the limits."""
        return (float(np.clip(yaw, *self.yaw)), float(np.clip(pitch, *self.pitch)))

    def allows(self, yaw: float, pitch: float) -> bool:
        """Whether the turn (degrees) is finite and within the limits (a thousandth of a degree of slack)."""
        return bool(np.isfinite(yaw) and np.isfinite(pitch) and self.yaw[0] - 1e-3 <= yaw <= self.yaw[1] + 1e-3
                    and self.pitch[0] - 1e-3 <= pitch <= self.pitch[1] + 1e-3)


def _vertex_areas(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """A third of the area of each vertex's triangles (mesh units²), (N,)."""
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    out = np.zeros(len(v))
    for k in range(3):
        np.add.at(out, f[:, k], area / 3.0)
    return out


def face_vertices(head: Head) -> np.ndarray | None:
    """Bool (N,): the head's vertices on her face (:data:`FACE_HALF_WIDTH`, :data:`FACE_DEPTH`), or None.

    None when the head lacks one of :data:`FACE_LANDMARKS` or they are degenerate.
    """
    lm = head.metadata.landmarks or {}
    if any(name not in lm for name in FACE_LANDMARKS):
        return None
    p = {name: np.asarray(lm[name], dtype=float) for name in FACE_LANDMARKS}
    span = abs(float(p["left_eye_outer"][0] - p["right_eye_outer"][0]))
    y0, y1 = float(p["gnathion"][1]), float(p["forehead"][1])
    y1 += 0.1 * (y1 - y0)
    if not (span > 0 and y1 > y0):
        return None
    v = np.asarray(head.vertices, dtype=float)
    cx = 0.5 * float(p["left_eye_outer"][0] + p["right_eye_outer"][0])
    ellipse = ((v[:, 0] - cx) / (FACE_HALF_WIDTH * span)) ** 2 + ((v[:, 1] - 0.5 * (y0 + y1)) / (0.5 * (y1 - y0))) ** 2
    return np.asarray((ellipse <= 1.0) & (v[:, 2] >= float(p["nose_tip"][2]) - FACE_DEPTH * span))


def turn_limits(head: Head, photo_camera: Pinhole, min_share: float = TURN_MIN_SHARE,
                stretch: float = TURN_MAX_STRETCH, step_deg: float = 1.0) -> TurnLimits:
    """How far her photograph lets the relight view turn (:class:`TurnLimits`, degrees).

    Her face (:func:`face_vertices`) is weighed by its on-screen area (vertex area × the cosine of its
    normal against the direction to the turned camera; back-facing 0). A vertex is seen well where the
    cosine towards the photograph's camera times ``stretch`` reaches the turned view's cosine. From the
    photograph's view, yaw and pitch each go out in ``step_deg`` steps, each way, to the last angle (at most
    :data:`MAX_TURN_DEG`) where the seen-well share of the area is still at least ``min_share``. Occlusion
    (the nose over a cheek) is not modelled. A head without :data:`FACE_LANDMARKS` turns
    ±:data:`MAX_TURN_DEG`. About 10 ms for a 9,000-vertex head.

    Raises:
        RenderError: ``min_share`` outside 0..1, ``stretch`` below 1 or ``step_deg`` outside 0.1..25.
    """
    if not (0.0 <= min_share <= 1.0 and stretch >= 1.0 and 0.1 <= step_deg <= MAX_TURN_DEG):
        raise RenderError(f"turn limits need a share in 0..1, a stretch ≥ 1 and a step in 0.1..{MAX_TURN_DEG:g}°; "
                          f"got {min_share!r}, {stretch!r}, {step_deg!r}")
    on_face = face_vertices(head)
    if on_face is None or not on_face.any():
        return TurnLimits()
    v = np.asarray(head.vertices, dtype=float)[on_face]
    n = np.asarray(head.normals, dtype=float)[on_face]
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    area = _vertex_areas(np.asarray(head.vertices, dtype=float), np.asarray(head.faces, dtype=np.int64))[on_face]
    pivot = turn_pivot(head.vertices, head.metadata.landmarks, float(head.mm_per_unit))
    centre = np.asarray(photo_camera.centre, dtype=float)

    def cosines(eye: np.ndarray) -> np.ndarray:
        d = eye[None, :] - v
        return np.einsum("pc,pc->p", n, d) / np.maximum(np.linalg.norm(d, axis=1), 1e-30)

    seen = cosines(centre) * float(stretch)

    def share(yaw: float, pitch: float) -> float:
        eye = (turn_matrix(yaw, pitch, pivot) @ np.append(centre, 1.0))[:3]
        weight = area * np.clip(cosines(eye), 0.0, None)
        total = float(weight.sum())
        return float(weight[seen >= np.clip(cosines(eye), 0.0, None)].sum()) / total if total > 0 else 0.0

    steps = np.arange(step_deg, MAX_TURN_DEG + 1e-9, step_deg)
    out: list[tuple[float, float]] = []  # (limit, share there) for yaw −, yaw +, pitch −, pitch +
    for axis in ("yaw", "pitch"):
        for sign in (-1.0, 1.0):
            limit, at = 0.0, share(0.0, 0.0)
            for a in steps:
                s = share(sign * a, 0.0) if axis == "yaw" else share(0.0, sign * a)
                if s < min_share:
                    break
                limit, at = float(sign * a), s
            out.append((limit, at))
    return TurnLimits(yaw=(out[0][0], out[1][0]), pitch=(out[2][0], out[3][0]),
                      share=(out[0][1], out[1][1], out[2][1], out[3][1]))


def photo_camera_at(face: CapturedFace, width: int, height: int) -> Pinhole:
    """The face's photograph camera for her photograph at ``width`` × ``height`` pixels.

    The capture may have fitted the face on a reduced copy of the photograph (face.json ``downscale``:
    ``capture.auto.MAX_FACE_PX``); the photograph itself — the size the copy was reduced ``from``, or any
    size at least the capture's of the same aspect ratio (within a pixel) — draws with the camera's
    intrinsics scaled to it (:meth:`core.camera.Pinhole.scaled_to`).

    Raises:
        RenderError: a smaller photograph, or one of another aspect ratio.
    """
    cam = face.camera()
    if (width, height) == (cam.width, cam.height):
        return cam
    why = "smaller" if width < cam.width or height < cam.height else ""
    if not why:
        try:
            return cam.scaled_to(width, height)
        except ValueError:
            why = "of another aspect ratio"
    raise RenderError(f"the photograph is {width}×{height} but the face was captured from a {cam.width}×"
                      f"{cam.height} one ({why}: give that photograph or the original it was reduced from)")


class _Layers:
    """The cosmetic layers of a view: its own :class:`KMTextureSpace`, or one shared with another view."""

    def _init_layers(self, ctx: moderngl.Context, shaders: ShaderLibrary, km: KMTextureSpace | None) -> None:
        self._own_km = km is None
        self.km = km if km is not None else KMTextureSpace(ctx, shaders)
        #: False shows the face without makeup (before/after) without touching the layers
        self.show_makeup = True

    def set_layers(self, layers: list[LayerInput]) -> None:
        """The cosmetic layers, bottom first (evaluated now, in texture space); ``[]`` = bare."""
        self.km.set_layers(layers)

    def bind_document(self, doc: Document, library: Library | None = None) -> DocumentBinding:
        """A :class:`render.binding.DocumentBinding` keeping this view's layers equal to ``doc``'s.

        Call its ``flush()`` before each frame and ``close()`` when done. Views sharing a KM pass need one
        binding. Raises :class:`RenderError` for a document painted in another UV layout than the head's
        own (an xatlas unwrap): the views address the paint maps with the mesh's UVs.
        """
        from render.binding import DocumentBinding

        source = getattr(getattr(doc, "layout", None), "source", "mesh")
        if source != "mesh":
            raise RenderError(f"the document is painted in a '{source}' UV layout; the mirror and relight views "
                              f"need the head's own UVs")
        return DocumentBinding(doc, self, library)  # type: ignore[arg-type]

    @property
    def has_makeup(self) -> bool:
        """Layers are set, visible, and :attr:`show_makeup` is on."""
        return self.show_makeup and bool(self.km.active)

    def _release_layers(self) -> None:
        if self._own_km:
            self.km.release()


class MirrorView(_Layers):
    """The photograph with the makeup composited on the face (see the module docstring).

    Args:
        ctx: a GL 4.5 context.
        head: the head the face was captured on (mesh units, its own UVs for the paint maps).
        face: the captured face (:class:`render.captured.CapturedFace`: fitted ``params``, the camera and the
            flash's direction).
        photo: the photograph, uint8 sRGB (H, W, 3) (as shot; its bytes come back unchanged where there is no
            makeup): the size the face was captured from or, where the capture fitted a reduced copy, the
            original at its own resolution (any size at least the capture's of its aspect ratio:
            :func:`photo_camera_at`). The view draws at the photograph's size: the albedo is the photograph's
            own pixel divided by the fitted shading, so every pixel keeps her photograph's detail; the
            makeup's texture-space maps are sampled with linear filtering (smooth edges at any size).
        shaders: a shader library to share, or None.
        km: a KM pass to share with another view (not released by this one), or None for its own.

    Attributes: ``size`` (the photograph's width, height, pixels), ``camera`` (the photograph's, a
    :class:`render.camera.OrbitCamera`), ``spec_intensity`` (the layers' own lobes' scale, the physical
    renderer's default), ``show_makeup``.
    """

    def __init__(self, ctx: moderngl.Context, head: Head, face: CapturedFace, photo: np.ndarray,
                 shaders: ShaderLibrary | None = None, km: KMTextureSpace | None = None) -> None:
        img = np.asarray(photo)
        if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] not in (3, 4):
            raise RenderError(f"the photograph must be uint8 RGB (H, W, 3), got {img.dtype} {img.shape}")
        h, w = img.shape[:2]
        self.ctx = ctx
        self.head = head
        self.face = face
        self.size = (w, h)
        self.shaders = shaders or ShaderLibrary()
        self.camera: OrbitCamera = pinhole_camera(photo_camera_at(face, w, h), head.vertices)
        self.light_dir = face.light_dir()
        self.spec_intensity = RenderSettings().layer_spec_intensity
        self._init_layers(ctx, self.shaders, km)
        rgba = np.concatenate([img[::-1, :, :3], np.full((h, w, 1), 255, np.uint8)], axis=2)
        self.photo = ctx.texture((w, h), 4, np.ascontiguousarray(rgba).tobytes())
        self.photo.filter = (ctx.NEAREST, ctx.NEAREST)
        v = np.asarray(head.vertices, dtype="f4")
        n = np.asarray(head.normals, dtype=np.float64)
        n = (n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)).astype("f4")
        edge = edge_weights(head.vertices, head.faces, float(head.mm_per_unit)).astype("f4")
        self._buffers = [ctx.buffer(v.tobytes()), ctx.buffer(n.tobytes()),
                         ctx.buffer(np.asarray(head.uv, dtype="f4").tobytes()), ctx.buffer(edge.tobytes())]
        self._faces = np.asarray(head.faces, dtype="u4")
        self._index = ctx.buffer(reserve=max(self._faces.nbytes, 12))
        self._all_index = ctx.buffer(self._faces.tobytes())
        # the whole head's depth first (colour kept), so a triangle with makeup stays hidden behind one without
        self._depth = self.shaders.program(ctx, "mirror_face.vert", "depth_only.frag")
        self._depth_vao = ctx.vertex_array(self._depth, [(self._buffers[0], "3f", "in_position")], self._all_index)
        uv = np.asarray(head.uv, dtype=np.float64)[self._faces]  # (F, 3, 2)
        self._tri_uv_box = (uv.min(axis=1), uv.max(axis=1))
        self._drawn: tuple[int, int] = (-1, 0)  # (km.version the index buffer was made for, triangles in it)
        self._background = self.shaders.program(ctx, "fullscreen.vert", "mirror_photo.frag")
        self._background_vao = ctx.vertex_array(self._background, [])
        self._programs: dict[int, tuple[Any, Any]] = {}
        self._offscreen: tuple[Any, Any, Any] | None = None
        self._init_lips(img)

    def _init_lips(self, img: np.ndarray) -> None:
        """Her lips in the photograph (:func:`render.mirror_lips.lip_image`) uploaded for the face program."""
        from render.mirror_lips import lip_image

        h = img.shape[0]
        #: False: the lip layers as the atlas paints them, without her micro-shading (before/after)
        self.clip_lips = True
        self.lips = lip_image(self.face, self.head, photo_camera_at(self.face, *self.size), img)
        self._rest: KMTextureSpace | None = None
        self._rest_version = -1
        self._lip_texture: Any = None
        self._lip_box = (0, 0, 0, 0)
        if self.lips is not None:
            cov, shade = self.lips.coverage, self.lips.shading
            rg = np.ascontiguousarray(np.stack([cov, shade], axis=2)[::-1], dtype="f4")
            self._lip_texture = self.ctx.texture((cov.shape[1], cov.shape[0]), 2, rg.tobytes(), dtype="f4")
            self._lip_texture.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
            x0, y0 = self.lips.origin
            self._lip_box = (x0, h - (y0 + cov.shape[0]), cov.shape[1], cov.shape[0])

    def _lip_slots(self) -> list[bool]:
        """Per active layer of the KM pass, whether it is a lip layer clipped to her lips (all False when off)."""
        from render.mirror_lips import is_lip_layer

        km = self.km
        if self.lips is None or not self.clip_lips:
            return [False] * len(km.active)
        return [is_lip_layer(km.layers[i]) for i in km.active]

    def _update_rest(self, lip_slots: list[bool]) -> None:
        """Evaluate the KM pass without the lip layers when the layers changed.

        Called before the frame's framebuffer is bound: the pass draws into its own.
        """
        km = self.km
        if not any(lip_slots) or (self._rest is not None and self._rest_version == km.version):
            return
        if self._rest is None:
            self._rest = KMTextureSpace(self.ctx, self.shaders)
        lip_ids = {i for i, lip in zip(km.active, lip_slots, strict=True) if lip}
        self._rest.set_layers([lay for i, lay in enumerate(km.layers) if i not in lip_ids])
        self._rest_version = km.version

    def _bind_lips(self, prog: Any, lip_slots: list[bool]) -> None:
        """Bind her lips' texture and the KM pass without the lip layers (units 6–9), and their uniforms."""
        on = any(lip_slots) and self._rest is not None
        if on:
            assert self._rest is not None
            self._rest.bind(6)
            self._lip_texture.use(9)
        else:
            self.km.bind(6)  # unread: the samplers stay valid
        set_uniform(prog, "u_lip_box", self._lip_box if on else (0, 0, 0, 0))
        flags = np.zeros(8, np.float32)
        flags[:min(len(lip_slots), 8)] = np.asarray(lip_slots[:8], dtype=np.float32)
        write_uniform(prog, "u_layer_lip", flags)
        for name, unit in (("u_rest_r_top", 6), ("u_rest_transmittance", 7), ("u_rest_r_bottom", 8), ("u_lips", 9)):
            set_uniform(prog, name, unit)

    def _program(self, n_layers: int) -> tuple[Any, Any]:
        """The face program (and its vertex array) for ``n_layers`` specular lobes, compiled once."""
        if n_layers not in self._programs:
            prog = self.shaders.program(self.ctx, "mirror_face.vert", "mirror_face.frag", {"MV_NL": n_layers})
            b = self._buffers
            vao = self.ctx.vertex_array(prog, [(b[0], "3f", "in_position"), (b[1], "3f", "in_normal"),
                                               (b[2], "2f", "in_uv"), (b[3], "1f", "in_edge")], self._index)
            self._programs[n_layers] = (prog, vao)
        return self._programs[n_layers]

    def _triangles_with_makeup(self) -> int:
        """Fill the index buffer with the triangles whose UV box meets a 64² tile holding makeup; their count.

        The KM pass tracks which tiles of its maps any layer is non-zero in (``km.present``); a triangle
        elsewhere would only add a difference of 0, so only these are drawn (a lipstick: a few hundred
        of the head's triangles). Rebuilt when the layers change (``km.version``).
        """
        km = self.km
        if self._drawn[0] == km.version:
            return self._drawn[1]
        from painting.tiles import TILE

        present = km.present.any(axis=0) if km.present.size else np.zeros((1, 1), bool)
        rows, cols = present.shape
        w, h = km.size
        sat = np.zeros((rows + 1, cols + 1), np.int64)  # summed-area table of the tiles holding makeup
        sat[1:, 1:] = present.cumsum(0).cumsum(1)
        lo, hi = self._tri_uv_box
        # one texel of margin (bilinear filtering), then the tile range of each triangle's UV box
        c0 = np.clip(((lo[:, 0] * w - 1) // TILE).astype(np.int64), 0, cols - 1)
        c1 = np.clip(((hi[:, 0] * w + 1) // TILE).astype(np.int64), 0, cols - 1)
        r0 = np.clip(((lo[:, 1] * h - 1) // TILE).astype(np.int64), 0, rows - 1)
        r1 = np.clip(((hi[:, 1] * h + 1) // TILE).astype(np.int64), 0, rows - 1)
        count = sat[r1 + 1, c1 + 1] - sat[r0, c1 + 1] - sat[r1 + 1, c0] + sat[r0, c0]
        faces = self._faces[count > 0]
        if len(faces):
            self._index.write(np.ascontiguousarray(faces).tobytes())
        self._drawn = (km.version, len(faces))
        return len(faces)

    def render(self, fbo: moderngl.Framebuffer, viewport: tuple[int, int, int, int] | None = None) -> None:
        """Draw the frame into ``fbo`` (8-bit RGBA with a depth attachment; the photograph's size).

        ``viewport`` must be the photograph's size (the photograph is fetched per pixel); default all of ``fbo``.
        """
        ctx = self.ctx
        vx, vy, w, h = viewport if viewport is not None else (0, 0, *fbo.size)
        if (w, h) != self.size:
            raise RenderError(f"the mirror view draws at the photograph's size {self.size[0]}×{self.size[1]}, "
                              f"not {w}×{h}")
        lip_slots = self._lip_slots() if self.has_makeup else []
        self._update_rest(lip_slots)
        fbo.use()
        fbo.viewport = (vx, vy, w, h)
        fbo.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
        ctx.disable(ctx.DEPTH_TEST | ctx.BLEND | ctx.CULL_FACE)
        self.photo.use(0)
        set_uniform(self._background, "u_photo", 0)
        self._background_vao.render(mode=ctx.TRIANGLES, vertices=3)
        if not self.has_makeup:
            return
        n_triangles = self._triangles_with_makeup()
        if n_triangles == 0:
            return
        km = self.km
        n_layers = len(km.active)
        prog, vao = self._program(n_layers)
        p = self.face.params
        vp = self.camera.view_projection(w / h)
        write_uniform(prog, "u_view_proj", vp.T.reshape(1, 16))
        set_uniform(prog, "u_eye", tuple(float(x) for x in self.camera.eye()))
        set_uniform(prog, "u_light_dir", tuple(float(x) for x in self.light_dir))
        set_uniform(prog, "u_ambient", tuple(float(x) for x in p.ambient_scale * np.asarray(p.ambient_rgb)))
        set_uniform(prog, "u_flash", tuple(float(x) for x in p.flash_rgb))
        set_uniform(prog, "u_spec", float(p.specular))
        set_uniform(prog, "u_shininess", float(p.exponent))
        set_uniform(prog, "u_edge_nv", EDGE_NV)
        upload_layer_lobes(prog, km, self.spec_intensity)
        for name, unit in (("u_photo", 0), ("u_r_top", 1), ("u_transmittance", 2), ("u_r_bottom", 3),
                           ("u_spec0", 4), ("u_spec1", 5)):
            set_uniform(prog, name, unit)
        km.bind(1)
        km.bind_spec(4, 5)
        self._bind_lips(prog, lip_slots)
        ctx.enable(ctx.DEPTH_TEST)
        write_uniform(self._depth, "u_view_proj", vp.T.reshape(1, 16))
        # colour kept by blending (ZERO, ONE): a framebuffer's colour mask only applies while moderngl
        # thinks it is bound
        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.ZERO, ctx.ONE
        self._depth_vao.render()
        ctx.disable(ctx.BLEND)
        ctx.blend_func = ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA
        ctx.depth_func = "<="
        vao.render(vertices=3 * n_triangles)
        ctx.depth_func = "<"
        ctx.disable(ctx.DEPTH_TEST)

    def render_image(self) -> np.ndarray:
        """The frame at the photograph's size, uint8 sRGB (H, W, 3), top row first."""
        w, h = self.size
        if self._offscreen is None:
            color = self.ctx.renderbuffer((w, h), 4)
            depth = self.ctx.depth_renderbuffer((w, h))
            self._offscreen = (self.ctx.framebuffer(color_attachments=[color], depth_attachment=depth), color, depth)
        fbo = self._offscreen[0]
        self.render(fbo)
        return np.frombuffer(fbo.read(components=3), np.uint8).reshape(h, w, 3)[::-1].copy()

    def release(self) -> None:
        """Release every GPU object this view owns (the context current)."""
        from render.glutil import release_all

        progs = [o for pair in self._programs.values() for o in pair[::-1]]
        self._programs = {}
        release_all(self.ctx, (*(self._offscreen or ()), *progs, self._background_vao, self._background,
                               self._depth_vao, self._depth, *self._buffers, self._index, self._all_index,
                               self.photo, *((self._lip_texture,) if self._lip_texture is not None else ())))
        self._lip_texture = None
        if self._rest is not None:
            self._rest.release()
            self._rest = None
        self._offscreen = None
        self._buffers = []
        self._release_layers()


class RelightView(_Layers):
    """The captured face relit by the lightweight engine, turnable about the neck (module docstring).

    Args:
        ctx, head, face, shaders, km: as :class:`MirrorView`.
        shadow_size: the shadow map's side, texels.

    Attributes: ``yaw``, ``pitch`` (degrees from the photograph's view, within ``limits``, at most
    ±:data:`MAX_TURN_DEG`; positive yaw shows more of her left cheek, positive pitch looks from above),
    ``limits`` (the :class:`TurnLimits` her photograph supports, :func:`turn_limits`), ``lights`` (≤ 8
    :class:`Light`, photograph units: intensity 1 = the captured flash), ``ambient`` (linear RGB
    irradiance added to every light, photograph units; default the capture's k·A), ``exposure``,
    ``engine`` (the :class:`LightweightRenderer`), ``size`` (the photograph's, pixels), ``photo_camera``
    (the photograph's :class:`core.camera.Pinhole`), ``show_makeup``.
    """

    def __init__(self, ctx: moderngl.Context, head: Head, face: CapturedFace,
                 shaders: ShaderLibrary | None = None, km: KMTextureSpace | None = None,
                 shadow_size: int = 1024) -> None:
        from render.lightweight import LightweightRenderer

        self.photo_camera = face.camera()
        self.size = (self.photo_camera.width, self.photo_camera.height)
        self.ctx = ctx
        self.head = head
        self.face = face
        self.shaders = shaders or ShaderLibrary()
        self._init_layers(ctx, self.shaders, km)
        self.engine = LightweightRenderer(ctx, head, face, self.shaders, shadow_size=shadow_size)
        self.pivot = turn_pivot(head.vertices, head.metadata.landmarks, float(head.mm_per_unit))
        self.limits = turn_limits(head, self.photo_camera)
        self.yaw = 0.0
        self.pitch = 0.0
        self.exposure = 1.0
        self.lights: list[Light] = []
        self.ambient: tuple[float, float, float] | None = None
        self.use_capture_light()

    def use_capture_light(self) -> None:
        """Light her as the photograph did: the captured flash (intensity 1) and the captured ambient."""
        d = self.face.light_dir()
        self.lights = [Light("directional", tuple(float(x) for x in d),  # type: ignore[arg-type]
                             tuple(float(x) for x in self.face.params.flash_rgb), 1.0, True)]  # type: ignore[arg-type]
        self.ambient = None

    def set_preset(self, azimuth: float, elevation: float, colour: tuple[float, float, float], intensity: float,
                   ambient: tuple[float, float, float]) -> None:
        """Light her with a kiosk preset (``app.settings.LIGHT_PRESETS``: degrees, colour, intensity, ambient).

        The presets are in the physical renderer's display units; here they are scaled by one factor so
        that a surface facing the photograph's camera receives the same luminance irradiance as under the
        captured flash and ambient (the photograph's exposure), keeping the preset's direction, colours and
        key-to-ambient ratio.
        """
        lum = np.array([0.2126, 0.7152, 0.0722])
        to_cam = -self.photo_camera.R[2]  # the camera's forward axis (world coordinates) negated: towards it
        key = Light.directional(azimuth, elevation, intensity, tuple(float(c) for c in colour))  # type: ignore[arg-type]
        e_preset = intensity * max(float(np.dot(key.vector, to_cam)), 0.0) * float(lum @ np.asarray(colour)) \
            + float(lum @ np.asarray(ambient, dtype=float))
        p = self.face.params
        e_capture = max(float(np.dot(self.face.light_dir(), to_cam)), 0.0) * float(lum @ p.flash_rgb) \
            + float(lum @ (p.ambient_scale * np.asarray(p.ambient_rgb)))
        if e_preset <= 0:
            raise RenderError("a light preset must light the face (its key and ambient are both dark)")
        s = e_capture / e_preset
        self.lights = [Light.directional(azimuth, elevation, intensity * s,
                                         tuple(float(c) for c in colour))]  # type: ignore[arg-type]
        self.ambient = tuple(float(c) * s for c in ambient)  # type: ignore[assignment]

    def camera(self) -> OrbitCamera:
        """The photograph's camera orbited by :attr:`yaw`, :attr:`pitch` about the neck.

        Raises:
            RenderError: a turn beyond :attr:`limits` (at most ±:data:`MAX_TURN_DEG`) or not finite.
        """
        if not self.limits.allows(self.yaw, self.pitch):
            lim = self.limits
            raise RenderError(f"her photograph lets the relight view turn {lim.yaw[0]:+g}° to {lim.yaw[1]:+g}° of yaw "
                              f"and {lim.pitch[0]:+g}° to {lim.pitch[1]:+g}° of pitch, at most ±{MAX_TURN_DEG:g}° for "
                              f"any photograph (asked yaw {self.yaw!r}, pitch {self.pitch!r})")
        return pinhole_camera(self.photo_camera, self.head.vertices, self.yaw, self.pitch, self.pivot)

    def _prepare(self) -> None:
        lw = self.engine
        lw.camera = self.camera()
        lw.lights = list(self.lights)
        lw.ambient = self.ambient
        lw.exposure = self.exposure
        lw.makeup = self.km if self.has_makeup else None

    def render(self, fbo: moderngl.Framebuffer, viewport: tuple[int, int, int, int] | None = None) -> None:
        """Draw the frame into ``fbo`` (with a depth attachment), any size of the photograph's aspect."""
        self._prepare()
        self.engine.render(fbo, viewport)

    def render_image(self, size: tuple[int, int] | None = None) -> np.ndarray:
        """The frame, uint8 sRGB (H, W, 3) top row first, at ``size`` (width, height; default the photograph's)."""
        self._prepare()
        return self.engine.render_image(size or self.size)

    def release(self) -> None:
        """Release every GPU object this view owns (the context current)."""
        self.engine.release()
        self._release_layers()
