"""The brick as the 2012 study models it: a rounded box, several contact points per touching face.

A rounded box is a sphero-polyhedron: an inner box of half extents h swept by a sphere of radius r
(the study's brick: 14.5 × 6.5 × 3 mm inside, r = 1 mm, 31 × 15 × 8 mm outside; Richefeu et al.
2012). Its faces are flat, its edges quarter cylinders, its corners sphere octants. Where two of
them touch, every vertex of one inner box within r_A + r_B of the other and every crossing pair of
edges is a contact point of its own (custom_contact/roundedbox_geometry.h): a face on a face gives
the corners of their overlap (16 points aligned, 8 offset, 4 crossed at 90°), so the resultant can
sit anywhere in the overlap and a brick slides on a brick at the friction angle.

Mass and inertia are the rounded solid's, in closed form (shapes/rigid.py `rounded_box_moments`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from orchestrator.fields import MIN_SIZE
from orchestrator.shapes.solid import OneBodyBrick

# Contact points the time step is sized by: a face landing flat on the board (its four vertices).
# On an aligned brick a face lands on 16 (at each corner both vertices and both crossing edge pairs),
# so that contact gets 25 steps, not 50; the study's code ran its quarter set-up at that step
# (1.2415726e-5 s at k_n 2e4, reference.toml [avalanche.quarter.richefeu_code]). Measured at it, a brick
# landing flat on an aligned brick rebounds 0.3527 of its speed, 0.3498 at 0.1 µs (docs/bricks.md).
FACE_CONTACTS = 4


@dataclass(frozen=True)
class BrickRoundedBox(OneBodyBrick):
    length: float
    width: float
    thickness: float
    density: float
    rounding: float  # m, > 0: the sphere that sweeps the inner box
    mass_given: float | None = None
    inertia_given: tuple[float, float, float] | None = None

    kind = "rounded_box"

    @property
    def inner_half_extents(self) -> np.ndarray:
        """(3,) half extents (m) of the inner box: the outer ones less the rounding."""
        return self.half_axes - self.rounding

    @property
    def sweep(self) -> tuple[np.ndarray, float]:
        """(inner half extents (3,) m, rounding m): the box and the sphere that sweeps it."""
        return self.inner_half_extents, float(self.rounding)

    @property
    def extent(self) -> np.ndarray:
        return 2.0 * self.half_axes

    @property
    def skin_length(self) -> float:
        """m, what neighbour skins are a multiple of: the smallest outer half extent (4 mm for the
        study's brick), not the bounding radius (17.7 mm: four thicknesses, twice the neighbour
        pairs). A rounded box keeps its contact history with the body, so the more frequent
        neighbour rebuilds cost it nothing; LIGGGHTS moves a superquadric's history at every
        rebuild, and its full-scale packing ran 35 % slower with this skin (see liggghts/deck.py)."""
        return float(self.half_axes.min())

    @property
    def bounding_radius(self) -> float:
        """|h| + r (m): a corner's sphere is the farthest surface."""
        return float(np.linalg.norm(self.inner_half_extents) + self.rounding)

    @property
    def face_contacts(self) -> int:
        return FACE_CONTACTS

    def surface_mesh(self, resolution: int = 24) -> tuple[np.ndarray, np.ndarray]:
        """(vertices (n, 3) in the body frame, m; triangles (m, 3) indices): a sphere of radius r
        cut into octants, each moved out to its corner of the inner box, the gaps between them
        (the flat faces and the edges' cylinders) closed; `resolution` / 2 latitudes per quarter circle."""
        return rounded_box_mesh(tuple(self.inner_half_extents), float(self.rounding), max(2, resolution // 2))

    @cached_property
    def probes(self) -> tuple[np.ndarray, np.ndarray]:
        """(points (n, 3), radii (n,)): the inner box's corners with the rounding (their union holds
        every corner), the surface's points (radius 0), and the centre with the smallest outer half
        extent (coincident bodies)."""
        corners = self._corners()
        surface = self.surface_mesh(8)[0]
        points = np.vstack([corners, surface, np.zeros((1, 3))])
        radii = np.concatenate([np.full(8, self.rounding), np.zeros(len(surface)), [float(self.half_axes.min())]])
        return points, radii

    def penetration(self, points: np.ndarray) -> np.ndarray:
        """(n,) depth (m) of body-frame points (n, 3) inside the solid, ≤ 0 outside: r less the
        signed distance to the inner box (exact)."""
        q = np.abs(np.asarray(points, dtype=float)) - self.inner_half_extents
        outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
        inside = np.minimum(q.max(axis=1), 0.0)
        return self.rounding - (outside + inside)

    def lowest_points(self, rotations: np.ndarray) -> np.ndarray:
        """(F,) lowest z (m) of the surface about the centre, the body turned by each of `rotations`
        (F, 3, 3): the lowest inner corner less r (exact)."""
        z = np.einsum("fj,vj->fv", np.asarray(rotations)[:, 2, :], self._corners())
        return z.min(axis=1) - self.rounding

    def _corners(self) -> np.ndarray:
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
        return signs * self.inner_half_extents


@lru_cache(maxsize=32)
def rounded_box_mesh(inner: tuple[float, float, float], rounding: float, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Cached (vertices, triangles) of a rounded box (see BrickRoundedBox.surface_mesh): a
    latitude-longitude grid whose rows and columns at the octants' borders are doubled, one copy
    per side, so that each quadrant of the grid takes its own corner's offset."""
    quarter = np.linspace(0.0, math.pi / 2.0, steps + 1)
    # latitudes from the south pole to the north, each with the sign of z it belongs to
    latitudes = np.concatenate([quarter - math.pi / 2.0, quarter])
    lat_sign = np.concatenate([-np.ones(steps + 1), np.ones(steps + 1)])
    longitudes = np.concatenate([quarter + k * math.pi / 2.0 for k in range(4)])
    lon_sx = np.concatenate([np.full(steps + 1, s) for s in (1.0, -1.0, -1.0, 1.0)])
    lon_sy = np.concatenate([np.full(steps + 1, s) for s in (1.0, 1.0, -1.0, -1.0)])
    cos_lat, sin_lat = np.cos(latitudes)[:, None], np.sin(latitudes)[:, None]
    direction = np.stack(np.broadcast_arrays(cos_lat * np.cos(longitudes)[None, :], cos_lat * np.sin(longitudes)[None, :],
                                             sin_lat * np.ones_like(longitudes)[None, :]), axis=2)
    offset = np.stack(np.broadcast_arrays(lon_sx[None, :] * inner[0], lon_sy[None, :] * inner[1],
                                          lat_sign[:, None] * inner[2] * np.ones_like(longitudes)[None, :]), axis=2)
    grid = offset + rounding * direction
    rows, columns = grid.shape[:2]
    vertices = grid.reshape(-1, 3)
    index = lambda i, j: i * columns + j % columns  # noqa: E731
    triangles = []
    for i in range(rows - 1):
        for j in range(columns):
            a, b, c, d = index(i, j), index(i, j + 1), index(i + 1, j + 1), index(i + 1, j)
            triangles += [(a, b, c), (a, c, d)]
    for row in (0, rows - 1):  # the bottom and top faces: the poles' rows hold their four corners
        c = [index(row, k * (steps + 1)) for k in range(4)]
        if row == 0:  # seen from below: outward is down
            c = c[::-1]
        triangles += [(c[0], c[1], c[2]), (c[0], c[2], c[3])]
    triangles = np.array(triangles, dtype=np.int64)
    # drop the triangles of zero area (at the poles, where a row's points coincide)
    p = vertices[triangles]
    area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    return vertices, triangles[area > 1e-18]


@lru_cache(maxsize=256)
def brick_rounded_box(length: float, width: float, thickness: float, density: float, rounding: float,
                      mass: float | None = None, inertia: tuple[float, float, float] | None = None) -> BrickRoundedBox:
    """One shared BrickRoundedBox per set of inputs (cases ask once per body)."""
    return BrickRoundedBox(length, width, thickness, density, float(rounding), mass,
                           None if inertia is None else tuple(float(i) for i in inertia))  # type: ignore[arg-type]


def from_spec(spec, density: float) -> BrickRoundedBox:
    """The rounded box of a shape entry (bodies.BrickShape: length, width, thickness, rounding, mass,
    inertia) at `density` kg/m³."""
    return brick_rounded_box(spec.length, spec.width, spec.thickness, density, spec.rounding, spec.mass, spec.inertia)


def check_spec(spec) -> str | None:
    """A rounded box is swept by a sphere: it needs a rounding, and has no bevelled faces."""
    if spec.bevel_deg:
        return f"bevel_deg: a rounded_box brick has no bevelled faces; allowed: 0, or kind: clump (got {spec.bevel_deg!r})"
    if not spec.rounding:
        limit = min(spec.length, spec.width, spec.thickness) / 2.0
        return f"rounding: a rounded_box brick is swept by a sphere of this radius; allowed: [{MIN_SIZE:g}, {limit:g}) m (got 0)"
    return None
