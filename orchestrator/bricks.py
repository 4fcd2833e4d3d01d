"""Bricks as clumps of spheres: layout, true mass and inertia, and how far the clump is from the box.

A brick is a box of length × width × thickness along its body axes x, y, z. A clump of n_x × n_y × n_z
equal spheres fills it: the radius is thickness / (2 n_z), so the spheres touch the two large faces,
and on every axis the centres are evenly spread from -(d/2 - r) to +(d/2 - r), so the spheres touch
the end faces too (neighbours overlap where the spacing is below 2 r). The clump
gets the mass and principal inertia of the true (full) box, never of the union of spheres, so the
dynamics of a brick do not depend on the resolution; only its surface does, and `surface_deviation`
reports by how much.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np


@dataclass(frozen=True)
class BrickClump:
    length: float
    width: float
    thickness: float
    density: float
    layout: tuple[int, int, int]  # spheres along x (length), y (width), z (thickness)

    @cached_property
    def radius(self) -> float:
        """Sphere radius: the thickness direction sets it (half the thickness over its sphere count)."""
        return self.thickness / (2.0 * self.layout[2])

    @cached_property
    def centres(self) -> np.ndarray:
        """(n, 3) sphere centres in the body frame, centred on the brick's centre."""
        axes = []
        for extent, count in zip((self.length, self.width, self.thickness), self.layout):
            reach = extent / 2.0 - self.radius
            axes.append(np.linspace(-reach, reach, count) if count > 1 else np.zeros(1))
        grid = np.meshgrid(*axes, indexing="ij")
        return np.stack([g.ravel() for g in grid], axis=1)

    @property
    def n_spheres(self) -> int:
        return int(np.prod(self.layout))

    @property
    def volume(self) -> float:
        return self.length * self.width * self.thickness

    @property
    def mass(self) -> float:
        return self.density * self.volume

    @property
    def principal_inertia(self) -> np.ndarray:
        """(I_x, I_y, I_z) of the full box about its centre: m/12 (b² + c²) etc."""
        a, b, c = self.length, self.width, self.thickness
        return self.mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])

    @property
    def bounding_radius(self) -> float:
        return float(np.max(np.linalg.norm(self.centres, axis=1)) + self.radius)

    def surface_deviation(self, samples_per_edge: int = 40) -> tuple[float, float]:
        """(max, mean) distance from points on the box surface to the surface of the sphere union.

        Points are a regular grid on all six faces; the distance is |signed distance to the union|,
        the union's signed distance being min_i(|p - c_i| - r).
        """
        points = box_surface_points(self.length, self.width, self.thickness, samples_per_edge)
        gaps = np.linalg.norm(points[:, None, :] - self.centres[None, :, :], axis=2) - self.radius
        distance = np.abs(gaps.min(axis=1))
        return float(distance.max()), float(distance.mean())


def box_surface_points(length: float, width: float, thickness: float, n: int) -> np.ndarray:
    """A regular grid of n × n points on each of the six faces of a centred box."""
    half = np.array([length, width, thickness]) / 2.0
    grid = np.linspace(-1.0, 1.0, n)
    u, v = np.meshgrid(grid, grid, indexing="ij")
    u, v = u.ravel(), v.ravel()
    faces = []
    for axis in range(3):
        others = [k for k in range(3) if k != axis]
        for sign in (-1.0, 1.0):
            face = np.empty((u.size, 3))
            face[:, axis] = sign * half[axis]
            face[:, others[0]] = u * half[others[0]]
            face[:, others[1]] = v * half[others[1]]
            faces.append(face)
    return np.concatenate(faces)


def quaternion_matrix(q: np.ndarray | tuple[float, float, float, float]) -> np.ndarray:
    """Rotation matrix of a quaternion (w, x, y, z); normalised first."""
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def world_sphere_centres(clump: BrickClump, position: np.ndarray, orientation: np.ndarray) -> np.ndarray:
    """(n, 3) sphere centres of one brick placed at `position` with quaternion `orientation` (w, x, y, z)."""
    return np.asarray(position, dtype=float) + clump.centres @ quaternion_matrix(orientation).T
