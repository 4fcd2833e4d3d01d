"""Deposit metrics of a granular avalanche (Manzella & Labiouse 2009; Richefeu et al. 2012, Fig. 9).

Frame: x horizontal along the flow with the slope toe at x = 0 (the slope is at x < 0), y across the
flow, z vertical with the run-out board at z = 0. All metrics use horizontal distances.

- L, length: distal minus proximal x of the deposit (the proximal end may lie on the slope).
- R, runout: distal x of the deposit, i.e. the distance from the slope toe to the distal end.
- W, width: largest minus smallest y of the deposit.
- H, height: highest point of the deposit above the board.
- X_CM: x of the deposit's centre of mass.
- φ_CM, travel angle of the centre of mass: atan(drop of the centre of mass / its horizontal travel).
- φ_app, fahrböschung: atan(z of the rear of the initial mass's base / horizontal distance from it to
  the distal end), the distal end lying on the board (z = 0). The rear of the base is where Fig. 9
  starts the line: the upslope end of the initial mass where it rests on the slope (`rear_of_base`;
  for the experiment's box filled as a slab, the upper end of the box's base, about (−1.41, 1.41) m).

- bodies on the slope: bodies whose centre came to rest upslope of the toe (x < 0), all bodies counted.

Outliers: a few bricks that bounce far ahead would set L, R and W alone. The deposit is therefore
the largest cluster of bodies whose centres are linked when closer than `link_distance` (default:
3 × the largest body diameter), a density criterion; bodies outside it are reported as outliers, and the raw extents
over all bodies are reported beside the clustered ones. Extents include each body's bounding radius.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from orchestrator.post.lost import require_bodies


@dataclass(frozen=True)
class DepositMetrics:
    length: float
    runout: float
    width: float
    height: float
    x_cm: float
    travel_angle_cm_deg: float
    fahrboschung_deg: float
    length_raw: float
    runout_raw: float
    width_raw: float
    bodies_in_deposit: int
    outliers: int
    bodies_on_slope: int = 0  # centres upslope of the toe (x < 0)
    bodies_lost: int = 0  # left the simulation domain (off a board's edge, say): in no other figure

    def as_dict(self) -> dict[str, float]:
        return {key: float(value) for key, value in asdict(self).items()}


def main_cluster(points: np.ndarray, link_distance: float) -> np.ndarray:
    """Boolean mask of the largest group of points connected by links shorter than link_distance."""
    if len(points) == 1:
        return np.ones(1, dtype=bool)
    pairs = cKDTree(points).query_pairs(link_distance, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(points), len(points)))
    _, labels = connected_components(graph, directed=False)
    return labels == np.bincount(labels).argmax()


def deposit_members(final: np.ndarray, radius: np.ndarray, link_distance: float | None = None) -> np.ndarray:
    """(B,) bool: the bodies of the deposit, the largest cluster of final centres (B, 3) linked when
    closer than link_distance (default 6 × the largest bounding radius); lost bodies (NaN) are out."""
    present = np.isfinite(final).all(axis=1)
    link = link_distance if link_distance is not None else 6.0 * float(radius.max())
    keep = np.zeros(len(final), dtype=bool)
    keep[np.flatnonzero(present)[main_cluster(final[present], link)]] = True
    return keep


def deposit_metrics(
    initial: np.ndarray,
    final: np.ndarray,
    mass: np.ndarray,
    radius: np.ndarray,
    link_distance: float | None = None,
    slope_deg: float = 45.0,
) -> DepositMetrics:
    """Metrics from initial and final body centres (B, 3) in the frame described in the module docstring,
    on a slope of `slope_deg` (°) ending at the toe x = 0; NoBodyLeft (a ValueError) when every body
    was lost."""
    require_bodies(final, "deposit")
    present = np.isfinite(final).all(axis=1)
    keep = deposit_members(final, radius, link_distance)
    x, y, z, r = final[:, 0], final[:, 1], final[:, 2], radius

    def extents(mask: np.ndarray) -> tuple[float, float, float, float]:
        x_min, x_max = float(np.min(x[mask] - r[mask])), float(np.max(x[mask] + r[mask]))
        return x_min, x_max, float(np.max(y[mask] + r[mask]) - np.min(y[mask] - r[mask])), float(np.max(z[mask] + r[mask]))

    proximal, distal, width, height = extents(keep)
    proximal_raw, distal_raw, width_raw, _ = extents(present)
    weights = mass[keep]
    cm_final = (final[keep] * weights[:, None]).sum(axis=0) / weights.sum()
    cm_initial = (initial[keep] * weights[:, None]).sum(axis=0) / weights.sum()
    travel = math.hypot(cm_final[0] - cm_initial[0], cm_final[1] - cm_initial[1])
    rear_x, rear_z = rear_of_base(initial, radius, slope_deg)
    to_distal = distal - rear_x  # the distal end lies on the board, at z = 0
    return DepositMetrics(
        length=distal - proximal,
        runout=distal,
        width=width,
        height=height,
        x_cm=float(cm_final[0]),
        travel_angle_cm_deg=math.degrees(math.atan2(cm_initial[2] - cm_final[2], travel)),
        fahrboschung_deg=math.degrees(math.atan2(rear_z, to_distal)),
        length_raw=distal_raw - proximal_raw,
        runout_raw=distal_raw,
        width_raw=width_raw,
        bodies_in_deposit=int(keep.sum()),
        outliers=int(present.sum() - keep.sum()),
        bodies_on_slope=int((x[present] < 0.0).sum()),
        bodies_lost=int((~present).sum()),
    )


def slope_coordinates(points: np.ndarray, slope_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """(s, n) of points (B, 3): s the distance up the slope from the toe, n the height above the
    slope's plane (m), for a slope of `slope_deg` (°) rising from the toe x = 0 towards −x."""
    a = math.radians(slope_deg)
    x, z = points[:, 0], points[:, 2]
    return -x * math.cos(a) + z * math.sin(a), x * math.sin(a) + z * math.cos(a)


def rear_of_base(initial: np.ndarray, radius: np.ndarray, slope_deg: float) -> tuple[float, float]:
    """(x, z) of the rear end of the initial mass where it rests on the slope (m): Fig. 9 of the
    2012 study draws the fahrböschung from there (the upper end of the release box's base).

    The base is the bodies whose centre lies within one body diameter of the slope's plane; the
    rear is the furthest upslope reach of their bounding spheres, taken on the slope. initial
    (B, 3) centres (NaN rows ignored), radius (B,) bounding radii; (NaN, NaN) when no body rests on
    the slope (a mass released from the flat has no such point, and no fahrböschung).
    """
    present = np.isfinite(initial).all(axis=1)
    s, n = slope_coordinates(initial[present], slope_deg)
    r = radius[present]
    base = (n <= 2.0 * r) & (s > 0.0)
    if not base.any():
        return math.nan, math.nan
    rear = float(np.max(s[base] + r[base]))
    a = math.radians(slope_deg)
    return -rear * math.cos(a), rear * math.sin(a)


def thickness_map(points: np.ndarray, radii: np.ndarray, slope_deg: float, cell: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gridded deposit thickness, as fringe projection measures it: (x edges (nx + 1,), y edges
    (ny + 1,), thickness (nx, ny), m, NaN where no body), the highest sphere top in each cell of size
    `cell` above the ground: the board (z = 0) for x ≥ 0, the slope (z = −x tan α) for x < 0.

    points (S, 3): sphere centres in the frame of this module; radii (S,).
    """
    x, y = points[:, 0], points[:, 1]
    height = points[:, 2] + radii - np.where(x < 0.0, -x * math.tan(math.radians(slope_deg)), 0.0)
    x_edges = np.arange(math.floor(x.min() / cell) * cell, x.max() + cell, cell)
    y_edges = np.arange(math.floor(y.min() / cell) * cell, y.max() + cell, cell)
    i = np.clip(np.searchsorted(x_edges, x, side="right") - 1, 0, len(x_edges) - 2)
    j = np.clip(np.searchsorted(y_edges, y, side="right") - 1, 0, len(y_edges) - 2)
    grid = np.full((len(x_edges) - 1, len(y_edges) - 1), np.nan)
    np.fmax.at(grid, (i, j), height)
    return x_edges, y_edges, grid

