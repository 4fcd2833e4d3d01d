"""Rigid-body helpers every kind of brick uses: the mass moments of its solid (a rounded box in
closed form, a convex polyhedron by tetrahedra) and rotations from quaternions (w, x, y, z)."""

from __future__ import annotations

import math

import numpy as np


def rounded_box_moments(sides: np.ndarray, rounding: float) -> tuple[float, np.ndarray, np.ndarray]:
    """(volume m³, centroid, covariance diag(∫x², ∫y², ∫z²) m⁵) of a box of `sides` (3,) whose edges
    and corners are rounded at `rounding` (the inner box swept by a sphere of that radius).

    Sum of the inner box, six face slabs, twelve quarter cylinders and eight sphere octants. Per
    unit length, a quarter disc of radius r at offset d has ∫ (d + u)² dA = d² πr²/4 + 2 d r³/3 +
    πr⁴/16; an octant at offset d, ∫ (d + u)² dV = d² πr³/6 + 2 d πr⁴/16 + πr⁵/30. The 2012 study's
    brick (31 × 15 × 8 mm, r = 1 mm): V = 3.6749852e-6 m³, I/m = (2.36912e-5, 8.45563e-5, 9.77668e-5) m².
    """
    r = float(rounding)
    inner = np.asarray(sides, dtype=float) - 2.0 * r
    half = inner / 2.0
    disc = (math.pi * r**2 / 4.0, r**3 / 3.0, math.pi * r**4 / 16.0)  # area, ∫u, ∫u² of a quarter disc
    ball = (math.pi * r**3 / 6.0, math.pi * r**4 / 16.0, math.pi * r**5 / 30.0)  # volume, ∫u, ∫u² of an octant
    volume, second = float(np.prod(inner)), np.prod(inner) * inner**2 / 12.0
    for k in range(3):  # k: the axis of the face slabs' normal, and of the edges' length
        i, j = [m for m in range(3) if m != k]
        slab = 2.0 * r * inner[i] * inner[j]
        volume += slab + 4.0 * disc[0] * inner[k]
        second[k] += 2.0 * inner[i] * inner[j] * ((half[k] + r) ** 3 - half[k] ** 3) / 3.0 + 4.0 * disc[0] * inner[k] ** 3 / 12.0
        for m in (i, j):
            second[m] += slab * inner[m] ** 2 / 12.0  # the slab normal to k spans the box along m
            second[m] += 4.0 * inner[k] * (half[m] ** 2 * disc[0] + 2.0 * half[m] * disc[1] + disc[2])  # edges along k, at ± half[m]
    volume += 8.0 * ball[0]
    second += 8.0 * (half**2 * ball[0] + 2.0 * half * ball[1] + ball[2])
    return float(volume), np.zeros(3), np.diag(second)


def solid_moments(points: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(volume, centroid, covariance about the centroid) of the convex hull of `points`.

    The hull is cut into tetrahedra (apex at the mean point, base a hull triangle); a tetrahedron
    with vertices v_0..v_3 and volume V has ∫ p pᵀ dV = V / 20 (Σ v_i v_iᵀ + s sᵀ), s = Σ v_i.
    """
    from scipy.spatial import ConvexHull

    points = np.asarray(points, dtype=float)
    apex = points.mean(axis=0)
    triangles = points[ConvexHull(points).simplices]  # (m, 3, 3)
    tetrahedra = np.concatenate([np.broadcast_to(apex, (len(triangles), 1, 3)), triangles], axis=1)  # (m, 4, 3)
    volumes = np.abs(np.linalg.det(triangles - apex)) / 6.0
    total = float(volumes.sum())
    centroid = np.einsum("m,mj->j", volumes, tetrahedra.mean(axis=1)) / total
    sums = tetrahedra.sum(axis=1)
    second = np.einsum("m,mij->ij", volumes / 20.0, np.einsum("mki,mkj->mij", tetrahedra, tetrahedra) + np.einsum("mi,mj->mij", sums, sums))
    return total, centroid, second - total * np.outer(centroid, centroid)


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


def quaternion_matrices(quaternions: np.ndarray) -> np.ndarray:
    """(B, 3, 3) rotation matrices of (B, 4) quaternions (w, x, y, z)."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(np.roll(np.asarray(quaternions, dtype=float), -1, axis=1)).as_matrix()


def inertia_tensor(covariance: np.ndarray, mass: float, volume: float,
                   given: tuple[float, float, float] | None = None) -> np.ndarray:
    """(3, 3) inertia (kg m²) about the centre of mass of a solid of `volume` (m³) and `mass` (kg)
    spread evenly, from its covariance C = ∫ (p − c)(p − c)ᵀ dV (m⁵): (m / V)(tr(C) 1 − C); or
    diag(`given`) when given. A given mass scales the inertia with it (the density is m / V)."""
    if given is not None:
        return np.diag(np.asarray(given, dtype=float))
    covariance = np.asarray(covariance, dtype=float)
    return mass / volume * (np.trace(covariance) * np.eye(3) - covariance)
