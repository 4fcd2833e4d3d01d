"""What the adapters share once a run is planned (orchestrator.plan): pair matrices, frame streams, the rest marker."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from orchestrator import physics
from orchestrator.case import Case
from orchestrator.plan import RunPlan
from orchestrator.results import Trajectory


def pair_matrices(case: Case, pairs: Sequence[physics.PairConstants]) -> dict[str, list[float]]:
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


AT_REST_MARKER = "DEMORCH_AT_REST"


def at_rest_attrs(rundir: Path, dt: float) -> dict[str, float]:
    """{'stopped_at_rest': time, 'rest_speed': m/s} when the engine ended the run at rest (its log says
    `DEMORCH_AT_REST step N speed v` or `... time t speed v`), else {}. Only the log's tail is read."""
    from orchestrator.engines.base import LOG_NAME, log_tail
    from orchestrator.engines.checkpoint import segment_files

    logs = segment_files(rundir, LOG_NAME)
    if not logs:
        return {}
    for line in reversed(log_tail(logs[-1], 65536)):  # the last segment's log
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


def frame_stream_trajectory(plan: RunPlan, rundir: Path, frames_name: str, deck: Path, engine: str, orientation_tracked: bool) -> Trajectory:
    """The Trajectory of a run whose engine appended (time, (bodies, 16) rows) frames with numpy.save:
    id, mass, radius, position, velocity, angular velocity, orientation (w, x, y, z)."""
    from orchestrator.engines.base import LOG_NAME, EngineError

    dt = plan.schedule.dt
    times, rows = read_segment_frames(rundir, frames_name, dt)
    if not rows:
        raise EngineError(f"{engine} wrote no frames", deck, rundir / LOG_NAME)
    stack = np.stack(rows)
    return Trajectory(
        time=np.asarray(times),
        ids=stack[0, :, 0].astype(np.int64),
        material=plan.materials(),
        mass=stack[0, :, 1].copy(),
        radius=stack[0, :, 2].copy(),
        inertia=plan.inertia(),
        position=stack[:, :, 3:6],
        velocity=stack[:, :, 6:9],
        angular_velocity=stack[:, :, 9:12],
        orientation=stack[:, :, 12:16],
        attrs={"orientation_tracked": orientation_tracked, **at_rest_attrs(rundir, dt)},
    )
