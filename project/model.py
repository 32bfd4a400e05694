"""What a ``.sheer`` file holds, in memory, and the format's constants (see ``docs/FORMAT.md``).

A :class:`Project` has its layers (:class:`ProjectLayer`) and a head reference (:class:`HeadRef`).

Plain data: nothing here reads or writes a file or knows the painting document (the bridge to a
``painting.Document`` is :mod:`project.document`; files are :mod:`project.io`).

Units: thickness maps float32 (N, N) in micrometres, texel row 0 on top; ``max_thickness_um`` in µm;
light and camera positions in head mesh units; angles in degrees.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from project.errors import ProjectError
from project.migrations import SCHEMA_VERSION

if TYPE_CHECKING:
    from pathlib import Path

    from km.material import Material

#: The first entry of every project (stored, uncompressed), as in OpenDocument/OpenRaster.
MIMETYPE = "application/x-sheer-project"
#: The entry holding the project's JSON description.
PROJECT_JSON = "project.json"
#: project.json may not be larger than this (bytes).
MAX_PROJECT_JSON_BYTES = 16 * 1024**2
#: Layer resolution of a new project (texels per side), as ``painting.Document``'s default.
DEFAULT_RESOLUTION = 2048
#: JSON nesting deeper than this is refused (a material is 4 levels deep).
MAX_JSON_DEPTH = 32
#: The encodings a layer map may use: EXR float32 (bit-exact) or 16-bit PNG (quantised).
ENCODINGS = ("exr-float32", "png16")
#: Entry-name prefix of an embedded head's files.
HEAD_PREFIX = "head/"


@dataclass
class HeadRef:
    """Which head a project paints on.

    Attributes:
        name: display name (from the head metadata).
        mesh_path: absolute path of the mesh file, or None when only embedded.
        asset: the mesh as a sample asset path (``heads/<name>/head.glb``), found through the asset
            search path on any machine, or None.
        mesh: key of the mesh in ``files``.
        files: SHA-256 (hex) of each head file, keyed by its path relative to the mesh's folder (the
            metadata sidecar as ``<mesh>.sheer-head.json`` wherever it was found).
        data: the files' bytes when the head is embedded in the project (same keys), else None.
    """

    name: str
    mesh_path: Path | None
    asset: str | None
    mesh: str
    files: dict[str, str]
    data: dict[str, bytes] | None = None

    @property
    def embedded(self) -> bool:
        """True when the head's files travel inside the project (``data`` holds them)."""
        return self.data is not None


@dataclass
class ProjectLayer:
    """One cosmetic layer: material name, thickness map float32 (N, N) in µm, display settings.

    Attributes:
        name: display name.
        material: the name of a material embedded in the project.
        thickness: float32 (N, N) µm, texel row 0 on top; N is the layer's resolution.
        visible: shown when rendering.
        opacity: [0, 1], scales the thickness when rendering.
        max_thickness_um: (0, 10000] µm, what the brush builds up to.
        encoding: how the map is stored, one of :data:`ENCODINGS`.
        mask: the layer mask's recipe as JSON (``regions`` [[op, name]…], ``invert``, ``feather_mm``;
            see ``painting.mask.LayerMask``), or None.
        mask_channel: the mask's paint channel, float32 (N, N) in [0, 2] (neutral 1), or None.
    """

    name: str
    material: str
    thickness: np.ndarray
    visible: bool = True
    opacity: float = 1.0
    max_thickness_um: float = 100.0
    encoding: str = "exr-float32"
    mask: dict[str, Any] | None = None
    mask_channel: np.ndarray | None = None

    @property
    def resolution(self) -> int:
        """Texels per side of the map."""
        return int(self.thickness.shape[0])

    def same_as(self, other: ProjectLayer) -> bool:
        """Equal settings and bit-identical maps."""
        return (self.name, self.material, self.visible, self.opacity, self.max_thickness_um, self.encoding) == (
            other.name, other.material, other.visible, other.opacity, other.max_thickness_um, other.encoding
        ) and self.thickness.dtype == other.thickness.dtype and np.array_equal(
            self.thickness.view(np.uint32), other.thickness.view(np.uint32)) and self.mask == other.mask and (
            (self.mask_channel is None) == (other.mask_channel is None)) and (
            self.mask_channel is None or other.mask_channel is None or np.array_equal(
                np.asarray(self.mask_channel, np.float32).view(np.uint32),
                np.asarray(other.mask_channel, np.float32).view(np.uint32)))


@dataclass
class Project:
    """Everything a ``.sheer`` file holds (see ``docs/FORMAT.md``).

    Attributes:
        name: display name.
        head: the head reference (and its bytes when embedded).
        resolution: the document's default layer resolution (texels per side, a multiple of 64 in
            64..8192); each layer has its own (``layer.resolution``), its map is that size square.
        layers: bottom layer first.
        materials: embedded material JSON (``km.Material.to_json()``) by name; see :meth:`material`.
        lights: plain JSON dicts (``type``, ``color``, ``intensity``, ``direction`` / ``position`` /
            ``environment`` / ``rotation_deg``), validated on load; the project never imports render.
        camera: a JSON dict (``position``, ``target``, ``up`` in mesh units, ``fov_deg``, ``near``,
            ``far``) or None.
        look: look metadata (``name``, optional ``description``, ``tags``) or None.
        created_by: the Sheer that wrote it.
        source_path: the file it was opened from, if any.
        source_schema_version: the version the file had (older ones are migrated on open).
        recovery: the ``recovery`` block of an autosave file, else None.
        layout: the paint layout the maps were painted on (``source``: "mesh" or "xatlas",
            ``sha256`` of its UVs and triangles; see :mod:`project.document`), or None when
            not known yet (a new project).
    """

    name: str
    head: HeadRef
    resolution: int = DEFAULT_RESOLUTION
    layers: list[ProjectLayer] = field(default_factory=list)
    materials: dict[str, dict[str, Any]] = field(default_factory=dict)
    lights: list[dict[str, Any]] = field(default_factory=list)
    camera: dict[str, Any] | None = None
    look: dict[str, Any] | None = None
    created_by: str = ""
    source_path: Path | None = None
    source_schema_version: int = SCHEMA_VERSION
    recovery: dict[str, Any] | None = None
    layout: dict[str, str] | None = None

    def material(self, name: str) -> Material:
        """The embedded material ``name`` as a ``km.Material`` (:class:`ProjectError` if absent)."""
        import km

        if name not in self.materials:
            raise ProjectError(f"project '{self.name}': no material named {name!r}")
        return km.Material.from_json(self.materials[name], where=f"materials[{name!r}]")

    def same_as(self, other: Project) -> bool:
        """Equal content (maps bit-exact), ignoring where each was loaded from."""
        return (
            self.name == other.name and self.resolution == other.resolution
            and self.head.files == other.head.files and self.head.mesh == other.head.mesh
            and self.head.asset == other.head.asset and self.head.embedded == other.head.embedded
            and (self.head.data or {}) == (other.head.data or {})
            and len(self.layers) == len(other.layers)
            and all(a.same_as(b) for a, b in zip(self.layers, other.layers))
            and self.materials == other.materials and self.lights == other.lights
            and self.camera == other.camera and self.look == other.look and self.layout == other.layout
        )
