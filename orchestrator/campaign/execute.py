"""Running a campaign's pending runs on a local process pool or a Dask cluster, resumably.

Each run is performed by `perform` in a worker process (or Dask worker). It takes the run
directory's lock first and gives the point up when another process holds it or has completed it,
so two launches on one campaign directory never run a point twice. A crashed run is recorded
(run.json with the log tail) and the campaign goes on. Workers and engines die with the campaign
process (PR_SET_PDEATHSIG; a worker whose campaign died while it was starting exits at once) and
the lock dies with them, so the next launch finds those runs `incomplete`, moves what they left to
the attic and runs them again.
"""

from __future__ import annotations

import concurrent.futures as futures
import dataclasses
import multiprocessing
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

from orchestrator import rundir
from orchestrator.campaign import store
from orchestrator.campaign.spec import Campaign, base_kind, expand, open_campaign
from orchestrator.case import CaseError
from orchestrator.engines import RunOptions, build_stamp
from orchestrator.engines.base import EngineError, die_with_parent
from orchestrator.studies.launch import Point
from orchestrator.studies.registry import launch_kind

RERUN = ("pending", "incomplete", "stale")  # what a launch runs; failed ones only when asked


def perform(point_json: str, directory: str, case_dir: str, timeout: float | None, kind: str = "case",
            rerun_failed: bool = False, options: dict[str, Any] | None = None, shared: str | None = None) -> dict[str, Any]:
    """Run one point of any launch kind (studies.registry) in `directory` (any process); never raises
    for an engine or case failure.

    Returns {"run_id", "status": completed | failed | skipped, ...}; skipped: another process holds
    the point or already completed it (or it failed before and rerun_failed is off), or its inputs no
    longer give the run id its directory stands for. options: the launch's RunOptions as a dict (how
    engines run: MPI processes), passed to every engine. shared: where a study point keeps its
    preparation (None: the campaign directory's folder for them).
    """
    run_options = RunOptions(**(options or {}))
    path = Path(directory)
    started = time.perf_counter()
    launch = launch_kind(kind)
    try:
        with rundir.locked(path, wait=False):
            state = store.status(path, held=True, model=launch.model)
            if state not in RERUN and not (state == "failed" and rerun_failed):
                return {"run_id": path.name, "status": "skipped", "reason": state}
            point = launch.point(point_json, Path(case_dir))
            if rundir.holds_attempt(path) and not point.continues(path):
                rundir.retire(path, path.parent.parent)
            return _perform_locked(point, kind, path, Path(case_dir), timeout, started, run_options, Path(shared) if shared else None)
    except rundir.Busy:
        return {"run_id": path.name, "status": "skipped", "reason": "running elsewhere"}


def _perform_locked(point: Point, kind: str, path: Path, case_dir: Path, timeout: float | None, started: float,
                    options: RunOptions, shared: Path | None) -> dict[str, Any]:
    today = rundir.run_id(point.inputs, build_stamp(point.inputs.engine.value), case_dir=case_dir)  # type: ignore[attr-defined]
    if today != path.name:  # a file it names, or the build, changed since the launch planned it: this directory is not its
        return {"run_id": path.name, "status": "skipped",
                "reason": f"its inputs changed since the launch planned it (now run {today}): relaunch to run them"}
    try:
        record = point.run(path, path.parent.parent, timeout, options, shared)
        return {"run_id": path.name, "status": "completed", "wall_time_s": record["wall_time_s"]}
    except (EngineError, CaseError) as error:
        summary = error.summary if isinstance(error, EngineError) else str(error)
        if (rundir.read_record(path) or {}).get("status") != "failed":  # the runner records a case's engine failure itself
            rundir.record_failure(path, kind, summary, error.tail if isinstance(error, EngineError) else [])
        return {"run_id": path.name, "status": "failed", "error": summary, "wall_time_s": time.perf_counter() - started}


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
class LaunchPlan:
    """What a launch will do: every point, and which of them need running."""

    campaign_dir: Path
    case_dir: Path
    timeout: float | None
    points: dict[str, dict[str, Any]]
    cases: dict[str, Any]  # validated cases, or avalanche / collapse studies when kind says so
    kind: str
    to_run: list[str]
    skipped: dict[str, str]  # run id -> why (completed, running elsewhere, failed)
    rerun_failed: bool = False
    options: RunOptions = field(default_factory=RunOptions)
    shared: Path | None = None  # where study points share preparations (None: the campaign's own folder)


def plan_campaign(campaign: Path | Campaign, campaign_dir: Path, rerun_failed: bool = False, shared: Path | None = None) -> LaunchPlan:
    """What a launch of `campaign` (its file, or one made in memory) in `campaign_dir` runs. shared:
    where study points keep their preparations (default: the campaign directory's own folder)."""
    spec, base, base_path = dataclasses.astuple(campaign if isinstance(campaign, Campaign) else open_campaign(campaign))
    kind = base_kind(spec, base)
    base_dir = base_path.parent
    points, cases = {}, {}
    builds: dict[str, dict[str, Any]] = {}
    for parameters, case in expand(spec, base):
        engine = case.engine.value
        if engine not in builds:  # once per engine: it hashes the templates and the plugin sources
            builds[engine] = build_stamp(engine)
        identifier = rundir.run_id(case, builds[engine], case_dir=base_dir)
        points[identifier] = parameters
        cases[identifier] = case
    # Another campaign's directory is refused before its points.json is touched; this one's is resumed.
    identity = {"name": spec.name, "base": str(base_path), "designs": [design.model_dump(mode="json") for design in spec.designs]}
    store.claim(campaign_dir, identity, {name for parameters in points.values() for name in parameters})
    store.write_points(campaign_dir, points)
    to_run, skipped = [], {}
    for identifier in points:
        state = store.status(store.run_dir(campaign_dir, identifier))
        if state in RERUN or (state == "failed" and rerun_failed):
            to_run.append(identifier)
        else:
            skipped[identifier] = state
    return LaunchPlan(campaign_dir, base_dir, spec.timeout_s, points, cases, kind, to_run, skipped, rerun_failed, shared=shared)


def _arguments(plan: LaunchPlan, identifier: str) -> tuple[str, str, str, float | None, str, bool, dict[str, Any], str | None]:
    directory = str(store.run_dir(plan.campaign_dir, identifier))
    return (plan.cases[identifier].model_dump_json(), directory, str(plan.case_dir), plan.timeout, plan.kind, plan.rerun_failed,
            plan.options.as_dict(), str(plan.shared) if plan.shared is not None else None)


def start_worker(campaign: int) -> None:
    """A pool worker's first act: die with the campaign process `campaign` at every moment of its life.

    PR_SET_PDEATHSIG kills the worker when the campaign dies from then on; a campaign killed earlier,
    while the worker was still starting (importing the package takes a second or two), has left it
    an orphan that no signal will reach, so the worker then checks its parent and exits at once."""
    die_with_parent()
    if os.getppid() != campaign:
        os._exit(1)


def local_results(plan: LaunchPlan, jobs: int) -> Iterator[dict[str, Any]]:
    """Run on a local process pool; yields each run's summary as it finishes."""
    context = multiprocessing.get_context("spawn")
    with futures.ProcessPoolExecutor(max_workers=jobs, mp_context=context, initializer=start_worker, initargs=(os.getpid(),)) as pool:
        pending = {pool.submit(perform, *_arguments(plan, identifier)) for identifier in plan.to_run}
        for future in futures.as_completed(pending):
            yield future.result()


def local_cluster(jobs: int) -> Any:
    """A Dask LocalCluster of `jobs` single-threaded worker processes."""
    from distributed import LocalCluster

    return LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True, dashboard_address=None)


def dask_results(plan: LaunchPlan, jobs: int, address: str | None = None, start: Callable[[int], Any] | None = None) -> Iterator[dict[str, Any]]:
    """Run on Dask: a scheduler at `address` (e.g. from dask-jobqueue), or a cluster of `jobs` workers
    that `start(jobs)` starts (default: local_cluster) and this closes."""
    from distributed import Client, as_completed

    cluster = None if address else (start or local_cluster)(jobs)
    client = Client(address or cluster)
    try:
        submitted = {client.submit(perform, *_arguments(plan, identifier), pure=False, key=f"run-{identifier}"): identifier
                     for identifier in plan.to_run}
        for future in as_completed(submitted):
            try:
                yield future.result()
            except Exception as error:  # its workers died too often (KilledWorker): the point stays for a relaunch
                yield {"run_id": submitted[future], "status": "failed", "error": f"{type(error).__name__}: {error}"}
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run_campaign(
    campaign_file: Path | Campaign,
    campaign_dir: Path,
    jobs: int = 1,
    executor: str = "local",
    rerun_failed: bool = False,
    dask_address: str | None = None,
    on_update: Callable[[Counts, dict[str, Any] | None], None] | None = None,
    options: RunOptions | None = None,
    dask_cluster: Callable[[int], Any] | None = None,
    shared: Path | None = None,
) -> Counts:
    """Run every pending point (options: how the engines run, e.g. MPI processes per run).

    jobs: runs at once, at least 1; the local pool, or the Dask cluster this starts (`dask_cluster(n)`,
    default a LocalCluster; none with `dask_address`), gets at most one worker per point to run, and
    none when every point is done. shared: where study points keep their preparations (default the
    campaign directory's folder for them). CaseError (nothing written) for jobs below 1 or a campaign
    directory that holds another campaign (store.claim)."""
    if jobs < 1:
        raise CaseError(f"--jobs: {jobs!r} runs at once; allowed: at least 1 (capped at the points to run)")
    plan = dataclasses.replace(plan_campaign(campaign_file, campaign_dir, rerun_failed, shared), options=options or RunOptions())
    jobs = min(jobs, len(plan.to_run))
    counts = Counts(total=len(plan.points), skipped=len(plan.skipped), running=jobs)
    if on_update:
        on_update(counts, None)
    if not plan.to_run:
        results: Iterator[dict[str, Any]] = iter(())
    else:
        results = dask_results(plan, jobs, dask_address, dask_cluster) if executor == "dask" else local_results(plan, jobs)
    for summary in results:
        if summary["status"] == "completed":
            counts.done += 1
        elif summary["status"] == "skipped":  # another launch holds it or finished it meanwhile
            counts.skipped += 1
        else:
            counts.failed += 1
        counts.running = min(jobs, counts.total - counts.skipped - counts.done - counts.failed)
        if on_update:
            on_update(counts, summary)
    with store.campaign_lock(campaign_dir):
        store.build_index(campaign_dir)
    return counts
