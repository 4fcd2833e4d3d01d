"""Initial arrangements of clumps: engine-neutral lists of positions and orientations.

`loose_grid` places randomly oriented bricks on a grid whose cells are one bounding diameter wide, so
no two bricks overlap whatever their orientation; released under gravity they rain into a pile. A
private random generator seeded from the case keeps packings reproducible.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from orchestrator.shapes import BodyShape


def random_orientations(count: int, seed: int) -> np.ndarray:
    """(count, 4) uniformly random unit quaternions, (w, x, y, z) order."""
    xyzw = Rotation.random(count, random_state=np.random.default_rng(seed)).as_quat()
    return np.roll(xyzw, 1, axis=1)


def loose_grid(
    brick: BodyShape,
    count: int,
    lower: tuple[float, float, float],
    columns: tuple[int, int],
    seed: int,
    gap: float = 0.001,
) -> tuple[np.ndarray, np.ndarray]:
    """Positions (count, 3) and orientations (count, 4) of bricks stacked on a columns[0] × columns[1] grid.

    Cells are (2 bounding radii + gap) wide; layers fill upward from `lower` (the grid's lowest corner).
    """
    cell = 2.0 * brick.bounding_radius + gap
    index = np.arange(count)
    per_layer = columns[0] * columns[1]
    i, j, k = index % columns[0], (index // columns[0]) % columns[1], index // per_layer
    positions = np.asarray(lower, dtype=float) + (np.stack([i, j, k], axis=1) + 0.5) * cell
    return positions, random_orientations(count, seed)
