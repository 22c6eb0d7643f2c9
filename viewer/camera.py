"""View state of the viewer: the 2D pan/zoom window and the orbit camera. Pure NumPy, no GL."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["PanZoom", "Orbit", "perspective", "look_at"]

#: a float64 array: a 4x4 matrix (column vectors) or a 3-vector
Float64Array = npt.NDArray[np.float64]


@dataclass
class PanZoom:
    """Pixel <-> texture-coordinate mapping of the 2D view.

    View pixels are counted from the view's top-left corner, y down, like image rows: texture
    v = 0 is the top row of a bake. ``origin`` is where texture coordinate (0, 0) lies; one
    texture unit spans ``zoom * base`` pixels, ``base`` being the shorter side of the view. At
    zoom 1 with an integer origin, the unit square [0, 1]^2 covers exactly ``base x base``
    pixels and matches a ``base x base`` bake pixel for pixel.
    """

    origin: tuple[float, float] = (0.0, 0.0)
    zoom: float = 1.0
    fitted: bool = False

    def fit(self, w: int, h: int) -> None:
        """Centre the unit square in a ``w x h`` view at zoom 1 (integer origin)."""
        base = min(w, h)
        self.origin = (float((w - base) // 2), float((h - base) // 2))
        self.zoom = 1.0
        self.fitted = True

    def unit(self, w: int, h: int) -> float:
        """Pixels per texture unit."""
        return self.zoom * min(w, h)

    def window(self, w: int, h: int) -> tuple[tuple[float, float], tuple[float, float]]:
        """(uv at the view's top-left corner, uv extent) of a ``w x h`` view."""
        u = self.unit(w, h)
        return (-self.origin[0] / u, -self.origin[1] / u), (w / u, h / u)

    def to_uv(self, x: float, y: float, w: int, h: int) -> tuple[float, float]:
        """Texture coordinate at view position (x, y) (top-left origin, y down, pixels)."""
        u = self.unit(w, h)
        return (x - self.origin[0]) / u, (y - self.origin[1]) / u

    def pan(self, dx: float, dy: float) -> None:
        self.origin = (self.origin[0] + dx, self.origin[1] + dy)

    def zoom_at(self, factor: float, x: float, y: float) -> None:
        """Zoom by ``factor`` keeping the texture point under view position (x, y) fixed."""
        factor = max(1e-3 / self.zoom, min(factor, 1e4 / self.zoom))
        ox, oy = self.origin
        self.origin = (x - (x - ox) * factor, y - (y - oy) * factor)
        self.zoom *= factor


def perspective(fovy_deg: float, aspect: float, near: float, far: float) -> Float64Array:
    f = 1.0 / math.tan(math.radians(fovy_deg) / 2.0)
    m = np.zeros((4, 4))
    m[0, 0] = f / aspect
    m[1, 1] = f
    m[2, 2] = (far + near) / (near - far)
    m[2, 3] = 2.0 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def look_at(eye: npt.ArrayLike, target: npt.ArrayLike, up: npt.ArrayLike = (0.0, 1.0, 0.0)) -> Float64Array:
    eye, target, up = (np.asarray(v, float) for v in (eye, target, up))
    f = target - eye
    f /= np.linalg.norm(f)
    s = np.cross(f, up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m


@dataclass
class Orbit:
    """Orbit camera around the origin: yaw/pitch in degrees, distance in object units."""

    yaw: float = 30.0
    pitch: float = 20.0
    distance: float = 3.6
    fovy: float = 40.0

    def eye(self) -> Float64Array:
        y, p = math.radians(self.yaw), math.radians(self.pitch)
        return self.distance * np.array([math.cos(p) * math.sin(y), math.sin(p), math.cos(p) * math.cos(y)])

    def rotate(self, dx: float, dy: float) -> None:
        """Drag by (dx, dy) pixels (y up)."""
        self.yaw = (self.yaw - 0.4 * dx) % 360.0
        self.pitch = max(-89.0, min(89.0, self.pitch - 0.4 * dy))

    def dolly(self, wheel: float) -> None:
        self.distance = max(1.3, min(20.0, self.distance * (0.9 ** wheel)))

    def matrices(self, aspect: float) -> tuple[Float64Array, Float64Array]:
        """(view, projection), float64 4x4, column vectors."""
        fovy = self.fovy
        if aspect < 1.0:  # narrow view: keep the horizontal field of view
            fovy = math.degrees(2.0 * math.atan(math.tan(math.radians(fovy) / 2.0) / aspect))
        return look_at(self.eye(), (0.0, 0.0, 0.0)), perspective(fovy, aspect, 0.05, 100.0)
