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

from orchestrator import physics
from orchestrator.case import Case, CaseError, RectangleWall
from orchestrator.results import Trajectory
from orchestrator.engines import common
from orchestrator.engines.checkpoint import Resume, segment_name
from orchestrator.engines.base import AdapterDefaults, EngineError, EngineInfo, ProgressCallback, run_engine

DECK_NAME = "cocd.json"
FRAMES_NAME = "frames.npy"
INSTALL_HINT = ".venv/bin/pip install clarabel scs piqp"


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
        try:
            version = "clarabel " + metadata.version("clarabel")
        except metadata.PackageNotFoundError:
            version = None
        return EngineInfo(name="cocd", executable=sys.executable, version=version, install_hint=INSTALL_HINT)

    def write_input(self, case: Case, case_dir: Path, rundir: Path, resume: Resume | None = None) -> Path:
        self.segment = resume.segment if resume else 0
        walls = []
        for i, wall in enumerate(case.walls):
            if not isinstance(wall, RectangleWall):
                raise CaseError(f"walls.{i}: the cocd engine takes rectangle walls only")
            if abs(float(np.dot(wall.edge1, wall.edge2))) > 1e-9 * float(np.linalg.norm(wall.edge1) * np.linalg.norm(wall.edge2)):
                raise CaseError(f"walls.{i}: the cocd engine needs a rectangle's edges at right angles")
        plan = physics.schedule(case)
        materials = [m.name for m in case.materials]
        index = {name: k for k, name in enumerate(materials)}
        mu = np.zeros((len(materials), len(materials)))
        for pair in case.contacts:
            a, b = (index[name] for name in pair.materials)
            mu[a, b] = mu[b, a] = pair.mu
        removal = physics.removal_steps(case, plan)
        for wall in case.walls:
            walls.append({
                "name": wall.name, "origin": list(wall.origin), "edge1": list(wall.edge1), "edge2": list(wall.edge2),
                "mu": [float(mu[index[wall.material], k]) for k in range(len(materials))],
                "remove_step": removal.get(wall.name),
            })
        bodies = []
        for sphere in case.bodies.spheres:
            mass = physics.sphere_mass(sphere, case.material(sphere.material).density)
            bodies.append([mass, sphere.radius, *sphere.position, *sphere.velocity, *sphere.angular_velocity,
                           index[sphere.material], 1.0 if sphere.fixed else 0.0])
        deck = {
            "name": case.name,
            "dt": plan.dt,
            "total_steps": plan.total_steps,
            "output_every": plan.output_every,
            "solver": case.cocd.solver,
            "tolerance": case.cocd.tolerance,
            "gravity": list(case.gravity),
            "planar": case.planar,
            "mu": mu.tolist(),
            "walls": walls,
            "bodies": bodies,
            "frames": segment_name(FRAMES_NAME, self.segment),
            "rest": common.rest_settings(case, plan),
            "checkpoint_every": self.checkpoint_steps(case, plan),
            "resume": resume.file if resume else None,
        }
        path = rundir / segment_name(DECK_NAME, self.segment)
        path.write_text(json.dumps(deck) + "\n")  # data only: the runner is fixed code
        return path

    def execute(self, case: Case, rundir: Path, progress: ProgressCallback | None = None, timeout: float | None = None) -> None:
        deck = rundir / segment_name(DECK_NAME, self.segment)
        end_time = physics.schedule(case).end_time
        command = [sys.executable, "-u", "-m", "orchestrator.engines.cocd", deck.name]
        env = dict(os.environ)
        env["PYTHONPATH"] = str(Path(__file__).resolve().parents[3]) + (":" + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        tail = run_engine(command, rundir, deck, _progress, end_time, progress, env=env, timeout=timeout,
                          failure_markers=("ERROR", "Traceback"), log_name=self.log_name())
        if not any(line.startswith("DEMORCH_DONE") for line in tail):
            raise EngineError("cocd ended without finishing", deck, rundir / self.log_name(), tail)

    def read_output(self, case: Case, rundir: Path) -> Trajectory:
        return common.frame_stream_trajectory(case, rundir, FRAMES_NAME, rundir / DECK_NAME, "cocd", orientation_tracked=False)

    def last_frame_step(self, case: Case, rundir: Path) -> int | None:
        return common.last_stream_step(rundir, FRAMES_NAME, physics.schedule(case).dt)
