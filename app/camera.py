"""Orbit camera maths (numpy only): yaw/pitch/distance around a target, perspective projection."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


def perspective(fov_y_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    """A right-handed OpenGL projection matrix (float32, row-major maths, column vectors)."""
    f = 1.0 / math.tan(math.radians(fov_y_deg) / 2.0)
    m = np.zeros((4, 4), dtype=np.float32)
    m[0, 0] = f / max(aspect, 1e-6)
    m[1, 1] = f
    m[2, 2] = (far + near) / (near - far)
    m[2, 3] = 2.0 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """A view matrix looking from ``eye`` at ``target``."""
    f = target - eye
    f = f / np.linalg.norm(f)
    s = np.cross(f, up)
    s = s / max(float(np.linalg.norm(s)), 1e-9)
    u = np.cross(s, f)
    m = np.eye(4, dtype=np.float32)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[0, 3], m[1, 3], m[2, 3] = -s @ eye, -u @ eye, f @ eye
    return m


@dataclass
class OrbitCamera:
    """Yaw and pitch in degrees (yaw 0 looks at the face along -Z), distance and target in mesh units."""

    yaw: float = 0.0
    pitch: float = 5.0
    distance: float = 9.0
    target: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.5, 0.3]))
    fov_y: float = 30.0
    home: tuple[float, float, float, tuple[float, float, float]] | None = None

    def eye(self) -> np.ndarray:
        yaw, pitch = math.radians(self.yaw), math.radians(self.pitch)
        d = np.array([math.sin(yaw) * math.cos(pitch), math.sin(pitch), math.cos(yaw) * math.cos(pitch)])
        return self.target + self.distance * d

    def view(self) -> np.ndarray:
        return look_at(self.eye(), self.target, np.array([0.0, 1.0, 0.0]))

    def projection(self, aspect: float) -> np.ndarray:
        return perspective(self.fov_y, aspect, max(self.distance * 0.05, 0.01), self.distance * 10.0)

    def orbit(self, dyaw: float, dpitch: float) -> None:
        self.yaw = (self.yaw + dyaw + 180.0) % 360.0 - 180.0
        self.pitch = float(np.clip(self.pitch + dpitch, -85.0, 85.0))

    def pan(self, dx: float, dy: float) -> None:
        """Move the target in the view plane by fractions of the view height."""
        v = self.view()
        right, up = v[0, :3].astype(float), v[1, :3].astype(float)
        scale = 2.0 * self.distance * math.tan(math.radians(self.fov_y) / 2.0)
        self.target = self.target - right * dx * scale + up * dy * scale

    def zoom(self, factor: float) -> None:
        self.distance = float(np.clip(self.distance * factor, 0.5, 200.0))

    def frame(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Frame the box ``lo``..``hi`` from the front."""
        centre = (np.asarray(lo, float) + np.asarray(hi, float)) / 2.0
        radius = float(np.linalg.norm(np.asarray(hi, float) - np.asarray(lo, float))) / 2.0
        self.target = centre
        self.distance = radius / math.sin(math.radians(self.fov_y) / 2.0) * 0.9
        self.yaw, self.pitch = 0.0, 5.0

    def ray(self, x: float, y: float, aspect: float) -> tuple[np.ndarray, np.ndarray]:
        """The world ray through normalised device coordinates (x, y) in [-1, 1]."""
        inv = np.linalg.inv(self.projection(aspect) @ self.view())
        p0 = inv @ np.array([x, y, -1.0, 1.0])
        p1 = inv @ np.array([x, y, 1.0, 1.0])
        a, b = p0[:3] / p0[3], p1[:3] / p1[3]
        d = b - a
        return a, d / np.linalg.norm(d)
