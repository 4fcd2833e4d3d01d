"""YADE adapter: a Python script from the template, `yade -x -n`, binary frame stream → Trajectory.

The orchestrator never imports yade: Debian's `yade` runs under Debian's python3.11, whatever
Python the orchestrator uses.
"""

from __future__ import annotations

import re
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from orchestrator.shapes.clump import world_sphere_centres
from orchestrator.case import ContactLaw, RectangleWall, Sphere, Wall
from orchestrator.results import Contacts, Trajectory
from orchestrator.engines import common
from orchestrator.engines.checkpoint import segment_name
from orchestrator.plan import RunPlan
from orchestrator.engines.build import engine_version
from orchestrator.engines.base import AdapterDefaults, EngineError, EngineInfo, ProgressCallback, require_executable, run_engine
from orchestrator.engines.yade.materials import GLUED, glued_clones, glued_friction, stand_in_scale, yade_materials

SCRIPT_NAME = "script.py"
FRAMES_NAME = "frames.npy"
CONTACTS_NAME = "contacts.npy"
# checkpoint.<step>.yade: the scene saved by O.save, binary and uncompressed (half the time of .gz:
# 32 against 67 ms for 800 spheres, measured 2026-11-30; 1 MB)
CHECKPOINT_EXT = "yade"  # (time, (rows, 12) contacts) per frame, when the case records contacts
INSTALL_HINT = "apt-get install -y yade python3-yade"

_PROGRESS = re.compile(r"^DEMORCH_PROGRESS (\S+) (\S+)$")


def _progress(line: str) -> float | None:
    match = _PROGRESS.match(line)
    return float(match.group(1)) if match else None


def _blocked_dofs(sphere: Sphere, planar: bool) -> str:
    """YADE's blockedDOFs: x y z translations, X Y Z rotations."""
    blocked = "XYZ" if sphere.fixed_rotation else ""
    if planar:
        blocked = "y" + ("XYZ" if sphere.fixed_rotation else "XZ")
    return blocked


class YadeAdapter(AdapterDefaults):
    name = "yade"
    checkpoint_ext = CHECKPOINT_EXT

    def __init__(self, executable: str = "yade", threads: int = 1):
        self.executable = executable
        self.threads = threads

    def info(self) -> EngineInfo:
        path = shutil.which(self.executable)
        version = engine_version(path, ("--version",), r"Yade version:\s*(\S+)")
        return EngineInfo(name=self.name, executable=path, version=version, install_hint=INSTALL_HINT)

    def warnings(self, plan: RunPlan) -> tuple[str, ...]:
        _, warning = stand_in_scale(plan)
        return (warning,) if warning else ()

    def write_input(self, plan: RunPlan, rundir: Path) -> Path:
        from orchestrator.engines.templating import render

        case, resume, segment = plan.case, plan.resume, plan.segment
        # YADE has no bilinear law (no headers to compile one against): it runs the linear
        # spring-dashpot with the same loading stiffness and restitution (the plan's pairs carry it;
        # docs/engines.md), scaled for clumps that land on several spheres at once.
        scale, _ = stand_in_scale(plan)
        pairs = [replace(p, cn=p.cn * scale) if p.law is ContactLaw.bilinear else p for p in plan.pairs]
        as_boxes = [rectangle_box(wall) for wall in case.walls]
        boxes = [box for box in as_boxes if box is not None]
        facets = [
            (wall.name, wall.material, *[tuple(float(c) for c in vertex) for vertex in triangle])
            for wall, triangles, box in zip(case.walls, plan.wall_triangles, as_boxes)
            if box is None
            for triangle in triangles
        ]
        spheres = [
            (GLUED.format(s.material) if s.fixed else s.material, s.radius, s.position, s.velocity, s.angular_velocity,
             _blocked_dofs(s, case.planar), not s.fixed)
            for s in case.bodies.spheres
        ]
        touching = case.touching_pairs()
        friction = [(p.materials[0], p.materials[1], p.mu) for p in pairs if frozenset(p.materials) in touching]
        materials = yade_materials(case, pairs)
        clones = glued_clones(case, pairs, materials)
        friction += glued_friction(friction, [str(c["name"]) for c in clones])
        data = {
            "seed": case.seed,
            "dt": plan.schedule.dt,
            "total_steps": plan.schedule.total_steps,
            "save_state": case.save_state,
            "output_every": plan.schedule.output_every,
            "gravity": tuple(float(g) for g in case.gravity),
            "frames_file": segment_name(FRAMES_NAME, segment),
            "contacts_file": segment_name(CONTACTS_NAME, segment) if case.record_contacts else None,
            "checkpoint_every": self.checkpoint_steps(plan),
            "resume": resume.file if resume else None,
            "walls": [wall.name for wall in case.walls],
            "materials": materials + clones,
            "friction": friction,
            "spheres": spheres,
            "clumps": _clumps(plan),
            "facets": facets,
            "boxes": boxes,
            "removals": _removals(plan),
            "rest": plan.rest.as_dict() if plan.rest else None,
        }
        context = {"name": case.name, "data": data}
        script = rundir / segment_name(SCRIPT_NAME, segment)
        script.write_text(render("yade", "case.py.j2", context))
        return script

    def execute(self, plan: RunPlan, rundir: Path, progress: ProgressCallback | None = None, timeout: float | None = None) -> None:
        script = rundir / segment_name(SCRIPT_NAME, plan.segment)
        executable = require_executable(self.executable, INSTALL_HINT)
        command = [executable, f"-j{self.threads}", "-x", "-n", script.name]
        tail = run_engine(
            command, rundir, script, _progress, plan.schedule.end_time, progress, timeout=timeout, failure_markers=("ERROR", "Traceback"),
            log_name=self.log_name(plan),
        )
        if not any(line.startswith("DEMORCH_DONE") for line in tail):
            raise EngineError("YADE ended without finishing the script", script, rundir / self.log_name(plan), tail)

    def read_output(self, plan: RunPlan, rundir: Path) -> Trajectory:
        trajectory = common.frame_stream_trajectory(plan, rundir, FRAMES_NAME, rundir / SCRIPT_NAME, "YADE", orientation_tracked=True)
        if plan.case.record_contacts:
            _, rows = common.read_segment_frames(rundir, CONTACTS_NAME, plan.schedule.dt)
            trajectory.contacts = Contacts.from_frames(rows[: trajectory.n_frames])
        return trajectory

    def last_frame_step(self, plan: RunPlan, rundir: Path) -> int | None:
        return common.last_stream_step(rundir, FRAMES_NAME, plan.schedule.dt)


def _clumps(plan: RunPlan) -> list[tuple]:
    """The script's CLUMPS rows: material, sphere centres (world) and radii, centre, orientation,
    velocity, spin, true mass and principal inertia, glued."""
    rows = []
    for c, brick in zip(plan.case.bodies.clumps, plan.shapes):
        centres = world_sphere_centres(brick, np.asarray(c.position), np.asarray(c.orientation))
        rows.append((c.material, [tuple(float(v) for v in p) for p in centres], [float(r) for r in brick.radii], c.position, c.orientation,
                     c.velocity, c.angular_velocity, brick.mass, tuple(float(i) for i in brick.principal_inertia), c.fixed))
    return rows


def rectangle_box(wall: Wall) -> tuple[str, str, list[float], list[float], list[float]] | None:
    """A rectangle wall with edges at right angles as YADE's flat box (name, material, centre, half
    extents, orientation w, x, y, z); None for a mesh or a parallelogram (those stay facets)."""
    if not isinstance(wall, RectangleWall):
        return None
    a, b = np.asarray(wall.edge1, float), np.asarray(wall.edge2, float)
    la, lb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    if abs(float(a @ b)) > 1e-9 * la * lb:
        return None
    axes = np.column_stack([a / la, b / lb, np.cross(a, b) / (la * lb)])
    x, y, z, w = Rotation.from_matrix(axes).as_quat()
    centre = np.asarray(wall.origin, float) + 0.5 * (a + b)
    return (wall.name, wall.material, centre.tolist(), [0.5 * la, 0.5 * lb, 0.0], [float(w), float(x), float(y), float(z)])


def _removals(plan: RunPlan) -> list[tuple[int, list[str]]]:
    steps = plan.removals
    return [(step, sorted(n for n, at in steps.items() if at == step)) for step in sorted(set(steps.values()))]
