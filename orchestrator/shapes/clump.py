"""Bricks as clumps of spheres: layout, true mass and inertia, and how far the clump is from the brick.

A brick is a box of length × width × thickness along its body axes x, y, z, optionally bevelled: the
paper's "modified bricks" have three faces (here +x, +y, +z) turned by `bevel_deg` so that stacked
bricks no longer sit flat on each other. Each bevelled face is turned about its centre line, so the
brick keeps its volume and mass (to 0.1 %): at 2° the +z and +y faces drop along x (the brick is
8.54 mm thick and 15.54 mm wide at its −x end, 7.46 and 14.46 mm at its +x end) and the +x face
along y (31.26 mm long on the −y side, 30.74 mm on the +y side).

A clump of n_x × n_y × n_z spheres fills the solid: along each axis the centres are evenly spread so
that the first and last spheres touch the two opposite faces, and the thickness sets the radius
(thickness / (2 n_z) for a box, so the spheres touch both large faces; neighbours overlap where the
spacing is below 2 r). On a bevelled brick the thickness, hence the radius, shrinks towards the +x
end. The clump gets the mass and inertia of the true solid, never of the union of spheres, so the
dynamics of a brick do not depend on the resolution; only its surface does, and `surface_deviation`
reports by how much. Body frame: origin at the solid's centre of mass, axes along the brick's edges.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from orchestrator.fields import MIN_SIZE
from orchestrator.shapes.rigid import inertia_tensor, quaternion_matrix, rounded_box_moments, solid_moments


INSET = 0.25  # of the rounding radius: how far the layout's spheres stay inside the faces of a rounded brick


@dataclass(frozen=True)
class BrickClump:
    length: float
    width: float
    thickness: float
    density: float
    layout: tuple[int, int, int]  # spheres along x (length), y (width), z (thickness)
    bevel_deg: float = 0.0  # turn of the +x, +y, +z faces (0: a box)
    # The body's mass (kg) and principal moments (kg m², about the brick axes) when given: those of
    # another solid than the sharp box, e.g. the study's brick with 1 mm rounded edges. None: the box's.
    mass_given: float | None = None
    inertia_given: tuple[float, float, float] | None = None
    # Radius (m) of eight more spheres, one in each corner, tangent to the three faces there: the
    # corners of a brick whose edges are rounded at that radius (the 2012 study's brick: 1 mm). The
    # layout's spheres, flush with the faces, lie inside that rounded brick. 0: no corner spheres.
    rounding: float = 0.0

    kind = "clump"

    @cached_property
    def vertices(self) -> np.ndarray:
        """(2, 2, 2, 3) corners of the solid, indexed by side (0: −, 1: +) along x, y, z, about the box centre."""
        a, b, c, t = self.length, self.width, self.thickness, self._slope
        corners = np.empty((2, 2, 2, 3))
        for sx, sy, sz in itertools.product((0, 1), repeat=3):
            # One face plane n · p = d per axis: the − face is the box's, the + face is bevelled.
            normals = [(1.0, t if sx else 0.0, 0.0), (t if sy else 0.0, 1.0, 0.0), (t if sz else 0.0, 0.0, 1.0)]
            offsets = [a / 2 if sx else -a / 2, b / 2 if sy else -b / 2, c / 2 if sz else -c / 2]
            corners[sx, sy, sz] = np.linalg.solve(np.array(normals), np.array(offsets))
        return corners

    @property
    def _slope(self) -> float:
        return math.tan(math.radians(self.bevel_deg))

    @cached_property
    def _mass_properties(self) -> tuple[float, np.ndarray, np.ndarray]:
        """(volume, centroid, covariance ∫ (p − centroid)(p − centroid)ᵀ dV) of the solid, about the box centre."""
        if self.bevel_deg == 0.0:  # the box, rounded or not, in closed form
            return rounded_box_moments(np.array([self.length, self.width, self.thickness]), self.rounding)
        return solid_moments(self.vertices.reshape(-1, 3))

    @cached_property
    def centroid_offset(self) -> np.ndarray:
        """Centre of mass of the solid relative to the centre of the full box (zero without bevel)."""
        return self._mass_properties[1]

    @cached_property
    def _spheres(self) -> tuple[np.ndarray, np.ndarray]:
        """(centres about the box centre, radii): each axis spread between its two faces, at the local extent.

        The extents on a bevelled brick depend on where the sphere sits (the +z face drops along x),
        so the layout is iterated to its fixed point (contracting by tan β per pass; one pass for a
        box). A sphere touches a bevelled face when its centre is r / cos β inside along the axis.
        """
        a, b, c, t = self.length, self.width, self.thickness, self._slope
        stretch = math.sqrt(1.0 + t * t)  # 1 / cos β
        lattice = [np.linspace(0.0, 1.0, n) if n > 1 else np.full(1, 0.5) for n in self.layout]
        fraction = np.stack([g.ravel() for g in np.meshgrid(*lattice, indexing="ij")], axis=1)
        centres = (fraction - 0.5) * np.array([a, b, c])
        for _ in range(50):
            x, y = centres[:, 0], centres[:, 1]
            low = np.array([-a / 2, -b / 2, -c / 2])
            high = np.stack([a / 2 - y * t, b / 2 - x * t, c / 2 - x * t], axis=1)
            radii = (high[:, 2] - low[2]) / (self.layout[2] * (1.0 + stretch))
            first, last = low + radii[:, None], high - stretch * radii[:, None]
            updated = first + fraction * (last - first)
            if np.allclose(updated, centres, rtol=0.0, atol=1e-15):
                break
            centres = updated
        return updated, radii

    @cached_property
    def _corner_spheres(self) -> tuple[np.ndarray, np.ndarray]:
        """(8, 3) centres about the box centre and (8,) radii of the corner spheres (none without rounding)."""
        if not self.rounding:
            return np.empty((0, 3)), np.empty(0)
        half = np.array([self.length, self.width, self.thickness]) / 2.0 - self.rounding
        signs = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
        return signs * half, np.full(8, self.rounding)

    @cached_property
    def centres(self) -> np.ndarray:
        """(n, 3) sphere centres in the body frame (about the centre of mass): the layout's, then the corners'."""
        return np.concatenate([self._spheres[0], self._corner_spheres[0]]) - self.centroid_offset

    @cached_property
    def radii(self) -> np.ndarray:
        """(n,) sphere radii: all equal on a box without rounding. With rounding, the layout's spheres
        sit INSET × rounding inside the faces, so that a face lands on its four corners alone (as the
        study's brick does) until the overlap exceeds that (0.25 mm: impacts faster than about 2 m/s
        with the study's constants)."""
        return np.concatenate([self._spheres[1] - INSET * self.rounding, self._corner_spheres[1]])

    @property
    def radius(self) -> float:
        """m, the largest sphere radius (the only one on a box): the engine moves spheres."""
        return float(self.radii.max())

    @property
    def skin_length(self) -> float:
        """m, what neighbour skins are a multiple of: the largest sphere radius."""
        return self.radius

    @property
    def n_spheres(self) -> int:
        return len(self.radii)

    @property
    def sweep(self) -> None:
        """A clump is no sphere-swept box (shapes/overlap.py measures it by its spheres)."""
        return None

    @property
    def particles(self) -> int:
        """Particles the engine moves for this body: its spheres."""
        return self.n_spheres

    @property
    def face_contacts(self) -> int:
        """Spheres that touch a plane at once when the brick lies on its largest face: the stiffness
        of a flat landing is this many times k_n (the shortest contact the time step must resolve)."""
        nx, ny, nz = self.layout
        return 4 if self.rounding else max(nx * ny, nx * nz, ny * nz)

    @property
    def volume(self) -> float:
        return self._mass_properties[0]

    @property
    def mass(self) -> float:
        return self.mass_given if self.mass_given is not None else self.density * self.volume

    @cached_property
    def inertia_tensor(self) -> np.ndarray:
        """(3, 3) inertia of the solid about its centre of mass, in the brick axes (rigid.inertia_tensor),
        or diag(inertia_given)."""
        return inertia_tensor(self._mass_properties[2], self.mass, self.volume, self.inertia_given)

    @property
    def principal_inertia(self) -> np.ndarray:
        """(I_x, I_y, I_z) about the brick axes: m/12 (b² + c²) etc. for a box, where they are principal.

        A 2° bevel adds products of inertia (up to 7 % of I_x) and tilts the principal axes by up to
        1.9°, but the principal moments differ from these diagonal terms by 0.3 % at most. LIGGGHTS
        takes the whole tensor; YADE, which takes three moments, gets these.
        """
        return np.diag(self.inertia_tensor).copy()

    @cached_property
    def extent(self) -> np.ndarray:
        """(3,) size of the smallest centred box holding the solid in any half-turned orientation.

        A bevelled face juts out of the nominal box on one side (0.54 mm at 2°); flipped bricks
        stacked in rows need that much room on both sides.
        """
        return 2.0 * np.abs(self.vertices.reshape(-1, 3)).max(axis=0)

    @property
    def bounding_radius(self) -> float:
        return float(np.max(np.linalg.norm(self.centres, axis=1) + self.radii))

    def surface_mesh(self, resolution: int = 12) -> tuple[np.ndarray, np.ndarray]:
        """(vertices (n, 3) in the body frame, m; triangles (m, 3) indices): each sphere of the clump
        as a latitude-longitude sphere of `resolution` latitudes (what the engine's body is)."""
        unit, triangles = unit_sphere_mesh(resolution)
        vertices = (self.centres[:, None, :] + self.radii[:, None, None] * unit[None, :, :]).reshape(-1, 3)
        offsets = (np.arange(self.n_spheres) * len(unit))[:, None, None]
        return vertices, (triangles[None, :, :] + offsets).reshape(-1, 3)

    @cached_property
    def probes(self) -> tuple[np.ndarray, np.ndarray]:
        """(centres (n, 3), radii (n,)) in the body frame: the clump's own spheres."""
        return self.centres, self.radii

    def penetration(self, points: np.ndarray) -> np.ndarray:
        """(n,) how deep each body-frame point (n, 3) lies inside the clump (m): the deepest of its
        spheres, r − |p − c|; ≤ 0 outside."""
        gaps = self.radii[None, :] - np.linalg.norm(np.asarray(points)[:, None, :] - self.centres[None, :, :], axis=2)
        return gaps.max(axis=1)

    def lowest_points(self, rotations: np.ndarray) -> np.ndarray:
        """(F,) lowest z (m) of the clump's spheres about its centre, the body turned by each of `rotations` (F, 3, 3)."""
        return (np.einsum("fj,sj->fs", np.asarray(rotations)[:, 2, :], self.centres) - self.radii[None, :]).min(axis=1)

    def surface_deviation(self, samples_per_edge: int = 40) -> tuple[float, float]:
        """(max, mean) distance from points on the brick's surface to the surface of the sphere union.

        Points are a regular grid on all six faces; the distance is |signed distance to the union|,
        the union's signed distance being min_i(|p - c_i| - r_i).
        """
        points = solid_surface_points(self.vertices, samples_per_edge) - self.centroid_offset
        gaps = np.linalg.norm(points[:, None, :] - self.centres[None, :, :], axis=2) - self.radii[None, :]
        distance = np.abs(gaps.min(axis=1))
        return float(distance.max()), float(distance.mean())


@lru_cache(maxsize=256)
def brick_clump(length: float, width: float, thickness: float, density: float, layout: tuple[int, int, int], bevel_deg: float = 0.0,
                mass: float | None = None, inertia: tuple[float, float, float] | None = None, rounding: float = 0.0) -> BrickClump:
    """One shared BrickClump per set of inputs: cases ask for a shape's clump once per body (10 000
    times for an ordered pile), and its layout, hull and moments are then worked out once."""
    return BrickClump(length, width, thickness, density, tuple(layout), bevel_deg, mass,  # type: ignore[arg-type]
                      None if inertia is None else tuple(float(i) for i in inertia), rounding)


def solid_surface_points(vertices: np.ndarray, n: int) -> np.ndarray:
    """A regular n × n grid of points on each of the six (planar, four-cornered) faces of a hexahedron.

    vertices: (2, 2, 2, 3) corners indexed by side along x, y, z (see BrickClump.vertices).
    """
    grid = np.linspace(0.0, 1.0, n)
    u, v = (g.ravel()[:, None] for g in np.meshgrid(grid, grid, indexing="ij"))
    faces = []
    for axis in range(3):
        for side in (0, 1):
            corner = np.take(vertices, side, axis=axis)  # (2, 2, 3) over the two other axes
            faces.append((1 - u) * (1 - v) * corner[0, 0] + u * (1 - v) * corner[1, 0] + (1 - u) * v * corner[0, 1] + u * v * corner[1, 1])
    return np.concatenate(faces)


def world_sphere_centres(clump: BrickClump, position: np.ndarray, orientation: np.ndarray) -> np.ndarray:
    """(n, 3) sphere centres of one brick placed at `position` with quaternion `orientation` (w, x, y, z)."""
    return np.asarray(position, dtype=float) + clump.centres @ quaternion_matrix(orientation).T


def bodies_sphere_centres(clump: BrickClump, positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """(B, n, 3) sphere centres of B bricks (or one brick at B frames) at `positions` (B, 3) turned
    by `rotations` (B, 3, 3)."""
    return np.asarray(positions, dtype=float)[:, None, :] + np.einsum("bij,sj->bsi", rotations, clump.centres)


@lru_cache(maxsize=8)
def unit_sphere_mesh(resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, triangles) of a unit sphere: `resolution` − 1 latitude rings of 2 × `resolution`
    points between the two poles."""
    eta = np.linspace(-math.pi / 2.0, math.pi / 2.0, resolution + 1)[1:-1]
    omega = np.linspace(0.0, 2.0 * math.pi, 2 * resolution, endpoint=False)
    rings = np.stack([np.outer(np.cos(eta), np.cos(omega)), np.outer(np.cos(eta), np.sin(omega)),
                      np.broadcast_to(np.sin(eta)[:, None], (len(eta), len(omega)))], axis=2).reshape(-1, 3)
    vertices = np.concatenate([[[0.0, 0.0, -1.0]], rings, [[0.0, 0.0, 1.0]]])
    n_rings, n_around, top = len(eta), len(omega), len(rings) + 1
    triangles = []
    for j in range(n_around):
        k = (j + 1) % n_around
        triangles += [(0, 1 + k, 1 + j), (top, 1 + (n_rings - 1) * n_around + j, 1 + (n_rings - 1) * n_around + k)]
        for i in range(n_rings - 1):
            a, b, c, d = 1 + i * n_around + j, 1 + i * n_around + k, 1 + (i + 1) * n_around + k, 1 + (i + 1) * n_around + j
            triangles += [(a, b, c), (a, c, d)]
    return vertices, np.array(triangles, dtype=np.int64)


def from_spec(spec, density: float) -> BrickClump:
    """The clump of a shape entry (bodies.BrickShape: length, width, thickness, layout, bevel_deg,
    rounding, mass, inertia) at `density` kg/m³."""
    return brick_clump(spec.length, spec.width, spec.thickness, density, spec.layout, spec.bevel_deg, spec.mass, spec.inertia, spec.rounding)


def check_spec(spec) -> str | None:
    """The clump's own limit on a shape entry, as a one-line field error (None: fine): its smallest
    sphere must be at least MIN_SIZE (bodies.MIN_SIZE) across."""
    smallest = float(brick_clump(spec.length, spec.width, spec.thickness, 1.0, spec.layout, spec.bevel_deg, rounding=spec.rounding).radii.min())  # thickness / (2 layout[2]), less INSET × rounding; thinner at a bevel's end
    if smallest >= MIN_SIZE:
        return None
    return (f"layout: the clump's smallest sphere would be {smallest:.3g} m in radius; allowed: at least {MIN_SIZE:g} m "
            f"(fewer spheres across the thickness{', less rounding' if spec.rounding else ''}"
            f"{', a smaller bevel' if spec.bevel_deg else ''}) (got {list(spec.layout)})")
