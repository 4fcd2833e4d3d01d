"""How deep two bodies are in each other, measured on their shapes (pre-flight checks and run audits).

Overlap here is the penetration depth: the shortest translation that parts the two solids (m; ≤ 0
when they are apart). Two measures:
- `swept_box_overlap`, exact for two sphere-swept boxes (rounded boxes): the solid A ⊕ ball(r_A)
  against B ⊕ ball(r_B) overlaps by r_A + r_B − d when the inner boxes are d apart, and by
  r_A + r_B + p when they interpenetrate by p. The distance d between two disjoint convex polyhedra
  is reached by a vertex of one against the other (a clamp, exact) or by two edges (closest points of
  two segments, Ericson 2005 §5.1.9); the penetration p is the least overlap of the boxes' projections
  on the 15 separating axes (face normals and edge cross products, Gottschalk et al. 1996), which are
  all the face normals of the boxes' Minkowski difference, so it is exact too.
- `probe_depth`, any shape: each body's probe spheres (`BodyShape.probes`) measured inside the other
  (`BodyShape.penetration`), both ways; exact for clumps (their probes are their spheres), within the
  surface sampling for smooth bodies.
`pair_overlap` takes the exact one where both bodies are swept boxes (`BodyShape.sweep`).
Poses: centres (p, 3) m, rotations (p, 3, 3) body → world.
"""

from __future__ import annotations

import numpy as np

# The inner box's vertices (v: bit k set = + along axis k) and its 12 edges as vertex pairs.
SIGNS = np.array([[1.0 if (v >> k) & 1 else -1.0 for k in range(3)] for v in range(8)])
EDGES = np.array([(v, v | (1 << k)) for k in range(3) for v in range(8) if not (v >> k) & 1])


def box_overlap(ca: np.ndarray, ra: np.ndarray, ha: np.ndarray, cb: np.ndarray, rb: np.ndarray, hb: np.ndarray) -> np.ndarray:
    """(p,) penetration depth of pairs of oriented boxes (m; ≤ 0: apart): the least overlap of their
    projections on the 15 separating axes (the 3 + 3 face normals and the 9 edge cross products;
    Gottschalk et al. 1996). Centres (p, 3), rotations (p, 3, 3) body → world, half extents (p, 3)."""
    axes_a, axes_b = np.swapaxes(ra, 1, 2), np.swapaxes(rb, 1, 2)  # (p, 3 axes, 3)
    crosses = np.cross(axes_a[:, :, None, :], axes_b[:, None, :, :]).reshape(-1, 9, 3)
    axes = np.concatenate([axes_a, axes_b, crosses], axis=1)  # (p, 15, 3)
    length = np.linalg.norm(axes, axis=2)
    usable = length > 1e-9  # parallel edges give no axis
    axes = axes / np.where(usable, length, 1.0)[:, :, None]
    reach_a = np.abs(np.einsum("pak,pik->pai", axes, axes_a)) @ ha[:, :, None]
    reach_b = np.abs(np.einsum("pak,pik->pai", axes, axes_b)) @ hb[:, :, None]
    gap = np.abs(np.einsum("pak,pk->pa", axes, cb - ca))
    overlap = reach_a[..., 0] + reach_b[..., 0] - gap
    return np.where(usable, overlap, np.inf).min(axis=1)


def _vertex_box_distance(points: np.ndarray, half: np.ndarray) -> np.ndarray:
    """(p, v) distance of points (p, v, 3), in a box's frame, to that box of half extents (p, 3)."""
    outside = np.maximum(np.abs(points) - half[:, None, :], 0.0)
    return np.linalg.norm(outside, axis=2)


def _segment_distances(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """(...,) distance between segments p1q1 and p2q2 (..., 3): closest points clamped to both
    (Ericson 2005, Real-Time Collision Detection §5.1.9); segments of non-zero length."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.einsum("...k,...k", d1, d1)
    e = np.einsum("...k,...k", d2, d2)
    b = np.einsum("...k,...k", d1, d2)
    c = np.einsum("...k,...k", d1, r)
    f = np.einsum("...k,...k", d2, r)
    denominator = a * e - b * b
    parallel = denominator <= 1e-12 * a * e
    s = np.where(parallel, 0.0, np.clip((b * f - c * e) / np.where(parallel, 1.0, denominator), 0.0, 1.0))
    t = (b * s + f) / e
    s = np.where(t < 0.0, np.clip(-c / a, 0.0, 1.0), np.where(t > 1.0, np.clip((b - c) / a, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    gap = (p1 + s[..., None] * d1) - (p2 + t[..., None] * d2)
    return np.linalg.norm(gap, axis=-1)


def swept_box_overlap(ca: np.ndarray, ra: np.ndarray, ha: np.ndarray, sweep_a: float,
                      cb: np.ndarray, rb: np.ndarray, hb: np.ndarray, sweep_b: float) -> np.ndarray:
    """(p,) exact overlap (m, ≤ 0 apart) of pairs of sphere-swept boxes: inner half extents ha, hb
    (3,) m, sweep radii sweep_a, sweep_b m (see the module docstring)."""
    if not len(ca):
        return np.zeros(0)
    ha_p, hb_p = np.broadcast_to(ha, ca.shape), np.broadcast_to(hb, cb.shape)
    depth = box_overlap(ca, ra, ha_p, cb, rb, hb_p)  # > 0: the inner boxes interpenetrate
    rel = np.einsum("pki,pkj->pij", ra, rb)  # B's axes in A's frame (columns)
    t = np.einsum("pki,pk->pi", ra, cb - ca)  # B's centre in A's frame
    b_in_a = t[:, None, :] + np.einsum("pij,vj->pvi", rel, SIGNS * hb)  # (p, 8, 3)
    a_in_b = np.einsum("pji,pvj->pvi", rel, (SIGNS * ha)[None, :, :] - t[:, None, :])
    vertex = np.minimum(_vertex_box_distance(b_in_a, ha_p).min(axis=1), _vertex_box_distance(a_in_b, hb_p).min(axis=1))
    a_vertices = np.broadcast_to(SIGNS * ha, b_in_a.shape)
    edges = _segment_distances(a_vertices[:, EDGES[:, 0]][:, :, None, :], a_vertices[:, EDGES[:, 1]][:, :, None, :],
                               b_in_a[:, EDGES[:, 0]][:, None, :, :], b_in_a[:, EDGES[:, 1]][:, None, :, :])
    distance = np.minimum(vertex, edges.reshape(len(ca), -1).min(axis=1))
    return sweep_a + sweep_b + np.where(depth > 0.0, depth, -distance)


def probe_depth(a, b, ca: np.ndarray, ra: np.ndarray, cb: np.ndarray, rb: np.ndarray) -> np.ndarray:
    """(p,) deepest reach of shape a's probes (bodies at ca, ra) into shape b (at cb, rb), m."""
    points, radii = a.probes
    world = np.einsum("pkl,vl->pvk", ra, points) + ca[:, None, :]
    local = np.einsum("plk,pvl->pvk", rb, world - cb[:, None, :])  # Rᵀ (x − c)
    return (b.penetration(local.reshape(-1, 3)).reshape(len(ca), -1) + radii[None, :]).max(axis=1)


def pair_overlap(a, b, ca: np.ndarray, ra: np.ndarray, cb: np.ndarray, rb: np.ndarray) -> np.ndarray:
    """(p,) overlap (m) of shape a at poses (ca, ra) with shape b at (cb, rb): exact for two swept
    boxes, else the probes both ways (see the module docstring)."""
    if a.sweep is not None and b.sweep is not None:
        return swept_box_overlap(ca, ra, a.sweep[0], a.sweep[1], cb, rb, b.sweep[0], b.sweep[1])
    return np.maximum(probe_depth(a, b, ca, ra, cb, rb), probe_depth(b, a, cb, rb, ca, ra))
