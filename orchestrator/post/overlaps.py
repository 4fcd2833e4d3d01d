"""The overlap audit of a run of shaped bodies: how deep bodies sit in each other and in the walls,
saved frame by saved frame, measured on their exact shapes (shapes/overlap.py), not by the engine.

A contact law lets bodies overlap a little: a brick resting under a pile by its load over k_n
(microns), an impact by about v √(m / k_n) (a millimetre for a brick landing at 2 m/s on k_n 2e4
N/m). A rounded box overlapping another by more than the two roundings (r_A + r_B, 2 mm for the
study's brick, a quarter of its 8 mm thickness) has its inner box in the other's: no contact model of
a rounded surface describes that any more, and a pair left so is two bodies inside each other. So
the audit flags an overlap beyond NESTED_FRACTION of the thinner body's thickness (its smallest
extent): `nested` in the record, a warning naming the pair and the time, and a packing whose last
frame holds such a pair is not used for a release (studies/avalanche).

Record (run.json `overlaps`): the bound (m); the largest body–body and body–wall overlap (m), with
when (s) and which bodies (results.h5 indices) or wall; the same per saved frame; the nested pairs
found (at most MAX_LISTED, the deepest first) and how many the last frame holds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from scipy.spatial import cKDTree

from orchestrator.shapes import BodyShape
from orchestrator.shapes.rigid import quaternion_matrices
from orchestrator.shapes.overlap import box_overlap, pair_overlap

NESTED_FRACTION = 0.25  # of the thinner body's smallest extent: the study's brick's two roundings, 2 mm
MAX_LISTED = 10
CHUNK = 1024  # pairs measured exactly at once


def nested_bound(shapes: Sequence[BodyShape]) -> float:
    """m: the overlap beyond which two of these shapes count as nested (see the module docstring)."""
    return NESTED_FRACTION * min(float(s.extent.min()) for s in shapes)


@dataclass(frozen=True)
class _Bodies:
    """What the audit reads of each body, once: its shape's index among the distinct shapes, its
    bounding radius (m), its outer box's half extents (m) and centroid offset (m, body frame)."""

    distinct: tuple[BodyShape, ...]
    kind: np.ndarray
    reach: np.ndarray
    half: np.ndarray
    offset: np.ndarray

    @classmethod
    def of(cls, shapes: Sequence[BodyShape]) -> "_Bodies":
        distinct = tuple({id(s): s for s in shapes}.values())
        index = {id(s): k for k, s in enumerate(distinct)}
        kind = np.array([index[id(s)] for s in shapes], dtype=np.int64)
        table = lambda f: np.array([f(s) for s in distinct])[kind]  # noqa: E731
        return cls(distinct, kind, table(lambda s: s.bounding_radius), table(lambda s: s.extent / 2.0), table(lambda s: s.centroid_offset))


def _frame_pairs(bodies: _Bodies, centres: np.ndarray, rotations: np.ndarray, floor: float) -> tuple[np.ndarray, np.ndarray]:
    """(pairs (p, 2), overlaps (p,)) of one frame: every pair whose overlap may exceed the deepest
    found or `floor` (m), measured exactly; the rest are bounded above by their outer boxes."""
    none = np.zeros((0, 2), dtype=np.int64), np.zeros(0)
    alive = np.flatnonzero(np.isfinite(centres).all(axis=1))
    if len(alive) < 2:
        return none
    pairs = alive[cKDTree(centres[alive]).query_pairs(2.0 * float(bodies.reach.max()), output_type="ndarray")]
    pairs = pairs[np.linalg.norm(centres[pairs[:, 0]] - centres[pairs[:, 1]], axis=1) < bodies.reach[pairs].sum(axis=1)]
    if not len(pairs):
        return none
    middles = centres - np.einsum("bkl,bl->bk", rotations, bodies.offset)
    a, b = pairs[:, 0], pairs[:, 1]
    upper = box_overlap(middles[a], rotations[a], bodies.half[a], middles[b], rotations[b], bodies.half[b])  # the solids lie in their boxes
    order = np.argsort(-upper)
    pairs, upper = pairs[order], upper[order]
    measured, best = [], -np.inf
    for start in range(0, len(pairs), CHUNK):
        if upper[start] <= min(max(best, 0.0), floor):
            break
        chunk = pairs[start:start + CHUNK]
        depth = np.empty(len(chunk))
        kinds = bodies.kind[chunk]
        for ka, kb in {(int(x), int(y)) for x, y in kinds}:
            members = (kinds[:, 0] == ka) & (kinds[:, 1] == kb)
            i, j = chunk[members, 0], chunk[members, 1]
            depth[members] = pair_overlap(bodies.distinct[ka], bodies.distinct[kb], centres[i], rotations[i], centres[j], rotations[j])
        measured.append((chunk, depth))
        best = max(best, float(depth.max()))
    if not measured:
        return none
    return np.concatenate([m[0] for m in measured]), np.concatenate([m[1] for m in measured])


def _frame_walls(bodies: _Bodies, centres: np.ndarray, rotations: np.ndarray, triangles: np.ndarray) -> tuple[float, int]:
    """(deepest overlap (m), body) of the bodies in one wall's triangles (t, 3, 3) in one frame: each
    body's probes past the plane of a triangle they stand over, on the side of the body's centre."""
    alive = np.flatnonzero(np.isfinite(centres).all(axis=1))
    if not len(alive) or not len(triangles):
        return -np.inf, -1
    centroids = triangles.mean(axis=1)
    circum = float(np.linalg.norm(triangles - centroids[:, None, :], axis=2).max())
    near = cKDTree(centroids).query_ball_point(centres[alive], float(bodies.reach.max()) + circum)
    counts = np.fromiter((len(found) for found in near), dtype=np.int64, count=len(near))
    if not counts.sum():
        return -np.inf, -1
    body = np.repeat(alive, counts)
    tri = triangles[np.concatenate([found for found in near if found]).astype(np.int64)]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    height = np.einsum("tk,tk->t", centres[body] - tri[:, 0], normal)
    keep = np.abs(height) < bodies.reach[body]
    body, tri, normal = body[keep], tri[keep], normal[keep] * np.where(height[keep] < 0.0, -1.0, 1.0)[:, None]
    worst, who = -np.inf, -1
    for k in np.unique(bodies.kind[body]):
        members = np.flatnonzero(bodies.kind[body] == k)
        points, radii = bodies.distinct[k].probes
        world = np.einsum("ckl,vl->cvk", rotations[body[members]], points) + centres[body[members]][:, None, :]
        rel = world - tri[members, 0][:, None, :]
        signed = np.einsum("cvk,ck->cv", rel, normal[members])
        foot = rel - signed[..., None] * normal[members][:, None, :]  # the probes' feet on the plane
        edges = tri[members][:, [1, 2, 0]] - tri[members]
        starts = tri[members] - tri[members, 0][:, None, :]
        inside = np.ones(signed.shape, dtype=bool)
        for e in range(3):
            side = np.einsum("cvk,ck->cv", np.cross(edges[:, e][:, None, :], foot - starts[:, e][:, None, :]), normal[members])
            inside &= side >= -1e-12
        depth = np.where(inside, radii[None, :] - signed, -np.inf).max(axis=1)
        best = int(np.argmax(depth))
        if depth[best] > worst:
            worst, who = float(depth[best]), int(body[members[best]])
    return worst, who


def audit(shapes: Sequence[BodyShape], first_body: int, time: np.ndarray, position: np.ndarray, orientation: np.ndarray,
          walls: Sequence[tuple[str, np.ndarray, float | None]]) -> dict[str, Any]:
    """The audit record (see the module docstring) of shaped bodies `shapes` (one per body, results.h5
    bodies first_body…), from frames `time` (F,) s, `position` (F, N, 3) m and `orientation` (F, N, 4)
    (w, x, y, z) of all N bodies; `walls`: (name, triangles (t, 3, 3) m, removal time s or None)."""
    n = len(shapes)
    bound = nested_bound(shapes)
    bodies = _Bodies.of(shapes)
    pair_series, wall_series = [], []
    pair_best: dict[str, Any] = {"overlap_m": None}
    wall_best: dict[str, Any] = {"overlap_m": None}
    nested: list[dict[str, Any]] = []
    last_nested = 0
    for f, t in enumerate(time):
        centres = position[f, first_body:first_body + n]
        quaternions = orientation[f, first_body:first_body + n]
        rotations = quaternion_matrices(np.where(np.isfinite(quaternions).all(axis=1)[:, None], quaternions, [1.0, 0.0, 0.0, 0.0]))
        pairs, depth = _frame_pairs(bodies, centres, rotations, bound)
        deepest = float(depth.max()) if len(depth) else None
        pair_series.append(deepest)
        if deepest is not None and (pair_best["overlap_m"] is None or deepest > pair_best["overlap_m"]):
            k = int(np.argmax(depth))
            pair_best = {"overlap_m": deepest, "time_s": float(t), "bodies": [int(first_body + v) for v in pairs[k]]}
        over = np.flatnonzero(depth > bound)
        last_nested = len(over)
        nested += [{"time_s": float(t), "bodies": [int(first_body + v) for v in pairs[k]], "overlap_m": float(depth[k])} for k in over]
        standing = [(name, triangles) for name, triangles, removed in walls if removed is None or t < removed]
        frame_wall = [(*_frame_walls(bodies, centres, rotations, triangles), name) for name, triangles in standing]
        worst = max(frame_wall, default=(-np.inf, -1, ""), key=lambda w: w[0])
        wall_series.append(worst[0] if np.isfinite(worst[0]) else None)
        if np.isfinite(worst[0]) and (wall_best["overlap_m"] is None or worst[0] > wall_best["overlap_m"]):
            wall_best = {"overlap_m": worst[0], "time_s": float(t), "body": first_body + worst[1], "wall": worst[2]}
    # a pair nested over many frames: its deepest frame once
    deepest_of: dict[tuple[int, int], dict[str, Any]] = {}
    for entry in nested:
        key = tuple(entry["bodies"])
        if key not in deepest_of or entry["overlap_m"] > deepest_of[key]["overlap_m"]:
            deepest_of[key] = entry
    listed = sorted(deepest_of.values(), key=lambda e: -e["overlap_m"])
    return {
        "bound_m": bound,
        "pairs": pair_best,
        "walls": wall_best,
        "nested_pairs": len(deepest_of),
        "nested": listed[:MAX_LISTED],
        "nested_at_end": last_nested,
        "per_frame": {"time_s": [float(t) for t in time], "pair_m": pair_series, "wall_m": wall_series},
    }


def warnings(record: dict[str, Any]) -> list[str]:
    """One line per kind of breach in an audit record: nested bodies, a body deep in a wall."""
    bound = record["bound_m"]
    lines = []
    if record["nested_pairs"]:
        worst = record["nested"][0]
        i, j = worst["bodies"]
        lines.append(f"bodies {i} and {j} overlap by {worst['overlap_m'] * 1e3:.2f} mm at t = {worst['time_s']:.4g} s, more than "
                     f"{bound * 1e3:.2g} mm (a quarter of the thinnest body): {record['nested_pairs']} pair(s) nested at some frame, "
                     f"{record['nested_at_end']} at the end (run.json overlaps)")
    wall = record["walls"]
    if wall["overlap_m"] is not None and wall["overlap_m"] > bound:
        lines.append(f"body {wall['body']} is {wall['overlap_m'] * 1e3:.2f} mm into wall {wall['wall']!r} at t = {wall['time_s']:.4g} s, "
                     f"more than {bound * 1e3:.2g} mm (run.json overlaps)")
    return lines


def refusal(record: dict[str, Any], what: str) -> str | None:
    """One line refusing to start from the last frame of a run whose audit record finds bodies nested
    there (`what` names the run, e.g. "packing /path"), or None when it holds none."""
    if not record.get("nested_at_end"):
        return None
    at_end = [e for e in record["nested"] if e["time_s"] == record["per_frame"]["time_s"][-1]] or record["nested"]
    i, j = at_end[0]["bodies"]
    return (f"{what}: {record['nested_at_end']} pair(s) of bodies nested in its last frame (bodies {i} and {j} overlap by "
            f"{at_end[0]['overlap_m'] * 1e3:.2f} mm, more than {record['bound_m'] * 1e3:.2g} mm); nothing is released from it "
            "(run.json overlaps lists them; a stiffer contact while packing, packing.contacts, keeps bodies apart)")


def summary(record: dict[str, Any]) -> dict[str, Any]:
    """An audit record without its per-frame series (what a study's report carries)."""
    return {key: value for key, value in record.items() if key != "per_frame"}
