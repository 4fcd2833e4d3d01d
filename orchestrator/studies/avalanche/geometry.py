"""The Manzella & Labiouse (2009) avalanche set-up, as case data: boards, release box, bricks.

Frame: x horizontal along the flow, the slope toe at x = 0 (the inclined board at x < 0), y across,
z vertical (the flat board at z = 0). A point at distance s up the slope is (-s cos α, y, s sin α).
The release box sits on the slope: its trap (downslope wall) at slope distance launch_height / sin α,
its depth running upslope, its height normal to the slope. As in the experiment and the 2012 study
(Fig. 9), the box is filled standing on its own base: the packing runs in place with gravity along
the slope's normal (`packing_gravity`), which is the box's own frame turned rigidly onto the slope,
so the pile is a slab parallel to the slope. Opening the trap at t = 0 is modelled by starting the
avalanche run without that wall, under vertical gravity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation

from orchestrator.shapes import BodyShape
from orchestrator.shapes.rigid import quaternion_matrices
from orchestrator.studies.avalanche.packing import random_orientations


@dataclass(frozen=True)
class AvalancheGeometry:
    slope_deg: float = 45.0
    launch_height: float = 1.0
    board_length: float = 3.0  # along the flow, each board
    board_width: float = 4.0
    box_depth: float = 0.6  # along the slope
    box_width: float = 0.4  # across
    box_height: float = 0.2  # normal to the slope

    @property
    def down(self) -> np.ndarray:
        a = math.radians(self.slope_deg)
        return np.array([math.cos(a), 0.0, -math.sin(a)])

    @property
    def normal(self) -> np.ndarray:
        a = math.radians(self.slope_deg)
        return np.array([math.sin(a), 0.0, math.cos(a)])

    def on_slope(self, s: float, y: float = 0.0, n: float = 0.0) -> np.ndarray:
        """World point at slope distance s from the toe (upslope), lateral y, height n above the board."""
        return -s * self.down + np.array([0.0, y, 0.0]) + n * self.normal

    @property
    def trap_distance(self) -> float:
        return self.launch_height / math.sin(math.radians(self.slope_deg))

    def box_corner(self) -> np.ndarray:
        """Lowest corner of the box: at the trap, on the board, at y = -width/2."""
        return self.on_slope(self.trap_distance, -self.box_width / 2)

    @property
    def box_axes(self) -> np.ndarray:
        """(3, 3) rows: the box frame's axes in the world (u upslope, v across, n normal to the slope)."""
        return np.stack([-self.down, np.array([0.0, 1.0, 0.0]), self.normal])

    def box_to_world(self, local: np.ndarray) -> np.ndarray:
        """(…, 3) box-frame points (u upslope, v across, n normal) to world points."""
        return self.box_corner() + np.asarray(local) @ self.box_axes

    def world_to_box(self, points: np.ndarray) -> np.ndarray:
        """(…, 3) world points to the box frame (u upslope from the trap, v across from the box's
        side, n above the slope), m."""
        return (np.asarray(points) - self.box_corner()) @ self.box_axes.T

    def packing_gravity(self, g: float = 9.81) -> tuple[float, float, float]:
        """Gravity while packing (m/s²): along the slope's normal, into the board, as for the box
        standing on its base before it is set on the slope."""
        return tuple(float(v) for v in -g * self.normal)  # type: ignore[return-value]

    def release_gravity(self, g: float = 9.81) -> tuple[float, float, float]:
        """Gravity during the release (m/s²): vertical, down, as in the experiment."""
        return (0.0, 0.0, -g)

    def slab(self, volume: float) -> tuple[np.ndarray, np.ndarray]:
        """Centre of a slab of `volume` (m³) lying flat on the box's base, and the upper end of that
        base (world (3,) points, m): the experiment's initial state (Fig. 9 of the 2012 study: 40 l
        in the 0.6 × 0.4 × 0.2 m box give about (−1.15, 1.27) and (−1.41, 1.41) m in (x, z))."""
        thickness = volume / (self.box_depth * self.box_width)
        return (self.box_to_world([self.box_depth / 2, self.box_width / 2, thickness / 2]),
                self.box_to_world([self.box_depth, self.box_width / 2, 0.0]))

    def outside_box(self, points: np.ndarray) -> np.ndarray:
        """(B,) bool: points (B, 3) outside the box (its depth, width and height)."""
        local = self.world_to_box(points)
        size = np.array([self.box_depth, self.box_width, self.box_height])
        return ~np.all((local >= 0.0) & (local <= size), axis=-1)

    def walls(self, trap_closed: bool, wall_height: float | None = None, lid: bool = False) -> list[dict[str, object]]:
        """Rectangles: slope board, flat board, box side and back walls (`wall_height` high, m; default
        the box's), the trap if closed and a lid on the walls' top if `lid`."""
        height = wall_height if wall_height is not None else self.box_height
        top = self.on_slope(self.board_length, -self.board_width / 2)
        walls: list[dict[str, object]] = [
            _rectangle("slope", "board", top, self.board_length * self.down, (0.0, self.board_width, 0.0)),
            _rectangle("runout", "board", (0.0, -self.board_width / 2, 0.0), (self.board_length, 0.0, 0.0), (0.0, self.board_width, 0.0)),
        ]
        corner = self.box_corner()
        up, across, normal = -self.down * self.box_depth, np.array([0.0, self.box_width, 0.0]), self.normal * height
        walls.append(_rectangle("box_left", "box", corner, up, normal))
        walls.append(_rectangle("box_right", "box", corner + across, up, normal))
        walls.append(_rectangle("box_back", "box", corner + up, across, normal))
        if trap_closed:
            walls.append(_rectangle("trap", "box", corner, across, normal))
        if lid:
            walls.append(_rectangle("lid", "box", corner + normal, up, across))
        return walls


def _rectangle(name: str, material: str, origin: object, edge1: object, edge2: object) -> dict[str, object]:
    return {
        "type": "rectangle",
        "name": name,
        "material": material,
        "origin": [float(v) for v in origin],  # type: ignore[union-attr]
        "edge1": [float(v) for v in edge1],  # type: ignore[union-attr]
        "edge2": [float(v) for v in edge2],  # type: ignore[union-attr]
    }


def rain_positions(geometry: AvalancheGeometry, brick: BodyShape, count: int, seed: int, gap: float = 0.001) -> tuple[np.ndarray, np.ndarray]:
    """Randomly oriented bricks on a grid inside the box footprint, stacked along the slope normal.

    Cells are one bounding diameter wide, so no two bricks overlap whatever their orientation.
    Returns world positions (count, 3) and orientations (count, 4; w, x, y, z).
    """
    cell = 2.0 * brick.bounding_radius + gap
    nu = max(1, int(geometry.box_depth // cell))
    nv = max(1, int(geometry.box_width // cell))
    index = np.arange(count)
    i, j, k = index % nu, (index // nu) % nv, index // (nu * nv)
    local = np.stack([(i + 0.5) * cell, (j + 0.5) * cell, (k + 0.5) * cell + gap], axis=1)
    return geometry.box_to_world(local), random_orientations(count, seed)


def rain_height(geometry: AvalancheGeometry, brick: BodyShape, count: int, gap: float = 0.001) -> float:
    """Height above the box floor (along the normal) that the rain grid of `count` bricks reaches."""
    cell = 2.0 * brick.bounding_radius + gap
    per_layer = max(1, int(geometry.box_depth // cell)) * max(1, int(geometry.box_width // cell))
    return math.ceil(count / per_layer) * cell + 2 * gap


def brick_count(volume: float, apparent_density: float, brick: BodyShape) -> int:
    """Bricks in a volume of pile at an apparent density (e.g. 40 l at 1000 kg/m³ → ≈ 6300 bricks)."""
    return int(round(volume * apparent_density / brick.mass))


def apparent_density(geometry: AvalancheGeometry, positions: np.ndarray, orientations: np.ndarray, brick: BodyShape,
                     spacing: float | None = None) -> float:
    """Total brick mass over the bulk volume it fills in the box (kg/m³): the volume between the box
    floor and the pile's levelled top surface.

    The top surface is sampled as a fringe projection would see it (`top_surface`, on a grid of
    `spacing`, default a quarter of the brick's thickness), then levelled as a person reading the
    pile's level would: pits narrower than a brick's width (between bricks, or between an ordered
    pile and the walls) are filled by a morphological closing (scipy.ndimage.grey_closing, walls
    counting as high), while a wider stretch of bare floor (where a pour leaning on the trap thins
    out) stays empty. A flush ordered pile thus reads the brick's mass over its box times the share of
    the floor its rows cover, as a level measured in the box would give.
    The reading follows the surface, not the grid (the same with a 1 mm and a 2 mm grid, where the
    highest sphere of coarse cells reads low: docs/studies/avalanche.md, packing density).
    positions (N, 3) m; orientations (N, 4) unit quaternions (w, x, y, z).
    """
    spacing = spacing or brick.extent[2] / 4.0
    axes = geometry.box_axes
    heights = top_surface(geometry.box_depth, geometry.box_width, spacing,
                          (np.asarray(positions) - geometry.box_corner()) @ axes.T,
                          axes @ quaternion_matrices(np.asarray(orientations)), brick)
    window = max(1, int(round(brick.extent[1] / spacing)))
    level = ndimage.grey_closing(heights, size=(window, window), mode="constant", cval=np.inf)
    return len(positions) * brick.mass / (geometry.box_depth * geometry.box_width * float(level.mean()))


def top_surface(depth: float, width: float, spacing: float, centres: np.ndarray, rotations: np.ndarray, brick: BodyShape) -> np.ndarray:
    """(nu, nv) heights (m) of the highest brick point above each point of a grid of `spacing` over
    [0, depth] × [0, width]: a vertical line through the point meets a brick's box (half extents e)
    where its slabs overlap (Kay & Kajiya's slab test); the top is where the line leaves the box.

    centres (N, 3): centres of mass in the frame (u, v, n up); rotations (N, 3, 3): brick → frame.
    """
    u = np.arange(spacing / 2, depth, spacing)
    v = np.arange(spacing / 2, width, spacing)
    heights = np.zeros((len(u), len(v)))
    half = brick.extent / 2.0
    reach = float(np.linalg.norm(half))
    boxes = centres - rotations @ brick.centroid_offset  # the nominal box's centre
    for centre, rotation in zip(boxes, rotations):
        i = slice(*np.searchsorted(u, [centre[0] - reach, centre[0] + reach]))
        j = slice(*np.searchsorted(v, [centre[1] - reach, centre[1] + reach]))
        uu, vv = np.meshgrid(u[i] - centre[0], v[j] - centre[1], indexing="ij")
        origin = np.stack([uu, vv, np.zeros_like(uu)], axis=-1) @ rotation  # brick frame, line start at the centre's height
        direction = rotation[2]  # frame's n in the brick frame
        step = np.where(np.abs(direction) > 1e-12, direction, 1e-12)  # a face parallel to the line: its slab is all or nothing
        t1, t2 = (-half - origin) / step, (half - origin) / step
        enter, leave = np.minimum(t1, t2).max(axis=-1), np.maximum(t1, t2).min(axis=-1)
        top = np.where(enter <= leave, centre[2] + leave, 0.0)
        heights[i, j] = np.maximum(heights[i, j], top)
    return heights


def ordered_pile(
    geometry: AvalancheGeometry, brick: BodyShape, count: int, gap: float = 0.0005, flip_seed: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Bricks in regular rows: length along the slope, width across, thickness normal; layers upward.

    The brick frame (length x, width y, thickness z) is turned onto the box frame (u, v, n). Each
    brick's nominal box fills its cell (its centre of mass is off the cell centre if bevelled). With
    `flip_seed`, each brick is also turned half a turn about one of its axes, or not, at random (the
    paper's random flips: bevelled faces then point every way, so rows no longer stack flat).
    """
    cell = brick.extent + gap
    nu, nv = pile_rows(geometry, brick, gap)
    index = np.arange(count)
    i, j, k = index % nu, (index // nu) % nv, index // (nu * nv)
    local = np.stack(
        [(i + 0.5) * cell[0], (j + 0.5) * cell[1], (k + 0.5) * cell[2] + gap], axis=1
    )
    # Rotation taking the brick axes onto (down-slope, across, normal), a right-handed frame.
    matrix = np.stack([geometry.down, np.array([0.0, 1.0, 0.0]), geometry.normal], axis=1)
    flips = HALF_TURNS[np.random.default_rng(flip_seed).integers(0, 4, count)] if flip_seed is not None else HALF_TURNS[np.zeros(count, dtype=int)]
    rotations = Rotation.from_matrix(matrix) * Rotation.from_quat(np.roll(flips, -1, axis=1))  # flip in the brick frame first
    x, y, z, w = rotations.as_quat().T
    positions = geometry.box_to_world(local) + rotations.apply(brick.centroid_offset)
    return positions, np.stack([w, x, y, z], axis=1)


def pile_rows(geometry: AvalancheGeometry, brick: BodyShape, gap: float) -> tuple[int, int]:
    """Bricks along the slope and across in one layer of the ordered pile."""
    cell = brick.extent + gap
    return max(1, int(geometry.box_depth // cell[0])), max(1, int(geometry.box_width // cell[1]))


# (w, x, y, z): no turn, and half turns about the brick's x, y, z axes.
HALF_TURNS = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
