"""Physical checks of a valid case before any engine starts: what the field ranges cannot see.

Each check raises CaseError with one line naming the field (and the body, by index) and what would
do instead:
- the time step, given or automatic, within (0, MAX_STEP] and at most MAX_STEPS steps; against the
  shortest contact duration: an explicit engine needs several steps per contact (MAX_STEP_FRACTION),
  or contacts are skipped and bodies leave at any speed;
- initial speeds against the step: no point of a body (its spin's surface speed included) may cross
  more than a tenth of the smallest radius per step;
- the output: frame count and results size (contacts included), capped (MAX_FRAMES, MAX_RESULTS_BYTES);
  what the machine can hold is checked where the run directory is known (estimate.check_machine);
- the geometry: spheres overlapping each other (coincident ones included), spheres cut by a wall,
  shaped bodies (clumps, superquadrics) overlapping or cut by a wall (preflight_shapes), bodies
  outside an explicit domain;
- the initial state: a state file the engine wrote (`save_state`) for a completed run.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.spatial import cKDTree

from orchestrator import physics
from orchestrator.case import Case, CaseError
from orchestrator.estimate import OutputEstimate
from orchestrator.capabilities import capabilities
from orchestrator.preflight_shapes import check_shaped_bodies
from orchestrator.results import CASE_COPY, read_json
from orchestrator.rundir import read_record

MAX_STEP_FRACTION = 0.1  # of the shortest contact duration: 10 steps per contact at the least
MAX_TRAVEL_PER_STEP = 0.1  # of the smallest body radius
MAX_STEP = 1e-2  # s, as time.step allows: the automatic step is held to it too
MAX_STEPS = 2**31 - 1  # LIGGGHTS (after LAMMPS) refuses `run N` beyond a 32-bit count
OUTPUT_ROUNDING = 0.01  # an output interval rounded to whole steps by more than this fraction is reported
MAX_FRAMES = 1_000_000
MAX_RESULTS_BYTES = 4 * 2**30  # results.h5 holds 13 doubles per body and frame
# Of the smaller radius: a settled packing carries its contact overlaps (m g / k_n, about 1e-3 of a
# radius in the shipped set-ups) into the release; coincident or deeply nested spheres are typos.
OVERLAP_TOLERANCE = 0.05
TRIANGLE_CHUNK = 100_000  # triangles measured at once against the spheres (bounds the memory of a large mesh)


def check_all(case: Case, case_dir: Path, plan: physics.Schedule, table: Sequence[physics.BodyInfo],
              triangles: Sequence[np.ndarray], output: OutputEstimate) -> None:
    """Raise CaseError for the first problem found; return when the case is fit to run.

    Called by `orchestrator.plan.make_plan` with the numbers the run will use (its schedule, body
    table, wall triangles (one (t, 3, 3) array per wall) and output estimate), so they are computed once."""
    check_step(case, plan)
    check_output(case, output)
    check_speeds(case, plan.dt, table)
    check_geometry(case, table, triangles)
    check_initial_state(case, case_dir)


def check_step(case: Case, plan: physics.Schedule) -> None:
    dt = plan.dt
    if not 0.0 < dt <= MAX_STEP:  # the automatic step of very soft contacts (contacts.0.kn 1e-300 gave 8e146 s)
        index, pair = max(enumerate(case.contacts), key=lambda item: item[1].kn)
        raise CaseError(f"contacts.{index}.kn: {pair.kn!r} N/m makes the automatic time.step {dt:.3g} s; allowed range of the "
                        f"step: (0, {MAX_STEP:g}] s: stiffen the contacts or give time.step")
    if plan.total_steps > MAX_STEPS:
        raise CaseError(f"time.duration: {case.time.duration!r} s is {plan.total_steps:.3g} steps of {dt:.3g} s; allowed: at most "
                        f"{MAX_STEPS} steps (the engines count steps in 32 bits), a duration of at most {MAX_STEPS * dt:.4g} s at this step")
    if case.time.step == "auto" or capabilities(case.engine).implicit:
        return
    duration = physics.shortest_contact_duration(case)
    if dt > MAX_STEP_FRACTION * duration:
        raise CaseError(f"time.step: {dt!r} s is more than {MAX_STEP_FRACTION:g} of the shortest contact ({duration:.3g} s), "
                        f"so contacts would be missed; allowed range: (0, {MAX_STEP_FRACTION * duration:.3g}] (or step: auto)")


def notes(case: Case, plan: physics.Schedule) -> list[str]:
    """What a valid case gets from its schedule `plan` that differs from what it asks, as one-line
    warnings: an output interval that is not a whole number of steps is rounded to one (one at the least)."""
    used = plan.output_every * plan.dt
    if abs(used - case.time.output_interval) <= OUTPUT_ROUNDING * case.time.output_interval:
        return []
    return [f"time.output_interval: {case.time.output_interval!r} s is not a whole number of steps of {plan.dt:.4g} s; "
            f"a frame is written every {plan.output_every} step{'s' if plan.output_every > 1 else ''} ({used:.4g} s), "
            f"{plan.frames + 1} frames in all"]


def check_output(case: Case, output: OutputEstimate) -> None:
    """At most MAX_FRAMES frames and MAX_RESULTS_BYTES of results (contacts included), whatever the machine."""
    frames, size = output.frames, output.results
    if frames > MAX_FRAMES or size > MAX_RESULTS_BYTES:
        per_frame = size / frames
        smallest = case.time.duration / min(MAX_FRAMES - 1, MAX_RESULTS_BYTES / per_frame - 1)
        raise CaseError(f"time.output_interval: {case.time.output_interval!r} s gives {frames} frames ({size / 2**30:.3g} GB of results"
                        f"{', contacts included' if case.record_contacts else ''}); allowed: at most {MAX_FRAMES} frames and "
                        f"{MAX_RESULTS_BYTES // 2**30} GB, an interval of at least {smallest:.3g} s")


def check_speeds(case: Case, dt: float, table: Sequence[physics.BodyInfo]) -> None:
    """No point of a body's surface may cross more than MAX_TRAVEL_PER_STEP of the smallest radius in
    one step: its speed is at most |v| + |ω| × its bounding radius (the spin's surface speed)."""
    if capabilities(case.engine).implicit:  # contact dynamics finds contacts over the whole step
        return
    smallest = min(b.radius for b in table)
    allowed = MAX_TRAVEL_PER_STEP * smallest / dt  # m/s
    spins = [s.angular_velocity for s in case.bodies.spheres] + [c.angular_velocity for c in case.bodies.clumps]  # table order
    for index, (body, omega) in enumerate(zip(table, spins)):
        speed = float(np.linalg.norm(body.velocity))
        spin = float(np.linalg.norm(omega))
        if speed * dt > MAX_TRAVEL_PER_STEP * smallest:
            raise CaseError(f"{_body_field(case, index)}.velocity: {speed:.3g} m/s crosses {speed * dt:.3g} m per step, more than "
                            f"{MAX_TRAVEL_PER_STEP:g} of the smallest radius ({smallest:.3g} m); allowed: at most {allowed:.3g} m/s at this step")
        surface = speed + spin * body.radius
        if surface * dt > MAX_TRAVEL_PER_STEP * smallest:
            raise CaseError(f"{_body_field(case, index)}.angular_velocity: {spin:.3g} rad/s moves the surface at up to {surface:.3g} m/s "
                            f"(|v| + |ω| × the bounding radius, {body.radius:.3g} m), crossing {surface * dt:.3g} m per step, more than "
                            f"{MAX_TRAVEL_PER_STEP:g} of the smallest radius ({smallest:.3g} m); allowed: |ω| at most "
                            f"{(allowed - speed) / body.radius:.3g} rad/s at this step")


def check_geometry(case: Case, table: Sequence[physics.BodyInfo], wall_triangles: Sequence[np.ndarray]) -> None:
    spheres = case.bodies.spheres
    if spheres:
        centres = np.array([s.position for s in spheres])
        radii = np.array([s.radius for s in spheres])
        glued = np.array([s.fixed for s in spheres])
        _check_overlaps(centres, radii, glued)
        for wall, triangles in zip(case.walls, wall_triangles):
            gaps = np.where(glued, np.inf, _distance_to_triangles(centres, triangles, float(radii.max())) - radii)  # glued: never moved by a wall
            worst = int(np.argmin(gaps))
            if gaps[worst] < -OVERLAP_TOLERANCE * radii[worst]:
                raise CaseError(f"bodies.spheres.{worst}.position: the sphere cuts wall {wall.name!r} by {-gaps[worst]:.3g} m; "
                                "move it off the wall (a sphere may touch a wall, not cross it)")
    check_shaped_bodies(case, wall_triangles)
    if case.domain is not None:
        lower, upper = np.asarray(case.domain.lower), np.asarray(case.domain.upper)
        for index, body in enumerate(table):
            if np.any(np.asarray(body.position) < lower) or np.any(np.asarray(body.position) > upper):
                raise CaseError(f"{_body_field(case, index)}.position: {list(body.position)} is outside domain "
                                f"[{list(case.domain.lower)}, {list(case.domain.upper)}]; enlarge `domain:` or move the body")


def check_initial_state(case: Case, case_dir: Path) -> None:
    """`initial_state` must be the state file of a completed run of this package that saved it
    (`save_state: true`), written by the case's engine: any other file is refused, never read."""
    if case.initial_state is None:
        return
    source = case_dir / case.initial_state
    name = capabilities(case.engine).state_file
    if not source.is_file():
        raise CaseError(f"initial_state: no state file at {source} (write one with `save_state: true`)")
    record, saved = read_record(source.parent) or {}, read_json(source.parent / CASE_COPY) or {}
    if source.name != name or record.get("status") != "completed" or not saved.get("save_state"):
        raise CaseError(f"initial_state: {source} is not a state this package wrote: give the {name} of a completed run "
                        "made with `save_state: true`")


def _check_overlaps(centres: np.ndarray, radii: np.ndarray, glued: np.ndarray) -> None:
    """Spheres that can touch may not overlap (glued ones never interact with each other)."""
    tree = cKDTree(centres)
    pairs = tree.query_pairs(2.0 * float(radii.max()), output_type="ndarray")
    pairs = pairs[~(glued[pairs[:, 0]] & glued[pairs[:, 1]])] if len(pairs) else pairs
    if not len(pairs):
        return
    gaps = np.linalg.norm(centres[pairs[:, 0]] - centres[pairs[:, 1]], axis=1) - radii[pairs].sum(axis=1)
    allowed = -OVERLAP_TOLERANCE * radii[pairs].min(axis=1)
    bad = np.flatnonzero(gaps < allowed)
    if len(bad):
        i, j = (int(k) for k in pairs[bad[np.argmin(gaps[bad])]])
        raise CaseError(f"bodies.spheres.{j}.position: sphere {j} overlaps sphere {i} by {-float(gaps[bad].min()):.3g} m "
                        f"({len(bad)} overlapping pairs); spheres may touch, not overlap")


def _distance_to_triangles(points: np.ndarray, triangles: np.ndarray, reach: float) -> np.ndarray:
    """(n,) distance from each point to the nearest of the (t, 3, 3) triangles, where that is at most
    `reach`; inf where no triangle comes that close. Only the pairs a k-d tree of the points finds
    near each triangle (its centroid's ball through its vertices, widened by `reach`) are measured,
    a chunk of triangles at a time: a mesh of a million triangles takes a second or two."""
    tree, best = cKDTree(points), np.full(len(points), np.inf)
    for start in range(0, len(triangles), TRIANGLE_CHUNK):
        chunk = triangles[start:start + TRIANGLE_CHUNK]
        centroids = chunk.mean(axis=1)
        near = tree.query_ball_point(centroids, np.linalg.norm(chunk - centroids[:, None], axis=2).max(axis=1) + reach)
        counts = np.fromiter((len(found) for found in near), dtype=np.int64, count=len(near))
        if counts.sum():
            point = np.concatenate([found for found in near if found]).astype(np.int64)
            np.minimum.at(best, point, _point_triangle_distance(points[point], np.repeat(chunk, counts, axis=0)))
    return best


def _point_triangle_distance(p: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Distance from each point p (n, 3) to its triangle (n, 3, 3) (no zero areas: geometry refuses
    them): the plane inside the triangle, else the nearest edge."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    normal = np.cross(b - a, c - a)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    height = np.einsum("nk,nk->n", p - a, normal)
    foot = p - height[:, None] * normal
    inside = np.ones(len(p), bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("nk,nk->n", np.cross(v - u, foot - u), normal) >= 0.0
    edges = np.min([_point_segment_distance(p, u, v) for u, v in ((a, b), (b, c), (c, a))], axis=0)
    return np.where(inside, np.abs(height), edges)


def _point_segment_distance(p: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    d = v - u
    t = np.clip(np.einsum("nk,nk->n", p - u, d) / np.einsum("nk,nk->n", d, d), 0.0, 1.0)
    return np.linalg.norm(p - (u + t[:, None] * d), axis=1)


def _body_field(case: Case, index: int) -> str:
    count = len(case.bodies.spheres)
    return f"bodies.spheres.{index}" if index < count else f"bodies.clumps.{index - count}"
