"""The brick as one superquadric body: flat faces, rounded edges, one contact per touching face.

A superquadric of half-axes (a, b, c) and blockiness (n1, n2) is the set

    (|x/a|^n2 + |y/b|^n2)^(n1/n2) + |z/c|^n1 <= 1        (Barr 1981; LIGGGHTS' `atom_style superquadric`)

n = 2 is an ellipsoid; as n grows the body tends to the box 2a × 2b × 2c, its edges rounded over a
width of about a (1 − 2^(−1/n)) along each face. Its faces are flat to within that: where a clump's
face is a row of spheres that a neighbour's corner sinks between, a superquadric's face is smooth,
so two bricks slide on each other at the friction angle (tests/test_brick_pair.py).

The body gets the true brick's mass and inertia (the study's brick: 31 × 15 × 8 mm with 1 mm rounded
edges, shapes/rigid.py `rounded_box_moments`), never those of the superquadric's own volume, so a
brick's dynamics do not depend on its blockiness; only its surface does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np
from scipy.special import beta

from orchestrator.shapes.solid import OneBodyBrick


@dataclass(frozen=True)
class BrickSuperquadric(OneBodyBrick):
    length: float
    width: float
    thickness: float
    density: float
    blockiness: tuple[float, float]  # (n1, n2): n1 along the thickness (z), n2 in the x-y plane
    mass_given: float | None = None
    inertia_given: tuple[float, float, float] | None = None
    rounding: float = 0.0  # the true brick's edge rounding (m): its mass and inertia, not the surface's

    kind = "superquadric"

    @property
    def superquadric_volume(self) -> float:
        """The superquadric's own volume (m³): 2 a b c ε1 ε2 B(ε1/2 + 1, ε1) B(ε2/2, ε2/2), ε = 2/n
        (Jaklič, Leonardis & Solina 2000, eq. 2.60)."""
        e1, e2 = 2.0 / self.blockiness[0], 2.0 / self.blockiness[1]
        a, b, c = self.half_axes
        return float(2.0 * a * b * c * e1 * e2 * beta(e1 / 2.0 + 1.0, e1) * beta(e2 / 2.0, e2 / 2.0))

    @property
    def engine_density(self) -> float:
        """The density (kg/m³) that gives the superquadric's own volume the brick's mass."""
        return self.mass / self.superquadric_volume

    @cached_property
    def extent(self) -> np.ndarray:
        """(3,) the box 2a × 2b × 2c that holds the body."""
        return 2.0 * self.half_axes

    @cached_property
    def bounding_radius(self) -> float:
        """Largest distance (m) from the centre to the surface (sampled finely: within 1e-6 of it)."""
        vertices, _ = self.surface_mesh(96)
        return float(np.linalg.norm(vertices, axis=1).max())

    @property
    def face_contacts(self) -> int:
        """Contacts when the brick lies on its largest face: one (a face is one smooth surface)."""
        return 1

    def surface_mesh(self, resolution: int = 24) -> tuple[np.ndarray, np.ndarray]:
        """(vertices (n, 3) in the body frame, m; triangles (m, 3) indices) of the surface, sampled on
        the superquadric's parametric grid x = a f(cos η, ε1) f(cos ω, ε2), y = b f(cos η, ε1)
        f(sin ω, ε2), z = c f(sin η, ε1), f(t, ε) = sign(t) |t|^ε, ε = 2/n; `resolution` rows of η."""
        return superquadric_mesh(tuple(self.half_axes), tuple(self.blockiness), resolution)

    @cached_property
    def probes(self) -> tuple[np.ndarray, np.ndarray]:
        """(points (n, 3), radii (n,)) in the body frame: the surface mesh's vertices at resolution 8
        (radius 0), and the centre with the smallest semi-axis (the inscribed ball: coincident bodies)."""
        vertices = self.surface_mesh(8)[0]
        return np.vstack([vertices, -self.centroid_offset]), np.append(np.zeros(len(vertices)), self.half_axes.min())

    def penetration(self, points: np.ndarray) -> np.ndarray:
        """(n,) about how deep each body-frame point (n, 3) lies inside the superquadric (m; ≤ 0
        outside): (1 − F) × the smallest semi-axis, F the inside-outside function
        ((|x/a|^n2 + |y/b|^n2)^(n1/n2) + |z/c|^n1)^(1/n1) (Barr 1981); exact on the flat faces'
        normals through the centre up to the ratio of the semi-axes, never deeper than the truth there."""
        n1, n2 = self.blockiness
        q = np.abs(np.asarray(points) + self.centroid_offset) / self.half_axes  # about the superquadric's own centre
        inside = ((q[:, 0] ** n2 + q[:, 1] ** n2) ** (n1 / n2) + q[:, 2] ** n1) ** (1.0 / n1)
        return (1.0 - inside) * float(self.half_axes.min())

    def lowest_points(self, rotations: np.ndarray) -> np.ndarray:
        """(F,) lowest z (m) of the surface about the centre, the body turned by each of `rotations`
        (F, 3, 3); from the surface sampled at resolution 48 (a face lying flat: exact)."""
        vertices, _ = self.surface_mesh(48)
        return np.einsum("fj,vj->fv", np.asarray(rotations)[:, 2, :], vertices).min(axis=1)


def _signed_power(t: np.ndarray, exponent: float) -> np.ndarray:
    """sign(t) |t|^exponent, with |t| below 1e-12 taken as 0: cos(π/2) is 6e-17 in floating point and
    its 1/8th power 0.009, which put the mesh's points on the axes 0.1 mm off them."""
    t = np.where(np.abs(t) < 1e-12, 0.0, t)
    return np.sign(t) * np.abs(t) ** exponent


@lru_cache(maxsize=32)
def superquadric_mesh(half_axes: tuple[float, float, float], blockiness: tuple[float, float], resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """Cached (vertices, triangles) of a superquadric (see BrickSuperquadric.surface_mesh): a grid of
    `resolution` + 1 latitudes (poles included, each pole one vertex) by 2 × `resolution` longitudes.
    Latitudes and longitudes are spread evenly in the parameter t of η = π/2 · sign(t) |t|^(1/ε)
    so that the flat faces and the rounded edges both get points."""
    a, b, c = half_axes
    e1, e2 = 2.0 / blockiness[0], 2.0 / blockiness[1]
    rows, columns = resolution, 2 * resolution

    def spread(count: int, half_range: float, exponent: float) -> np.ndarray:
        u = np.linspace(-1.0, 1.0, count)
        return half_range * np.sign(u) * np.abs(u) ** max(exponent, 1.0)

    eta = spread(rows + 1, math.pi / 2.0, 1.0 / e1 ** 0.5)[1:-1]
    quarter = spread(columns // 4 * 2 + 1, math.pi / 4.0, 1.0 / e2 ** 0.5)[:-1]  # one side's longitudes
    omega = np.concatenate([quarter + k * math.pi / 2.0 for k in range(4)])
    cos_eta, sin_eta = np.cos(eta)[:, None], np.sin(eta)[:, None]
    ring_x = a * _signed_power(cos_eta, e1) * _signed_power(np.cos(omega)[None, :], e2)
    ring_y = b * _signed_power(cos_eta, e1) * _signed_power(np.sin(omega)[None, :], e2)
    ring_z = np.broadcast_to(c * _signed_power(sin_eta, e1), ring_x.shape)
    rings = np.stack([ring_x, ring_y, ring_z], axis=2).reshape(-1, 3)
    vertices = np.concatenate([[[0.0, 0.0, -c]], rings, [[0.0, 0.0, c]]])
    n_rings, n_around = len(eta), len(omega)
    triangles = []
    ring = lambda i, j: 1 + i * n_around + j % n_around  # noqa: E731
    for j in range(n_around):
        triangles.append((0, ring(0, j + 1), ring(0, j)))
        triangles.append((len(vertices) - 1, ring(n_rings - 1, j), ring(n_rings - 1, j + 1)))
        for i in range(n_rings - 1):
            triangles += [(ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)), (ring(i, j), ring(i + 1, j + 1), ring(i + 1, j))]
    return vertices, np.array(triangles, dtype=np.int64)


@lru_cache(maxsize=256)
def brick_superquadric(length: float, width: float, thickness: float, density: float, blockiness: tuple[float, float],
                       mass: float | None = None, inertia: tuple[float, float, float] | None = None, rounding: float = 0.0) -> BrickSuperquadric:
    """One shared BrickSuperquadric per set of inputs (cases ask once per body)."""
    return BrickSuperquadric(length, width, thickness, density, tuple(float(n) for n in blockiness),  # type: ignore[arg-type]
                             mass, None if inertia is None else tuple(float(i) for i in inertia), rounding)


def from_spec(spec, density: float) -> BrickSuperquadric:
    """The superquadric of a shape entry (bodies.BrickShape: length, width, thickness, blockiness,
    rounding, mass, inertia) at `density` kg/m³."""
    return brick_superquadric(spec.length, spec.width, spec.thickness, density, spec.blockiness, spec.mass, spec.inertia, spec.rounding)


def no_bevel(spec) -> str | None:
    """Only clumps have bevelled faces: a one-line field error for a bevelled entry of this kind."""
    if spec.bevel_deg:
        return f"bevel_deg: a {spec.kind} brick has no bevelled faces; allowed: 0, or kind: clump (got {spec.bevel_deg!r})"
    return None
