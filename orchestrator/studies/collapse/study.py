"""The collapse study kind: a column rained once behind its gate, released, its front and bed measured.

The skeleton (studies.base) keeps the preparation under a preparations directory (default: beside
the study's directory), so a campaign over slopes, frictions or durations of the same column rains
it once. The release's results stay in outdir/run; the report (report.json, profiles.npz) in outdir.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from orchestrator.case import Case
from orchestrator.engines import RunOptions
from orchestrator.post import collapse as cm
from orchestrator.results import Trajectory
from orchestrator.rundir import saved_case
from orchestrator.studies.base import StageProgress, StudyKind
from orchestrator.studies.collapse.fields import field_metrics, measure_fields
from orchestrator.studies.collapse.cases import preparation_case, release_case
from orchestrator.studies.collapse.spec import CollapseStudy


class CollapseKind(StudyKind):
    """A column rained behind its gate (the preparation), released down the channel, front and bed measured."""

    name = "collapse"
    model = CollapseStudy
    detect_keys = frozenset({"column", "channel", "grains", "bed"})
    preparation = "preparation"
    shared_dir = "preparations"
    lost_bodies = "some grains left the channel while settling"
    arrays_file = "profiles.npz"

    def preparation_case(self, study: CollapseStudy) -> Case:
        return preparation_case(study)

    def release_case(self, study: CollapseStudy, prepared: Case, packed: Trajectory, state: Path | None) -> Case:
        return release_case(study, prepared, packed)

    def measure(self, study: CollapseStudy, trajectory: Trajectory, release_dir: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        case = saved_case(release_dir)
        glued = np.array([sphere.fixed for sphere in case.bodies.spheres])
        return measure(study, trajectory, glued, g_normal=-case.gravity[2])

    def metrics(self, report: dict[str, Any]) -> dict[str, float]:
        return collapse_metrics(report)


KIND = CollapseKind()


def run_collapse(
    study: CollapseStudy,
    outdir: Path,
    progress: StageProgress | None = None,
    preparations: Path | None = None,
    timeout: float | None = None,
    options: RunOptions | None = None,
) -> dict[str, Any]:
    """Prepare (or reuse the preparation in `preparations`), release, measure (studies.base.run_study).
    A finished release is reused."""
    return KIND.run(study, outdir, progress, preparations, timeout, options)


def measure(study: CollapseStudy, trajectory: Trajectory, glued: np.ndarray, g_normal: float | None = None) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The report (scalars and curves) and the arrays too big for JSON (h(x, t)); `glued` marks the rough bed.

    g_normal: m/s², gravity normal to the bed (the case's −g_z); default 9.81 cos α."""
    planar = study.dimension == 2
    position, velocity = trajectory.position, trajectory.velocity
    radii = trajectory.radius
    masses = trajectory.mass
    start = position[0]
    mobile = ~glued
    column = mobile & (start[:, 0] < 0.0)
    bed = mobile & (start[:, 0] >= 0.0)
    lost = ~np.isfinite(position[-1]).all(axis=1)
    fraction = cm.column_fraction(radii[column], study.column.length, study.column.height, study.column.width, planar)
    column_measure = float(cm.grain_measure(radii[column], planar).sum())
    grid = cm.profile_grid(study.channel.length, study.grains.diameter, 1.0 if planar else study.column.width, fraction, planar,
                           column_measure, study.column.length)
    thickness = cm.profiles(np.nan_to_num(position, nan=-1e9), radii, mobile, grid)
    times = trajectory.time
    front = cm.front_positions(thickness, grid)
    speed = cm.front_velocity(times, front)
    phases = cm.front_phases(times, speed, front)
    if g_normal is None:
        g_normal = 9.81 * math.cos(math.radians(study.channel.slope_deg))
    energy = [cm.bed_energy_ratio(frame[:, 2], v, masses, bed, g_normal) for frame, v in zip(position, velocity)]
    entrained = [cm.entrained_mass(frame, start, masses, bed, study.grains.diameter) for frame in position]
    probes = {f"{at:g}": [cm.static_flowing_interface(frame[:, 2], v[:, 0], frame[:, 0], radii, at, study.grains.diameter)
                          for frame, v in zip(position, velocity)] for at in (study.column.length, 2 * study.column.length)}
    fields, field_arrays = measure_fields(study, np.nan_to_num(position, nan=-1e9), np.nan_to_num(velocity), radii, mobile, bed, times, front)
    final_speeds = np.linalg.norm(velocity[-1][mobile & ~lost], axis=1)
    report: dict[str, Any] = {
        "grains": {"glued": int(glued.sum()), "column": int(column.sum()), "bed": int(bed.sum()), "lost": int(lost.sum())},
        "mass": {"initial": float(masses[mobile].sum()), "final": float(masses[mobile & ~lost].sum()), "column": float(masses[column].sum())},
        "column_solid_fraction": fraction,
        "runout": float(front[-1]),
        "runout_over_R0": float(front[-1] / study.column.length),
        "front": {"time": times.tolist(), "position": front.tolist(), "velocity": speed.tolist(), **phases,
                  # the flow reached the end wall: the runout is the channel's, lengthen channel.length
                  "reached_end": bool(front.max() >= study.channel.length - 3 * study.grains.diameter)},
        "bed": {
            "energy_ratio": [None if math.isnan(e) else e for e in energy],
            "entrained_mass": entrained,
            "entrained_mass_final": entrained[-1],
            "interface": probes,
        },
        "final_max_speed": float(final_speeds.max()) if final_speeds.size else 0.0,
        "fields": fields,
    }
    arrays = {"time": times, "edges": grid.edges, "thickness": thickness, "front": front, "front_velocity": speed, **field_arrays}
    return report, arrays


def collapse_metrics(report: dict[str, Any]) -> dict[str, float]:
    """The scalar numbers of a collapse report, flat, for campaign tables and plots."""
    front = report["front"]
    metrics = {"runout": report["runout"], "runout_over_R0": report["runout_over_R0"], "final_max_speed": report["final_max_speed"],
               "bed.entrained_mass": report["bed"]["entrained_mass_final"], "column_solid_fraction": report["column_solid_fraction"]}
    for key in ("v_max", "t_max", "x_max", "t_slow", "x_slow", "v_slow", "t_stop", "x_stop"):
        metrics[f"front.{key}"] = float(front[key])
    metrics["front.slow_phase"] = float(bool(front["slow_phase"]))
    metrics["front.at_rest"] = float(bool(front["at_rest"]))
    return {**metrics, **field_metrics(report)}
