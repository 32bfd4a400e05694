"""The studio's and the kiosk's use of :mod:`project`, the ``.sheer`` format (docs/FORMAT.md).

Open, save, autosave snapshots and crash recovery, with no Qt (the dialogs are :mod:`app.studio.project_files`).

- Saving: :func:`snapshot` is ``project_from_document(doc, base=…)`` (the project last opened or saved, so
  its head reference and metadata are kept) plus the studio's view state (key light, ambient,
  environment, camera, look) as the project's plain JSON ``lights`` / ``camera`` / ``look`` fields.
- Opening: :func:`read_document` is ``open_project(…)`` + ``document_from_project(…)`` (maps bit-exact, the
  head's paint layout checked); :func:`install_layers` then moves the layers into the studio's document
  (which must be on the same head and at the same resolution: nothing is resampled).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable

    from app.view.camera import Lighting, ViewCamera
    from km.library import Library
    from painting import Document
    from painting.atlas import Atlas
    from project.model import Project
    from project.recovery import Autosaver, RecoveryInfo


# ---------------------------------------------------------------------------------------------- view state


@dataclass
class ViewState:
    """The studio's view as the project stores it (see FORMAT.md ``lights``, ``camera``, ``look``)."""

    lights: list[dict[str, Any]]
    camera: dict[str, Any] | None
    look: dict[str, Any] | None


def _vec(v: Any) -> list[float]:
    return [float(x) for x in np.asarray(v, dtype=float).reshape(3)]


def view_state(camera: ViewCamera, lighting: Lighting, environment: str,
               look: dict[str, Any] | None) -> ViewState:
    """The studio's view as a project stores it.

    The lights are the directional key light, the ambient light and the HDR environment (when
    ``environment`` is not "none"); the camera is a position, a target and a vertical field of view
    (degrees), with near/far planes at 5 % and 10× its distance (mesh units).
    """
    toward_light = np.asarray(lighting.direction(), dtype=float)
    lights: list[dict[str, Any]] = [
        {"type": "directional", "color": _vec(lighting.colour), "intensity": float(lighting.intensity),
         "direction": _vec(-toward_light)},
        {"type": "ambient", "color": _vec(lighting.ambient), "intensity": 1.0},
    ]
    if environment and environment != "none":
        lights.append({"type": "environment", "color": [1.0, 1.0, 1.0], "intensity": 1.0,
                       "environment": f"environments/{environment}.exr", "rotation_deg": 0.0})
    distance = float(camera.distance)
    cam = {"position": _vec(camera.eye()), "target": _vec(camera.target), "up": [0.0, 1.0, 0.0],
           "fov_deg": float(camera.fov_y), "near": max(distance * 0.05, 0.01), "far": distance * 10.0}
    return ViewState(lights, cam, look)


def key_light_angles(lights: list[dict[str, Any]]) -> tuple[float, float] | None:
    """(azimuth, elevation) in degrees of the first directional light (the studio's key light)."""
    for light in lights:
        if light.get("type") == "directional":
            d = -np.asarray(light["direction"], dtype=float)
            n = float(np.linalg.norm(d))
            if n <= 0.0:
                return None
            d /= n
            return math.degrees(math.atan2(d[0], d[2])), math.degrees(math.asin(float(np.clip(d[1], -1, 1))))
    return None


def environment_name(lights: list[dict[str, Any]]) -> str:
    """The studio's environment name for the project's environment light (``"none"`` without one)."""
    for light in lights:
        if light.get("type") == "environment":
            return Path(str(light.get("environment", ""))).stem or "none"
    return "none"


def closest_preset(lights: list[dict[str, Any]], presets: dict[str, dict[str, Any]]) -> str | None:
    """The light preset whose colour and intensity are nearest the project's key light."""
    key = next((lg for lg in lights if lg.get("type") == "directional"), None)
    if key is None or not presets:
        return None
    want = np.asarray(key["color"], dtype=float) * float(key["intensity"])
    return min(presets, key=lambda n: float(np.linalg.norm(
        np.asarray(presets[n]["colour"], dtype=float) * float(presets[n]["intensity"]) - want)))


def restore_camera(camera: ViewCamera, record: dict[str, Any] | None) -> None:
    """Set the studio's camera (a ``ViewCamera``) from the project's camera (its ``up`` is always +Y here)."""
    if not record:
        return
    target = np.asarray(record["target"], dtype=float)
    offset = np.asarray(record["position"], dtype=float) - target
    distance = float(np.linalg.norm(offset))
    if distance <= 0.0:
        return
    camera.target = target
    camera.distance = distance
    camera.yaw = math.degrees(math.atan2(offset[0], offset[2]))
    camera.pitch = float(np.clip(math.degrees(math.asin(float(np.clip(offset[1] / distance, -1, 1)))), -85, 85))
    camera.fov_y = float(record["fov_deg"])


# ---------------------------------------------------------------------------------------------- save


def snapshot(doc: Document, name: str, base: Project | None = None, view: ViewState | None = None) -> Project:
    """A ``project.model.Project`` of the document now (maps copied).

    :func:`project.document.project_from_document` with ``base`` (the project last opened or saved)
    and the view state, when given.
    """
    from project.document import project_from_document

    kwargs: dict[str, Any] = {"name": name, "base": base}
    if view is not None:
        kwargs.update(lights=view.lights, camera=view.camera, look=view.look)
    return project_from_document(doc, **kwargs)


def save_document(doc: Document, path: Path, name: str, base: Project | None = None,
                  view: ViewState | None = None, self_contained: bool | None = None) -> Path:
    """Save the document as a ``.sheer`` project (atomic, with ``.bak``; removes its recovery file)."""
    return save_project_file(snapshot(doc, name, base, view), path, self_contained)


def save_project_file(project: Project, path: Path, self_contained: bool | None = None) -> Path:
    """``save_project``; ``self_contained=True`` embeds the head, None keeps it as the project had it."""
    from project.io import save_project

    return save_project(project, path, self_contained=self_contained)


# ---------------------------------------------------------------------------------------------- open


def read_document(path: Path, head_path: Path | None = None,
                  accept_head_change: bool = False) -> tuple[Project, Document]:
    """``open_project`` + ``document_from_project``: (project, painting.Document). Safe in a worker.

    Raises ``HeadMissingError`` / ``HeadChecksumError`` (offer to relink) and other ``ProjectError``s.
    """
    from project.document import document_from_project
    from project.io import open_project

    project = open_project(path, head_path=head_path, accept_head_change=accept_head_change)
    return project, document_from_project(project)


def other_resolution(opened: Document, doc: Document) -> int | None:
    """The resolution of the opened project's maps when it differs from the studio document's, else None."""
    want = int(doc.resolution)
    for lay in opened.layers:
        if int(lay.thickness.shape[0]) != want:
            return int(lay.thickness.shape[0])
    return None


def resample_map(values: np.ndarray, src_atlas: Atlas, dst_atlas: Atlas) -> np.ndarray:
    """A thickness map (µm) from one paint resolution to another of the same UV layout.

    Uses painting's bakes at both resolutions (``Document.atlas_at``): the source is averaged (down) or
    interpolated (up) only over its baked texels (covered or padding; weights renormalised, so nothing
    bleeds in from outside the charts), then the target keeps its covered texels and refills its padding
    texels from their sources (``Atlas.pad_dst``/``pad_src``), as painting does after a dab.
    """
    from PIL import Image

    src = np.asarray(values, np.float32)
    n = int(dst_atlas.resolution)
    weight = (src_atlas.coverage | src_atlas.padded).astype(np.float32)
    method = Image.Resampling.BOX if n < src.shape[0] else Image.Resampling.BILINEAR

    def resize(a: np.ndarray) -> np.ndarray:
        return np.asarray(Image.fromarray(np.ascontiguousarray(a, np.float32), mode="F").resize((n, n), method))

    num, den = resize(src * weight), resize(weight)
    out = np.where(den > 1e-6, num / np.maximum(den, 1e-6), 0.0).astype(np.float32)
    out[~dst_atlas.coverage] = 0.0
    flat = out.reshape(-1)
    flat[dst_atlas.pad_dst] = flat[dst_atlas.pad_src]
    return np.clip(out, 0.0, None)


def resample_layers(doc: Document, opened: Document,
                    progress: Callable[[float, str], None] | None = None) -> list[np.ndarray]:
    """Every opened layer's map at the studio document's resolution (see :func:`resample_map`).

    ``progress`` gets (fraction in [0, 1], the layer being resampled).
    """
    dst = doc.atlas_at(int(doc.resolution))
    out = []
    for i, lay in enumerate(opened.layers):
        if progress is not None:
            progress(i / max(len(opened.layers), 1), f"resampling {lay.name}")
        src = np.asarray(lay.thickness, np.float32)
        out.append(src.copy() if src.shape == dst.shape else resample_map(src, doc.atlas_at(src.shape[0]), dst))
    return out


def check_compatible(project: Project, opened: Document, doc: Document, resample: bool = False) -> None:
    """Refuse a project whose maps would not line up with the studio's document.

    Raises:
        ProjectError: the project was painted on another head (another paint layout), or at another
            resolution and ``resample`` is False (see :func:`resample_layers`).
    """
    from project.document import layout_record
    from project.errors import ProjectError

    if layout_record(doc.layout) != layout_record(opened.layout):
        raise ProjectError(f"the project '{project.name}' was painted on another head ({project.head.name}); "
                           f"start Sheer with that head (sheer --head MESH --project FILE) to open it")
    want = int(doc.resolution)
    for lay in opened.layers:
        if int(lay.thickness.shape[0]) != want and not resample:
            raise ProjectError(f"the project '{project.name}' has {lay.thickness.shape[0]}-texel maps and this "
                               f"studio paints at {want}: start Sheer with --resolution "
                               f"{lay.thickness.shape[0]} to open it")


def install_layers(doc: Document, library: Library, project: Project, opened: Document,
                   maps: list[np.ndarray] | None = None) -> None:
    """Replace the studio document's layers with the opened document's, and clear the undo history.

    The maps are copied bit-exactly, or taken from ``maps`` (e.g. :func:`resample_layers`'s). The layers
    wear the project's embedded materials, as saved: one the library lacks is added to it, and one the
    library holds otherwise (edited since, or in another studio) replaces the library's of that name (the
    library file is unchanged until the library is saved). Call :func:`check_compatible` first.
    """
    for name in project.materials:
        saved = project.material(name)
        if name not in library:
            library.add(saved)
        elif library.get(name).to_json() != saved.to_json():
            library.add(saved, replace=True)
    for i in reversed(range(len(doc.layers))):
        doc.remove_layer(i)
    for i, lay in enumerate(opened.layers):
        new = doc.add_layer(lay.material, name=lay.name, max_thickness=float(lay.max_thickness))
        values = lay.thickness if maps is None else maps[i]
        if np.any(values):
            doc.set_thickness(new, np.array(values, dtype=np.float32, copy=True))
        doc.set_layer(i, visible=bool(lay.visible), opacity=float(lay.opacity))
    doc.clear_history()


def load_project_into(doc: Document, library: Library, source: Path | Project, resample: bool = False) -> str:
    """Replace the document's layers with a project's (a path, or a ``Project`` already opened).

    Maps at another resolution are refused, or with ``resample`` resampled (:func:`resample_layers`).

    Returns:
        The project's name.

    Raises:
        ProjectError: a bad file, or maps that do not fit; the document is unchanged then.
    """
    from project.document import document_from_project
    from project.io import open_project

    project = open_project(source) if isinstance(source, str | Path) else source
    opened = document_from_project(project)
    check_compatible(project, opened, doc, resample=resample)
    maps = resample_layers(doc, opened) if resample and other_resolution(opened, doc) is not None else None
    install_layers(doc, library, project, opened, maps)
    return str(project.name)


# ---------------------------------------------------------------------------------------------- autosave


def sweep_temporaries(path: Path) -> int:
    """Remove the temporary files a killed save of ``path`` left beside it over an hour ago; how many."""
    from project.io import STALE_TEMP_S
    from project.recovery_files import remove_stale_temporaries

    return remove_stale_temporaries(path, STALE_TEMP_S)


def make_autosaver(snap: Callable[[], Project], project_path: Path | None, interval_s: float) -> Autosaver:
    """A ``project.recovery.Autosaver`` of the projects ``snap()`` returns, every ``interval_s`` seconds."""
    from project.recovery import Autosaver

    return Autosaver(snap, project_path, interval_s=interval_s)


def pending_recoveries() -> list[RecoveryInfo]:
    """Recovery files left by sessions that did not end normally (not another running studio's)."""
    from project.recovery import list_recoveries

    return [r for r in list_recoveries() if not r.owner_alive and r.error is None]
