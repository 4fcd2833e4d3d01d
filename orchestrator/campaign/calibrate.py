"""Calibration of contact parameters against measured brick impacts (Richefeu et al. 2012, §3).

Error of one launch: E2 = Σ over the 8 brick corners and over the measured instants of the distance
between the simulated and the measured corner, the simulated corners interpolated linearly in time.
The optimiser (CMA-ES from `cma`, or scipy's Nelder-Mead / differential evolution) proposes
parameter sets; each becomes a content-addressed run of the campaign machinery, so an interrupted
calibration resumes by replaying: runs already done are read back instead of recomputed, and the
optimiser, seeded, proposes the same points again. The history (every evaluation) is kept in
`history.jsonl` and drawn in `convergence.png`.

Measured trajectories (CSV, header required): `t, corner, x, y, z` — time in s, corner index 0-7,
position in m in the case frame. Corner k of the brick frame is (±L/2, ±W/2, ±T/2) with the signs
of bits 2, 1, 0 of k (bit set = minus): corner 0 = (+L/2, +W/2, +T/2), corner 7 = (-L/2, -W/2, -T/2).
"""

from __future__ import annotations

import copy
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Callable, Literal

import numpy as np
import pandas as pd
from pydantic import Field

from orchestrator.shapes.rigid import quaternion_matrix
from orchestrator.validation import parse_model, read_yaml
from orchestrator.case import Case, CaseError, Name, Strict, parse_case
from orchestrator import rundir
from orchestrator.engines import build_stamp
from orchestrator.results import RESULTS, Trajectory, read_results
from orchestrator.campaign import store
from orchestrator.campaign.execute import perform
from orchestrator.campaign.spec import ParameterPath, set_path

HISTORY = "history.jsonl"


def corner_offsets(length: float, width: float, thickness: float) -> np.ndarray:
    """(8, 3) corners in the brick frame, in the documented order."""
    half = np.array([length, width, thickness]) / 2.0
    signs = np.array([[-1.0 if k & (4 >> axis) else 1.0 for axis in range(3)] for k in range(8)])
    return signs * half


def corners(trajectory: Trajectory, body: int, offsets: np.ndarray) -> np.ndarray:
    """(frames, 8, 3) world corners of one body from its position and orientation."""
    result = np.empty((trajectory.n_frames, len(offsets), 3))
    for frame in range(trajectory.n_frames):
        rotation = quaternion_matrix(trajectory.orientation[frame, body])
        result[frame] = trajectory.position[frame, body] + offsets @ rotation.T
    return result


def read_measured(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Measured instants (N,) and corners (N, 8, 3) from the documented CSV."""
    table = pd.read_csv(path)
    missing = {"t", "corner", "x", "y", "z"} - set(table.columns)
    if missing:
        raise CaseError(f"{path}: missing columns {sorted(missing)}; expected t, corner, x, y, z")
    table = table.sort_values(["t", "corner"])
    times = np.unique(table["t"].to_numpy(dtype=float))
    if len(table) != 8 * len(times) or sorted(set(table["corner"])) != list(range(8)):
        raise CaseError(f"{path}: each instant needs exactly the 8 corners 0-7")
    return times, table[["x", "y", "z"]].to_numpy(dtype=float).reshape(len(times), 8, 3)


def write_measured(path: Path, times: np.ndarray, corner_positions: np.ndarray) -> None:
    rows = [(t, k, *corner_positions[i, k]) for i, t in enumerate(times) for k in range(8)]
    pd.DataFrame(rows, columns=["t", "corner", "x", "y", "z"]).to_csv(path, index=False)


def e2_error(sim_time: np.ndarray, sim_corners: np.ndarray, times: np.ndarray, measured: np.ndarray) -> float:
    """Σ_corners Σ_instants |simulated - measured|, simulated corners interpolated at the measured instants."""
    total = 0.0
    for k in range(8):
        at = np.stack([np.interp(times, sim_time, sim_corners[:, k, axis]) for axis in range(3)], axis=1)
        total += float(np.linalg.norm(at - measured[:, k], axis=1).sum())
    return total


class ParameterSpec(Strict):
    path: ParameterPath
    # In the unit of the field at `path`.
    start: Annotated[float, Field(json_schema_extra={"unit": "that of the field at path"})]
    low: Annotated[float, Field(json_schema_extra={"unit": "that of the field at path"})]
    high: Annotated[float, Field(json_schema_extra={"unit": "that of the field at path"})]


class CalibrationSpec(Strict):
    name: Name
    base: str  # case file of one launch (one brick), relative to this file
    measured: str  # CSV, relative to this file
    parameters: Annotated[list[ParameterSpec], Field(min_length=1)]
    method: Literal["cma", "nelder-mead", "differential-evolution"] = "cma"
    max_runs: Annotated[int, Field(ge=1, le=100_000)] = 200
    sigma0: Annotated[float, Field(gt=0.0, le=1.0, json_schema_extra={"unit": "1"})] = 0.3  # CMA-ES step, as a fraction of each range
    seed: Annotated[int, Field(ge=1)] = 1
    jobs: Annotated[int, Field(ge=1, le=1024)] = 2
    tolerance: Annotated[float, Field(gt=0.0, json_schema_extra={"unit": "1"})] = 1e-3  # on the normalised parameters


@dataclass
class Calibration:
    spec: CalibrationSpec
    base: dict[str, Any]
    base_dir: Path
    times: np.ndarray
    measured: np.ndarray
    directory: Path

    def case_for(self, values: np.ndarray) -> Case:
        data = copy.deepcopy(self.base)
        for parameter, value in zip(self.spec.parameters, values):
            set_path(data, parameter.path, float(value))
        return parse_case(data, source=f"{self.spec.name} evaluation")

    def error_of(self, case: Case, directory: Path) -> float:
        """E2 of the completed run of `case` in `directory` against the measured corners."""
        trajectory = read_results(directory / RESULTS)
        shape = case.shapes[0]
        sim = corners(trajectory, 0, corner_offsets(shape.length, shape.width, shape.thickness))
        return e2_error(trajectory.time, sim, self.times, self.measured)


def load_calibration(path: Path, directory: Path) -> Calibration:
    spec = parse_model(CalibrationSpec, read_yaml(path, "calibration"), str(path))
    base_path = (path.parent / spec.base).resolve()
    base = read_yaml(base_path, "base case")
    times, measured = read_measured((path.parent / spec.measured).resolve())
    directory.mkdir(parents=True, exist_ok=True)
    return Calibration(spec, base, base_path.parent, times, measured, directory)


def evaluate_batch(calibration: Calibration, batch: list[np.ndarray], record: Callable[[np.ndarray, float, str], None]) -> list[float]:
    """Run (or find) every parameter set of a batch in parallel and return their E2 errors."""
    import concurrent.futures as futures
    import multiprocessing

    from orchestrator.engines.base import die_with_parent

    cases = [calibration.case_for(values) for values in batch]
    identifiers = [rundir.run_id(case, build_stamp(case.engine.value), case_dir=calibration.base_dir) for case in cases]
    todo = []
    for case, identifier in zip(cases, identifiers):
        directory = store.run_dir(calibration.directory, identifier)
        if store.status(directory) != "completed":
            if directory.exists():
                store.retire(directory, calibration.directory)
            todo.append((case.model_dump_json(), str(directory), str(calibration.base_dir), None))
    if todo:
        context = multiprocessing.get_context("spawn")
        with futures.ProcessPoolExecutor(max_workers=calibration.spec.jobs, mp_context=context, initializer=die_with_parent) as pool:
            list(pool.map(perform, *zip(*todo)))
    errors = []
    for values, case, identifier in zip(batch, cases, identifiers):
        directory = store.run_dir(calibration.directory, identifier)
        if store.status(directory) == "completed":
            error = calibration.error_of(case, directory)
        else:
            error = float("inf")  # a failed run is the worst possible fit
        record(values, error, identifier)
        errors.append(error)
    return errors


def calibrate(calibration: Calibration) -> dict[str, Any]:
    """Minimise E2 over the parameters; returns the best values, error and the number of runs."""
    spec = calibration.spec
    low = np.array([p.low for p in spec.parameters])
    high = np.array([p.high for p in spec.parameters])
    start = np.array([p.start for p in spec.parameters])
    history_path = calibration.directory / HISTORY
    history_path.unlink(missing_ok=True)  # rebuilt by replaying: finished runs are found, not rerun
    evaluations: list[dict[str, Any]] = []

    def record(values: np.ndarray, error: float, identifier: str) -> None:
        entry = {"evaluation": len(evaluations) + 1, "run_id": identifier, "error": error, **{p.path: float(v) for p, v in zip(spec.parameters, values)}}
        evaluations.append(entry)
        with open(history_path, "a") as stream:
            stream.write(json.dumps(entry) + "\n")

    to_unit = lambda x: (np.asarray(x) - low) / (high - low)  # noqa: E731 - optimisers work on [0, 1]
    from_unit = lambda u: low + np.clip(u, 0.0, 1.0) * (high - low)  # noqa: E731

    if spec.method == "cma":
        import cma

        options = {"bounds": [0.0, 1.0], "seed": spec.seed, "maxfevals": spec.max_runs, "tolx": spec.tolerance, "verbose": -9}
        strategy = cma.CMAEvolutionStrategy(to_unit(start).tolist(), spec.sigma0, options)
        while not strategy.stop():
            proposals = strategy.ask()
            errors = evaluate_batch(calibration, [from_unit(u) for u in proposals], record)
            strategy.tell(proposals, errors)
    elif spec.method == "nelder-mead":
        from scipy.optimize import minimize

        minimize(
            lambda u: evaluate_batch(calibration, [from_unit(u)], record)[0],
            to_unit(start),
            method="Nelder-Mead",
            options={"maxfev": spec.max_runs, "xatol": spec.tolerance, "fatol": 1e-12, "initial_simplex": _simplex(to_unit(start), spec.sigma0)},
        )
    else:
        from scipy.optimize import differential_evolution

        def batch_map(function: Callable[[np.ndarray], float], population: Any) -> list[float]:
            return evaluate_batch(calibration, [from_unit(u) for u in population], record)

        differential_evolution(
            lambda u: 0.0,  # replaced by batch_map, which evaluates whole populations in parallel
            [(0.0, 1.0)] * len(low),
            seed=spec.seed,
            maxiter=max(1, spec.max_runs // (15 * len(low))),
            workers=batch_map,
            updating="deferred",
            polish=False,
            x0=to_unit(start),
            tol=spec.tolerance,
        )
    return _finish(calibration, evaluations)


def _finish(calibration: Calibration, evaluations: list[dict[str, Any]]) -> dict[str, Any]:
    """The best evaluation, saved as calibration.json with its convergence plot."""
    spec = calibration.spec
    best = min(evaluations, key=lambda e: e["error"])
    result = {
        "method": spec.method,
        "runs": len({e["run_id"] for e in evaluations}),
        "evaluations": len(evaluations),
        "best_error": best["error"],
        "best": {p.path: best[p.path] for p in spec.parameters},
    }
    (calibration.directory / "calibration.json").write_text(json.dumps(result, indent=2) + "\n")
    plot_convergence(evaluations, spec, calibration.directory / "convergence.png")
    return result


def _simplex(centre: np.ndarray, step: float) -> np.ndarray:
    points = [centre]
    for axis in range(len(centre)):
        point = centre.copy()
        point[axis] = point[axis] + step if point[axis] + step <= 1.0 else point[axis] - step
        points.append(point)
    return np.array(points)


def plot_convergence(evaluations: list[dict[str, Any]], spec: CalibrationSpec, path: Path) -> None:
    from orchestrator.figures import subplots

    errors = np.array([e["error"] for e in evaluations])
    fig, axes = subplots(1, 1 + len(spec.parameters), figsize=(4 * (1 + len(spec.parameters)), 3.5), constrained_layout=True)
    axes[0].semilogy(np.arange(1, len(errors) + 1), errors, ".", color="grey", label="evaluation")
    axes[0].semilogy(np.arange(1, len(errors) + 1), np.minimum.accumulate(errors), color="tab:red", label="best so far")
    axes[0].set_xlabel("evaluation")
    axes[0].set_ylabel("E2 (m·samples)")
    axes[0].legend()
    for ax, parameter in zip(axes[1:], spec.parameters):
        ax.plot([e[parameter.path] for e in evaluations], ".", color="tab:blue")
        ax.set_xlabel("evaluation")
        ax.set_ylabel(parameter.path)
    fig.savefig(path, dpi=110)
