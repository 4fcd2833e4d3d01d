"""Engine-neutral preparation shared by the adapters: schedule, pair constants, wall triangles, domain."""

from __future__ import annotations

import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from orchestrator import geometry, physics
from orchestrator.case import Case, Domain
from orchestrator.results import Trajectory


@dataclass(frozen=True)
class Prepared:
    schedule: physics.Schedule
    pairs: list[physics.PairConstants]
    wall_triangles: list[np.ndarray]
    domain: Domain


def prepare(case: Case, case_dir: Path, dashpot_for_bilinear: bool = False) -> Prepared:
    plan = physics.schedule(case)
    triangles = [geometry.wall_triangles(wall, case_dir) for wall in case.walls]
    domain = case.domain or geometry.automatic_domain(case, triangles, plan.end_time)
    return Prepared(schedule=plan, pairs=physics.pair_constants(case, dashpot_for_bilinear), wall_triangles=triangles, domain=domain)


def pair_matrices(case: Case, pairs: list[physics.PairConstants]) -> dict[str, list[float]]:
    """Row-major n×n matrices (n = number of materials) of every pair constant.

    Pairs that can never touch (wall/wall) take the first listed pair's values: an engine
    wants a full matrix but never uses those entries.
    """
    names = [m.name for m in case.materials]
    by_key = {frozenset(p.materials): p for p in pairs}
    fallback = pairs[0]
    matrices: dict[str, list[float]] = {key: [] for key in ("kn", "kt", "mu", "cn", "en2")}
    for a in names:
        for b in names:
            pair = by_key.get(frozenset((a, b)), fallback)
            for key in matrices:
                matrices[key].append(float(getattr(pair, key)))
    return matrices


def body_materials(case: Case) -> np.ndarray:
    """Material of each body, in body order (both engines number bodies in case order)."""
    return np.array([b.material for b in physics.bodies(case)])


def body_masses(case: Case) -> np.ndarray:
    """Exact body masses from the case (dumps print fewer digits than the engines compute with)."""
    return np.array([b.mass for b in physics.bodies(case)])


def moving_mass(case: Case) -> float:
    """Total mass of the bodies that can move (glued spheres left out): the M of the rest criterion."""
    glued = [s.fixed for s in case.bodies.spheres] + [False] * len(case.bodies.clumps)
    return float(sum(mass for mass, fixed in zip(body_masses(case), glued) if not fixed))


def body_inertia(case: Case) -> np.ndarray:
    return np.array([b.inertia for b in physics.bodies(case)])


AT_REST_MARKER = "DEMORCH_AT_REST"


def rest_settings(case: Case, plan: physics.Schedule) -> dict[str, float | None] | None:
    """What a YADE script or cocd deck needs to stop at rest: check period and first step (whole output
    intervals), the speed threshold, the moving mass M and the stray fraction (None: the RMS criterion).
    None: run the whole duration."""
    checks = physics.rest_check_steps(case, plan)
    if checks is None:
        return None
    every, after = checks
    rest = case.time.stop_at_rest
    # The first check: at `after`, or at the last wall removal if later (a release's trap opening).
    first = max([after, *physics.removal_steps(case, plan).values()])
    return {"every": every, "after": after, "first": first, "speed": rest.speed, "mass": moving_mass(case),
            "stray_fraction": rest.stray_fraction}


def at_rest_attrs(rundir: Path, dt: float) -> dict[str, float]:
    """{'stopped_at_rest': time, 'rest_speed': m/s} when the engine ended the run at rest (its log says
    `DEMORCH_AT_REST step N speed v` or `... time t speed v`), else {}. Only the log's tail is read."""
    from orchestrator.engines.base import LOG_NAME
    from orchestrator.engines.checkpoint import segment_files

    logs = segment_files(rundir, LOG_NAME)
    if not logs:
        return {}
    log = logs[-1]  # the last segment's
    with log.open("rb") as handle:
        handle.seek(max(0, log.stat().st_size - 65536))
        tail = handle.read().decode("utf-8", "replace").splitlines()
    for line in reversed(tail):
        words = line.split()
        if len(words) == 5 and words[0] == AT_REST_MARKER:
            moment = float(words[2]) * dt if words[1] == "step" else float(words[2])
            return {"stopped_at_rest": moment, "rest_speed": float(words[4])}
    return {}


def read_frames(path: Path) -> tuple[list[float], list[np.ndarray]]:
    """Read the (time, rows) pairs the script appended with numpy.save; a cut-off tail is dropped."""
    times: list[float] = []
    rows: list[np.ndarray] = []
    if not path.exists():
        return times, rows
    with open(path, "rb") as stream:
        while True:
            try:
                time = np.load(stream, allow_pickle=False)
                state = np.load(stream, allow_pickle=False)
            except (EOFError, ValueError, OSError):
                break
            times.append(float(time[0]))
            rows.append(state)
    return times, rows


def read_segment_frames(rundir: Path, name: str, dt: float) -> tuple[list[float], list[np.ndarray]]:
    """The (time, rows) frames of every segment's stream of `name`, merged (engines.checkpoint.merge):
    each frame once, a continued run's frames replacing what the cut-off one wrote after its checkpoint."""
    from orchestrator.engines.checkpoint import merge, segment_files

    pieces = []
    for path in segment_files(rundir, name):
        times, rows = read_frames(path)
        pieces.append(([round(t / dt) for t in times], list(zip(times, rows))))
    _, frames = merge(pieces)
    return [t for t, _ in frames], [r for _, r in frames]


def last_stream_step(rundir: Path, name: str, dt: float) -> int | None:
    """The step of the newest frame of the segments' streams of `name` (None: no frame)."""
    times, _ = read_segment_frames(rundir, name, dt)
    return round(times[-1] / dt) if times else None


def package_version(package: str) -> str | None:
    """The installed version of a Debian package (dpkg-query), or None."""
    try:
        result = subprocess.run(["dpkg-query", "-W", "-f=${Version}", package], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return result.stdout.strip() or None


def frame_stream_trajectory(case: Case, rundir: Path, frames_name: str, deck: Path, engine: str, orientation_tracked: bool) -> Trajectory:
    """The Trajectory of a run whose engine appended (time, (bodies, 16) rows) frames with numpy.save:
    id, mass, radius, position, velocity, angular velocity, orientation (w, x, y, z)."""
    from orchestrator.engines.base import EngineError

    dt = physics.schedule(case).dt
    times, rows = read_segment_frames(rundir, frames_name, dt)
    if not rows:
        raise EngineError(f"{engine} wrote no frames", deck, rundir / "engine.log")
    stack = np.stack(rows)
    return Trajectory(
        time=np.asarray(times),
        ids=stack[0, :, 0].astype(np.int64),
        material=body_materials(case),
        mass=stack[0, :, 1].copy(),
        radius=stack[0, :, 2].copy(),
        inertia=body_inertia(case),
        position=stack[:, :, 3:6],
        velocity=stack[:, :, 6:9],
        angular_velocity=stack[:, :, 9:12],
        orientation=stack[:, :, 12:16],
        attrs={"orientation_tracked": orientation_tracked, **at_rest_attrs(rundir, dt)},
    )
