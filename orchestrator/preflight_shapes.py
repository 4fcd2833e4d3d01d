"""Geometry checks of shaped bodies (clumps, superquadrics, rounded boxes) before any engine starts.

Spheres have exact tests in `preflight`; a shaped body is checked through its `BodyShape`:
- overlaps: pairs whose bounding spheres meet and whose boxes (`extent`) overlap by more than the
  tolerance (separating axes: the boxes hold the solids, so a pair they clear is clear), then their
  overlap on the shapes (shapes/overlap.py `pair_overlap`: exact for two rounded boxes, else each
  body's probe spheres, a clump's own spheres or a smooth body's surface points, measured inside the
  other, both ways);
- walls: a body cut by a wall, i.e. its surface points lie on both sides of the plane of the wall
  triangle nearest its centre, that triangle under its centre.
A settled packing carries its contact overlaps into a release (m g / k_n, about a micrometre for the
bricks), so a body may sink into another or a wall by OVERLAP_TOLERANCE of its smallest half extent.
A case that starts from an engine's saved state (`initial_state`) is not checked: its bodies are
where the engine left them.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Sequence

import numpy as np
from scipy.spatial import cKDTree

from orchestrator.case import Case, CaseError
from orchestrator.shapes import BodyShape
from orchestrator.shapes.rigid import quaternion_matrices
from orchestrator.shapes.overlap import box_overlap, pair_overlap

OVERLAP_TOLERANCE = 0.05  # of the smallest half extent of the shapes involved
CHUNK = 2048  # pairs measured at once (bounds the memory: pairs × probes × the other's spheres)


def check_shaped_bodies(case: Case, wall_triangles: Sequence[np.ndarray]) -> None:
    """CaseError naming the first clump that overlaps another (`bodies.clumps.J.position`) or is cut
    by a wall; nothing for a case without clumps or started from a saved state."""
    clumps = case.bodies.clumps
    if not clumps or case.initial_state is not None:
        return
    shapes = [case.shape(c.shape).body(case.material(c.material).density) for c in clumps]
    centres = np.array([c.position for c in clumps], dtype=float)
    rotations = quaternion_matrices(np.array([c.orientation for c in clumps], dtype=float))
    fixed = np.array([c.fixed for c in clumps])
    _check_pairs(shapes, centres, rotations, fixed)
    for wall, triangles in zip(case.walls, wall_triangles):
        _check_wall(wall.name, shapes, centres, rotations, fixed, triangles)


def _tolerance(*shapes: BodyShape) -> float:
    return OVERLAP_TOLERANCE * min(float(s.extent.min()) for s in shapes) / 2.0


def _check_pairs(shapes: list[BodyShape], centres: np.ndarray, rotations: np.ndarray, fixed: np.ndarray) -> None:
    reach = np.array([s.bounding_radius for s in shapes])
    pairs = cKDTree(centres).query_pairs(2.0 * float(reach.max()), output_type="ndarray")
    if not len(pairs):
        return
    pairs = pairs[~(fixed[pairs[:, 0]] & fixed[pairs[:, 1]])]  # glued bodies never meet each other
    pairs = pairs[np.linalg.norm(centres[pairs[:, 0]] - centres[pairs[:, 1]], axis=1) < reach[pairs].sum(axis=1)]
    boxes = np.array([s.extent / 2.0 for s in shapes])
    middles = centres - np.einsum("bkl,bl->bk", rotations, np.array([s.centroid_offset for s in shapes]))
    tolerance = _tolerance(*{id(s): s for s in shapes}.values())
    pairs = pairs[box_overlap(middles[pairs[:, 0]], rotations[pairs[:, 0]], boxes[pairs[:, 0]],
                              middles[pairs[:, 1]], rotations[pairs[:, 1]], boxes[pairs[:, 1]]) > tolerance]
    groups: dict[tuple[int, int], list[int]] = defaultdict(list)  # pairs of the same two shapes, measured together
    for k, (i, j) in enumerate(pairs):
        groups[(id(shapes[i]), id(shapes[j]))].append(k)
    for members in groups.values():
        chosen = pairs[members]
        a, b = shapes[chosen[0, 0]], shapes[chosen[0, 1]]
        depth = np.concatenate([pair_overlap(a, b, centres[part[:, 0]], rotations[part[:, 0]], centres[part[:, 1]], rotations[part[:, 1]])
                                for part in np.array_split(chosen, max(1, -(-len(chosen) // CHUNK)))])
        worst = int(np.argmax(depth))
        if depth[worst] > _tolerance(a, b):
            i, j = (int(v) for v in chosen[worst])
            raise CaseError(f"bodies.clumps.{j}.position: body {j} overlaps body {i} by {depth[worst]:.3g} m "
                            f"({int((depth > _tolerance(a, b)).sum())} overlapping pairs); bodies may touch, not overlap")


def _check_wall(name: str, shapes: list[BodyShape], centres: np.ndarray, rotations: np.ndarray, fixed: np.ndarray,
                triangles: np.ndarray) -> None:
    """A body whose probes straddle the plane of the wall triangle under its centre (the nearest such),
    by more than the tolerance each way."""
    centroids = triangles.mean(axis=1)
    circum = float(np.linalg.norm(triangles - centroids[:, None, :], axis=2).max())
    near = cKDTree(centroids).query_ball_point(centres, max(s.bounding_radius for s in shapes) + circum)
    counts = np.fromiter((len(found) for found in near), dtype=np.int64, count=len(near))
    if not counts.sum():
        return
    body = np.repeat(np.arange(len(centres)), counts)
    tri = triangles[np.concatenate([found for found in near if found]).astype(np.int64)]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    height = np.einsum("tk,tk->t", centres[body] - tri[:, 0], normal)
    foot = centres[body] - height[:, None] * normal
    under = ~fixed[body]
    for u, v in ((0, 1), (1, 2), (2, 0)):
        under &= np.einsum("tk,tk->t", np.cross(tri[:, v] - tri[:, u], foot - tri[:, u]), normal) >= 0.0
    nearest_first = np.lexsort((np.abs(height), body))  # by body, nearest plane first
    order = nearest_first[under[nearest_first]]
    first = order[np.unique(body[order], return_index=True)[1]]  # each body's nearest triangle under it
    groups: dict[int, list[int]] = defaultdict(list)
    for k in first:
        groups[id(shapes[body[k]])].append(k)
    for chosen in (np.array(members) for members in groups.values()):
        shape = shapes[body[chosen[0]]]
        points, radii = shape.probes
        world = np.einsum("ckl,vl->cvk", rotations[body[chosen]], points) + centres[body[chosen]][:, None, :]
        signed = np.einsum("cvk,ck->cv", world - tri[chosen, 0][:, None, :], normal[chosen])
        low, high = (signed - radii).min(axis=1), (signed + radii).max(axis=1)
        cut = np.minimum(-low, high)
        worst = int(np.argmax(cut))
        if cut[worst] > _tolerance(shape):
            raise CaseError(f"bodies.clumps.{body[chosen[worst]]}.position: the body cuts wall {name!r} by {cut[worst]:.3g} m; "
                            "move it off the wall (a body may touch a wall, not cross it)")
