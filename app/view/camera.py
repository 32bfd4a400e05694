"""The viewport's camera and key light: interaction on top of ``render``'s own types.

No matrix or light maths of its own: :class:`render.camera.OrbitCamera` (on :mod:`core.camera`'s matrices)
and :class:`render.lights.Light` do that. :class:`ViewCamera` is the orbit camera's interactive side: the
viewport's gestures (orbit, pan, zoom, frame a box) and the studio's starting view.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from render.camera import OrbitCamera

if TYPE_CHECKING:
    from render.lights import Light


class ViewCamera(OrbitCamera):
    """The viewport's orbit camera, with its mouse interactions (orbit, pan, zoom, frame a box).

    Yaw and pitch in degrees (yaw 0 looks at the face along −Z), distance and target in mesh units.
    """

    def __init__(self) -> None:
        super().__init__(yaw=0.0, pitch=5.0, distance=9.0, fov_y=30.0, target=np.array([0.0, 1.5, 0.3]))

    def orbit(self, dyaw: float, dpitch: float) -> None:
        """Turn around the target by ``dyaw``/``dpitch`` degrees (pitch kept within ±85°)."""
        self.yaw = (self.yaw + dyaw + 180.0) % 360.0 - 180.0
        self.pitch = float(np.clip(self.pitch + dpitch, -85.0, 85.0))

    def pan(self, dx: float, dy: float) -> None:
        """Move the target in the view plane by fractions of the view height."""
        v = self.view()
        right, up = v[0, :3].astype(float), v[1, :3].astype(float)
        scale = 2.0 * self.distance * math.tan(math.radians(self.fov_y) / 2.0)
        self.target = np.asarray(self.target, float) - right * dx * scale + up * dy * scale

    def zoom(self, factor: float) -> None:
        """Scale the distance to the target (kept within 0.5–200 mesh units)."""
        self.distance = float(np.clip(self.distance * factor, 0.5, 200.0))

    def frame_box(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Frame the box ``lo``..``hi`` from the front."""
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        self.frame((lo + hi) / 2.0, float(np.linalg.norm(hi - lo)) / 2.0, margin=0.9)
        self.yaw, self.pitch = 0.0, 5.0


@dataclass
class Lighting:
    """The studio's key light, the ambient colour (light presets) and the exposure.

    Azimuth/elevation in degrees (azimuth 0 = from the camera side, +Z), linear RGB colour × intensity.
    """

    azimuth: float = 30.0
    elevation: float = 25.0
    colour: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 2.2
    ambient: tuple[float, float, float] = (0.35, 0.35, 0.38)
    exposure: float = 1.4

    def key_light(self, scale: float = 0.7) -> Light:
        """The key light as a ``render.Light`` (intensity × ``scale``)."""
        from render.lights import Light

        return Light.directional(float(self.azimuth), float(self.elevation), float(self.intensity) * scale,
                                 tuple(float(x) for x in self.colour))

    def direction(self) -> np.ndarray:
        """Unit vector toward the light, head space (``render.Light``'s convention), float32.

        float32 so that a project's light saved, reopened (angles recovered) and saved again stores the
        same vector.
        """
        from render.lights import Light

        return np.asarray(Light.direction_from_angles(float(self.azimuth), float(self.elevation)), np.float32)
