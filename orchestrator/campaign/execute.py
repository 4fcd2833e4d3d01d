"""Running a campaign's pending runs on a local process pool or a Dask cluster, resumably.

Each run is performed by `perform` in a worker process (or Dask worker): it marks the directory
with its PID, runs the case, and returns a small summary. A crashed run is recorded (run.json with
the log tail) and the campaign goes on. Workers and engines die with the campaign process
(PR_SET_PDEATHSIG), so a killed campaign leaves no orphans writing into run directories; the next
launch finds those runs `incomplete`, moves them to the attic and runs them again.
"""

from __future__ import annotations

import concurrent.futures as futures
import json
import multiprocessing
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

from ..case import Case, CaseError
from ..engines.base import EngineError, die_with_parent
from ..runner import RESULTS, RUN_RECORD, run_case, write_json_atomic
from . import store
from .spec import STUDY_KINDS, base_kind, expand, load_campaign


def perform(point_json: str, directory: str, case_dir: str, timeout: float | None, kind: str = "case") -> dict[str, Any]:
    """Run one case, avalanche or collapse study in `directory` (any process); never raises for an engine or case failure."""
    path = Path(directory)
    path.mkdir(parents=True, exist_ok=True)
    pid_file = path / store.WORKER_PID
    pid_file.write_text(str(os.getpid()))
    started = time.perf_counter()
    try:
        if kind in STUDY_KINDS:
            record = perform_study(kind, point_json, path, started, timeout)
        else:
            case = Case.model_validate_json(point_json)
            record = run_case(case, Path(case_dir), path, timeout=timeout)
        return {"run_id": path.name, "status": "completed", "wall_time_s": record["wall_time_s"]}
    except (EngineError, CaseError) as error:
        summary = error.summary if isinstance(error, EngineError) else str(error)
        if isinstance(error, CaseError) or kind != "case":
            tail = error.tail if isinstance(error, EngineError) else []
            write_json_atomic(path / RUN_RECORD, {"status": "failed", "error": summary, "log_tail": tail})
        return {"run_id": path.name, "status": "failed", "error": summary, "wall_time_s": time.perf_counter() - started}
    finally:
        pid_file.unlink(missing_ok=True)


def perform_study(kind: str, study_json: str, path: Path, started: float, timeout: float | None) -> dict[str, Any]:
    """An avalanche or collapse study as one campaign run, with a summary run.json.

    The study's preparation (an avalanche's packing, a collapse's rained column) is shared by every
    run of the campaign in <campaign>/packings or <campaign>/preparations. The summary points at the
    release's results (run/results.h5) and holds the study's scalar metrics, so the index and the
    plots treat it like any run.
    """
    shared_root = path.parent.parent
    if kind == "avalanche":
        from ..avalanche_study import AvalancheStudy, run_study

        report = run_study(AvalancheStudy.model_validate_json(study_json), path, packings=shared_root / "packings", timeout=timeout)
        shared, metrics = report["packing"], study_metrics(report)
    else:
        from ..collapse import CollapseStudy
        from ..collapse_study import collapse_metrics, run_collapse

        report = run_collapse(CollapseStudy.model_validate_json(study_json), path, preparations=shared_root / "preparations", timeout=timeout)
        shared, metrics = report["preparation"], collapse_metrics(report)
    release = json.loads((path / "run" / RUN_RECORD).read_text())
    record = {
        "status": "completed",
        "kind": kind,
        "results": f"run/{RESULTS}",
        "engine": release.get("engine"),
        "engine_version": release.get("engine_version"),
        "contact_build": release.get("contact_build"),
        "wall_time_s": time.perf_counter() - started,
        "preparation": shared.get("directory"),
        "preparation_reused": shared.get("reused"),
        "metrics": metrics,
    }
    write_json_atomic(path / RUN_RECORD, record)
    return record


def study_metrics(report: dict[str, Any]) -> dict[str, float]:
    """The scalar numbers of a study report, flat: deposit.*, front.*, packing density, energy left."""
    metrics = {f"deposit.{k}": float(v) for k, v in report["deposit"].items() if isinstance(v, (int, float))}
    metrics.update({f"front.{k}": float(v) for k, v in report["front"].items() if isinstance(v, (int, float))})
    metrics["packing.apparent_density"] = float(report["packing"]["apparent_density"])
    metrics["kinetic_to_released_energy"] = float(report["kinetic_to_released_energy"])
    return metrics


@dataclass
class Counts:
    total: int
    skipped: int = 0
    done: int = 0
    failed: int = 0
    running: int = 0
    started_at: float = field(default_factory=time.monotonic)

    @property
    def remaining(self) -> int:
        return self.total - self.skipped - self.done - self.failed - self.running

    def eta_s(self) -> float | None:
        finished = self.done + self.failed
        if not finished:
            return None
        per_run = (time.monotonic() - self.started_at) / finished
        return per_run * (self.remaining + self.running)


@dataclass
class Plan:
    """What a launch will do: every point, and which of them need running."""

    campaign_dir: Path
    case_dir: Path
    timeout: float | None
    points: dict[str, dict[str, Any]]
    cases: dict[str, Any]  # validated cases, or avalanche / collapse studies when kind says so
    kind: str
    to_run: list[str]
    skipped: dict[str, str]  # run id -> why (completed, running elsewhere, failed)


def plan_campaign(campaign_file: Path, campaign_dir: Path, rerun_failed: bool = False) -> Plan:
    spec, base = load_campaign(campaign_file)
    kind = base_kind(spec, base)
    expanded = expand(spec, base)
    points, cases = {}, {}
    for parameters, case in expanded:
        identifier = store.run_id(case)
        points[identifier] = parameters
        cases[identifier] = case
    campaign_dir.mkdir(parents=True, exist_ok=True)
    store.write_points(campaign_dir, points)
    to_run, skipped = [], {}
    for identifier in points:
        directory = store.run_dir(campaign_dir, identifier)
        state = store.status(directory)
        if state in ("completed", "running") or (state == "failed" and not rerun_failed):
            skipped[identifier] = state
            continue
        if state in ("incomplete", "failed"):
            store.retire(directory, campaign_dir)
        to_run.append(identifier)
    base_dir = (campaign_file.parent / spec.base).resolve().parent
    return Plan(campaign_dir, base_dir, spec.timeout_s, points, cases, kind, to_run, skipped)


def _arguments(plan: Plan, identifier: str) -> tuple[str, str, str, float | None, str]:
    directory = str(store.run_dir(plan.campaign_dir, identifier))
    return (plan.cases[identifier].model_dump_json(), directory, str(plan.case_dir), plan.timeout, plan.kind)


def local_results(plan: Plan, jobs: int) -> Iterator[dict[str, Any]]:
    """Run on a local process pool; yields each run's summary as it finishes."""
    context = multiprocessing.get_context("spawn")
    with futures.ProcessPoolExecutor(max_workers=jobs, mp_context=context, initializer=die_with_parent) as pool:
        pending = {pool.submit(perform, *_arguments(plan, identifier)) for identifier in plan.to_run}
        for future in futures.as_completed(pending):
            yield future.result()


def dask_results(plan: Plan, jobs: int, address: str | None = None) -> Iterator[dict[str, Any]]:
    """Run on Dask: a scheduler at `address` (e.g. from dask-jobqueue), or a LocalCluster of `jobs` processes."""
    from distributed import Client, LocalCluster, as_completed

    cluster = None if address else LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True, dashboard_address=None)
    client = Client(address or cluster)
    try:
        submitted = [client.submit(perform, *_arguments(plan, identifier), pure=False, key=f"run-{identifier}") for identifier in plan.to_run]
        for future in as_completed(submitted):
            yield future.result()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run_campaign(
    campaign_file: Path,
    campaign_dir: Path,
    jobs: int = 1,
    executor: str = "local",
    rerun_failed: bool = False,
    dask_address: str | None = None,
    on_update: Callable[[Counts, dict[str, Any] | None], None] | None = None,
) -> Counts:
    plan = plan_campaign(campaign_file, campaign_dir, rerun_failed)
    counts = Counts(total=len(plan.points), skipped=len(plan.skipped), running=min(jobs, len(plan.to_run)))
    if on_update:
        on_update(counts, None)
    results = dask_results(plan, jobs, dask_address) if executor == "dask" else local_results(plan, jobs)
    for summary in results:
        if summary["status"] == "completed":
            counts.done += 1
        else:
            counts.failed += 1
        counts.running = min(jobs, len(plan.to_run) - counts.done - counts.failed)
        if on_update:
            on_update(counts, summary)
    store.build_index(campaign_dir)
    return counts
