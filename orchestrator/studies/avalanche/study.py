"""The avalanche study kind: pack bricks in the release box (searching the packing's density), open
the trap, measure the deposit and the front; the skeleton of studies.base runs it.

Its parts: the study file (spec.py), its two cases (cases.py), the density search (density.py), the
measurements (measure.py), the pictures (report.py). The names most callers use are importable from
here.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from orchestrator import physics
from orchestrator.capabilities import brick_gaps
from orchestrator.case import Case
from orchestrator.engines import RunOptions
from orchestrator.results import Trajectory
from orchestrator.rundir import read_record
from orchestrator.runner import ensure_run
from orchestrator.studies.avalanche.cases import first_packing_mu, packing_case, packing_key, packing_state_file, release_case
from orchestrator.studies.avalanche.density import Trial, closest, next_mu
from orchestrator.studies.avalanche.geometry import apparent_density
from orchestrator.studies.avalanche.measure import LOST_WHILE_PACKING, initial_state, measure, packed_density
from orchestrator.studies.avalanche.table import ensemble_rows
from orchestrator.studies.avalanche.spec import DEMO_STUDY, PILE_GAP, RAIN_GAP, AvalancheStudy, BrickSpec, ContactSpec, PackingSpec
from orchestrator.studies.base import EnsembleRow, StageProgress, StudyKind
from orchestrator.studies.reference import PACKAGED_REFERENCE, SHARED_REFERENCE, load_reference, reference_path

__all__ = ["AvalancheStudy", "BrickSpec", "ContactSpec", "PackingSpec", "PILE_GAP", "RAIN_GAP", "KIND", "load_study", "run_study",
           "packing_case", "packing_key", "release_case", "measure", "load_reference", "reference_path", "SHARED_REFERENCE",
           "PACKAGED_REFERENCE", "DEMO_STUDY"]


class AvalancheKind(StudyKind):
    """Bricks packed in the release box (the preparation), released down the slope, deposit and front measured."""

    name = "avalanche"
    model = AvalancheStudy
    detect_keys = frozenset({"packing", "release", "geometry", "brick"})
    preparation = "packing"
    shared_dir = "packings"
    lost_bodies = LOST_WHILE_PACKING
    # Under MPI, split the box across the flow (y): the set-up is symmetric about y = 0, so each process
    # gets half the bricks all along (docs/benchmarks.md, strong scaling: the split, measured).
    processor_grid = "1 * 1"

    def preparation_case(self, study: AvalancheStudy) -> Case:
        return packing_case(study)

    def prepare(self, study: AvalancheStudy, root: Path, progress: StageProgress | None, timeout: float | None,
                options: RunOptions) -> tuple[Case, Path, bool, dict[str, Any]]:
        """Pack, trial after trial, until the pile's apparent density is within the tolerance of its
        target (density.py); keep the closest trial. The record lists every trial (μ, density, wall
        time) and, when the target was not reached, a warning naming the closest."""
        search, target = study.packing.density_search, study.target_density
        trials: list[Trial] = []
        cases: dict[float, Case] = {}  # μ → the trial's packing case, made once
        mu: float | None = first_packing_mu(study)
        while mu is not None:
            label = "packing" if search.max_trials == 1 else f"packing, trial {len(trials) + 1} (μ brick/brick {mu:.3g})"
            cases[mu] = packing_case(study, mu)
            directory, reused = ensure_run(cases[mu], root, "packing", lambda d: packing_state_file(study, d),
                                           progress(label) if progress else None, timeout, options)
            record = read_record(directory) or {}
            trials.append(Trial(mu, packed_density(study, directory), str(directory), reused,
                                float(record.get("wall_time_s", float("nan"))), None if reused else record.get("set_aside")))
            if abs(trials[-1].off(target)) <= search.tolerance or len(trials) >= search.max_trials:
                break
            mu = next_mu(trials, target, search.mu_bounds)
        best = closest(trials, target)
        contacts = study.packing.contacts or study.contacts
        # what the packing ran with, beside the flow's (the study's packing may be softer: spec.PackingSpec)
        summary: dict[str, Any] = {"brick_brick_mu": best.mu, "trials": [t.as_dict() for t in trials],
                                  "target_reached": abs(best.off(target)) <= search.tolerance,
                                  "kn_brick_brick": contacts.brick_brick.kn, "kn_brick_board": contacts.brick_board.kn,
                                  "time_step_s": physics.schedule(cases[best.mu]).dt}
        # A search that ran out of trials is warned of; a packing asked to pack once (max_trials 1)
        # is not a search: its density and verdict are in the table (table.packing_verdict).
        if not summary["target_reached"] and search.max_trials > 1:
            summary["warning"] = (f"packing: apparent density {best.apparent_density:.0f} kg/m³ ({best.off(target):+.1%}) is the closest of "
                                 f"{len(trials)} trial(s) to the target {target:g} ± {search.tolerance:.0%} (μ brick/brick {best.mu:.3g} "
                                 f"while packing; packing.density_search sets the trials and the bounds of μ)")
        return cases[best.mu], Path(best.directory), best.reused, summary

    def state_file(self, study: AvalancheStudy, directory: Path) -> Path | None:
        return packing_state_file(study, directory)

    def release_case(self, study: AvalancheStudy, prepared: Case, packed: Trajectory, state: Path | None) -> Case:
        return release_case(study, packed, state)

    def measure(self, study: AvalancheStudy, trajectory: Trajectory, release_dir: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        brick, geometry = study.brick_spec.build(), study.geometry.build()
        report = measure(trajectory, brick, gravity=-geometry.release_gravity()[2], slope_deg=study.geometry.slope_deg)
        density = apparent_density(geometry, trajectory.position[0], trajectory.orientation[0], brick)
        report["packing"] = {"bricks": trajectory.n_bodies, "apparent_density": density, "target_apparent_density": study.target_density}
        report["initial"] = initial_state(geometry, trajectory, density, study.packing.volume)
        # where the engine's brick (preferred or fallback) does not hold on another brick's face as the study's does
        gaps = brick_gaps(study.engine, study.brick_spec.kind)
        if gaps:
            report["brick_gaps"] = list(gaps)
        return report, {}

    def metrics(self, report: dict[str, Any]) -> dict[str, float]:
        """deposit.*, front.*, packing density and the kinetic energy left, flat."""
        metrics = {f"deposit.{k}": float(v) for k, v in report["deposit"].items() if isinstance(v, (int, float))}
        metrics.update({f"front.{k}": float(v) for k, v in report["front"].items() if isinstance(v, (int, float))})
        metrics["packing.apparent_density"] = float(report["packing"]["apparent_density"])
        metrics["kinetic_to_released_energy"] = float(report["kinetic_to_released_energy"])
        return metrics

    def ensemble_rows(self, reports: dict[int, dict[str, Any]]) -> list[EnsembleRow]:
        """The study's table (table.study_rows) over seeds: each seed's value, and the references and
        verdicts beside the members' mean."""
        return ensemble_rows(reports)


KIND = AvalancheKind()


def load_study(path: Path) -> AvalancheStudy:
    return KIND.load(path)


def run_study(
    study: AvalancheStudy,
    outdir: Path,
    progress: StageProgress | None = None,
    packings: Path | None = None,
    timeout: float | None = None,
    options: RunOptions | None = None,
) -> dict[str, Any]:
    """Pack (or reuse the packing from `packings`, default outdir/../packings), release, measure.

    A finished release in outdir/run is reused (rerun = report only). Returns the report, also
    written to outdir/report.json (studies.base.run_study).
    """
    return KIND.run(study, outdir, progress, packings, timeout, options)
