"""COCD adapter: a JSON deck, `python -m orchestrator.engines.cocd`, the frame stream → Trajectory.

COCD (orchestrator/engines/cocd) runs in its own process like the other engines, so timeouts, logs,
progress and failure handling are the same. It takes spheres (3D) or spheres in one plane (2D,
`planar`), glued spheres, rectangle walls with orthogonal edges and wall removal; contacts are
perfectly inelastic with the pair's μ (e_n², k_n and k_t are not used: there is no stiffness).
"""

from __future__ import annotations

import json
import os
import sys
from importlib import metadata
from pathlib import Path

import numpy as np

from orchestrator.case import CaseError, RectangleWall
from orchestrator.plan import RunPlan
from orchestrator.results import Trajectory
from orchestrator.engines import common
from orchestrator.engines.checkpoint import segment_name
from orchestrator.engines.cocd.__main__ import STATS_NAME
from orchestrator.engines.cocd.solver import DISC_INERTIA
from orchestrator.engines.base import AdapterDefaults, EngineError, EngineInfo, ProgressCallback, run_engine

DECK_NAME = "cocd.json"
FRAMES_NAME = "frames.npy"
INSTALL_HINT = ".venv/bin/pip install clarabel scs piqp cvxopt"


def _progress(line: str) -> float | None:
    if line.startswith("DEMORCH_T "):
        try:
            return float(line.split()[1])
        except (IndexError, ValueError):
            return float("nan")
    return None


class CocdAdapter(AdapterDefaults):
    name = "cocd"
    checkpoint_ext = "npz"  # checkpoint.<step>.npz: the scene's arrays

    def info(self) -> EngineInfo:
        try:  # the solvers' libraries: Clarabel (3D default) and cvxopt's CHOLMOD (mehrotra, the 2D default)
            version = f"clarabel {metadata.version('clarabel')}, cvxopt {metadata.version('cvxopt')}"
        except metadata.PackageNotFoundError:
            version = None
        return EngineInfo(name="cocd", executable=sys.executable, version=version, install_hint=INSTALL_HINT)

    def write_input(self, plan: RunPlan, rundir: Path) -> Path:
        case, resume, segment = plan.case, plan.resume, plan.segment
        walls = []
        for i, wall in enumerate(case.walls):
            if not isinstance(wall, RectangleWall):
                raise CaseError(f"walls.{i}: the cocd engine takes rectangle walls only")
            if abs(float(np.dot(wall.edge1, wall.edge2))) > 1e-9 * float(np.linalg.norm(wall.edge1) * np.linalg.norm(wall.edge2)):
                raise CaseError(f"walls.{i}: the cocd engine needs a rectangle's edges at right angles")
        materials = [m.name for m in case.materials]
        index = {name: k for k, name in enumerate(materials)}
        # The same pair constants as every engine (pairs that never touch take the first pair's μ).
        mu = np.asarray(common.pair_matrices(case, plan.pairs)["mu"]).reshape(len(materials), len(materials))
        for wall in case.walls:
            walls.append({
                "name": wall.name, "origin": list(wall.origin), "edge1": list(wall.edge1), "edge2": list(wall.edge2),
                "mu": [float(mu[index[wall.material], k]) for k in range(len(materials))],
                "remove_step": plan.removals.get(wall.name),
            })
        bodies = []
        for sphere, body in zip(case.bodies.spheres, plan.bodies):
            bodies.append([body.mass, sphere.radius, *sphere.position, *sphere.velocity, *sphere.angular_velocity,
                           index[sphere.material], 1.0 if sphere.fixed else 0.0])
        schedule = plan.schedule
        deck = {
            "name": case.name,
            "dt": schedule.dt,
            "total_steps": schedule.total_steps,
            "output_every": schedule.output_every,
            "solver": case.cocd.resolved(case.planar),
            "tolerance": case.cocd.tolerance,
            "gravity": list(case.gravity),
            "planar": case.planar,
            "mu": mu.tolist(),
            "walls": walls,
            "bodies": bodies,
            "frames": segment_name(FRAMES_NAME, segment),
            "rest": plan.rest.as_dict() if plan.rest else None,
            "checkpoint_every": self.checkpoint_steps(plan),
            "resume": resume.file if resume else None,
        }
        path = rundir / segment_name(DECK_NAME, segment)
        path.write_text(json.dumps(deck) + "\n")  # data only: the runner is fixed code
        return path

    def execute(self, plan: RunPlan, rundir: Path, progress: ProgressCallback | None = None, timeout: float | None = None) -> None:
        deck = rundir / segment_name(DECK_NAME, plan.segment)
        end_time = plan.schedule.end_time
        command = [sys.executable, "-u", "-m", "orchestrator.engines.cocd", deck.name]
        env = dict(os.environ)
        env["PYTHONPATH"] = str(Path(__file__).resolve().parents[3]) + (":" + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        tail = run_engine(command, rundir, deck, _progress, end_time, progress, env=env, timeout=timeout,
                          failure_markers=("ERROR", "Traceback"), log_name=self.log_name(plan))
        if not any(line.startswith("DEMORCH_DONE") for line in tail):
            raise EngineError("cocd ended without finishing", deck, rundir / self.log_name(plan), tail)

    def engine_summary(self, plan: RunPlan, rundir: Path) -> dict[str, object]:
        """The solver's record over the run's steps (every segment; per step in cocd_stats.json): its
        name, the steps with contacts, iterations (mean, max), solver seconds and, in 2D, the largest
        of each optimality measure (solver.StepStats)."""
        try:
            stats = json.loads((rundir / STATS_NAME).read_text())
        except (OSError, ValueError):
            return {}
        solved = [k for k, count in enumerate(stats["contacts"]) if count]
        summary: dict[str, object] = {"solver": plan.case.cocd.resolved(plan.case.planar), "per_step": STATS_NAME,
                                      "steps_with_contacts": len(solved), "solver_seconds": float(sum(stats["solve_s"]))}
        if solved:
            iterations = [stats["iterations"][k] for k in solved]
            summary["iterations"] = {"mean": float(np.mean(iterations)), "max": int(max(iterations))}
            for measure in ("primal", "dual", "gap"):
                values = [stats[measure][k] for k in solved if stats[measure][k] is not None]
                if values:
                    summary[f"{measure}_max"] = float(max(values))
        return summary

    def read_output(self, plan: RunPlan, rundir: Path) -> Trajectory:
        trajectory = common.frame_stream_trajectory(plan, rundir, FRAMES_NAME, rundir / DECK_NAME, "cocd", orientation_tracked=False)
        if plan.case.planar:  # 2D grains are discs: the frames carry their mass per metre, their inertia is ½ m r² (solver.py)
            moment = DISC_INERTIA * trajectory.mass * trajectory.radius**2
            trajectory.inertia = np.repeat(moment[:, None], 3, axis=1)
        return trajectory

    def last_frame_step(self, plan: RunPlan, rundir: Path) -> int | None:
        return common.last_stream_step(rundir, FRAMES_NAME, plan.schedule.dt)
