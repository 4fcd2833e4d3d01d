"""One run: validate → write the deck → execute the engine → collect results.h5 → run.json.

run.json is rewritten at each stage (atomically), so a run directory always says how far it got.
A failed run keeps its deck, its log and whatever frames it wrote. A run whose process was killed
(its record still says `running`) continues from its newest checkpoint when it is run again, in a
new segment (engines.checkpoint); its record lists the segments and the simulated time lost. A
completed run's checkpoints are deleted (its results hold everything).
`ensure_run` makes a run once under a content address (its run id) and reuses it afterwards:
settled packings, prepared columns.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Callable

from orchestrator import __version__, rundir
from orchestrator.case import Case, CaseError
from orchestrator.engines import EngineAdapter, EngineError, RunOptions, build_stamp, capabilities, get_adapter
from orchestrator.engines import checkpoint
from orchestrator.engines.base import LOG_NAME, TAIL_LINES, ProgressCallback, log_tail
from orchestrator.estimate import check_machine
from orchestrator.plan import Resume, RunPlan, make_plan
from orchestrator.post import overlaps, summary
from orchestrator.post.lost import drop_lost, lost_bodies
from orchestrator.results import CAMPAIGN_RECORD, RESULTS, RUN_RECORD, STUDY_RECORD, Trajectory, write_results



def render_case(case: Case, case_dir: Path, directory: Path) -> Path:
    """Write the deck (and its data files) only; returns the deck path."""
    plan = make_plan(case, case_dir)
    directory.mkdir(parents=True, exist_ok=True)
    rundir.save_inputs(directory, case)
    return get_adapter(case.engine.value).write_input(plan, directory)


def run_case(
    case: Case,
    case_dir: Path,
    directory: Path,
    progress: ProgressCallback | None = None,
    timeout: float | None = None,
    adapter: EngineAdapter | None = None,
    options: RunOptions | None = None,
    plan: RunPlan | None = None,
) -> dict[str, Any]:
    """Run a validated case in `directory` and return the run record (also saved as run.json).

    Holds the directory's lock while it runs (rundir.Busy if another process holds it). Raises
    EngineError (after recording the failure in run.json) when the engine fails. `adapter`: an
    engine adapter set up by the caller (tuning a benchmark varies); default get_adapter(engine,
    options), options being how the engine runs (MPI processes), never what it computes. `plan`:
    the case's plan when the caller made it already (make_plan(case, case_dir)).
    """
    refuse_foreign(directory)
    with rundir.locked(directory, wait=False):
        return run_locked(case, case_dir, directory, progress, timeout, adapter or get_adapter(case.engine.value, options), plan)


def refuse_foreign(directory: Path) -> None:
    """CaseError (one line) when `directory` holds a study (study.json) or a campaign or a study over
    seeds (campaign.json): a run keeps a directory of its own."""
    for record, what in ((STUDY_RECORD, "a study"), (CAMPAIGN_RECORD, "a campaign or a study over seeds")):
        if (directory / record).exists():
            raise CaseError(f"--output: {directory} holds {what} ({record}), not a run; a run keeps a directory of its own: choose another -o")


def resume_point(plan: RunPlan, directory: Path, adapter: EngineAdapter | None = None, identity: str | None = None) -> Resume | None:
    """The checkpoint a cut-off run of the plan's case in `directory` continues from, or None (start afresh).

    A run is cut off when its record says `running` and no process holds the directory's lock (the
    caller holds it, or checks is_locked). It continues only with the same run id (same inputs and
    build), from the newest checkpoint that was sealed complete and still matches its seal; a damaged
    one is set aside (engines.checkpoint), never deleted.
    """
    case = plan.case
    adapter = adapter or get_adapter(case.engine.value)
    previous = rundir.read_record(directory)
    if adapter.checkpoint_ext is None or not previous or previous.get("status") != "running":
        return None
    if previous.get("run_id") != (identity or rundir.run_id(case, build_stamp(case.engine.value), case_dir=plan.case_dir)):
        return None
    reached = adapter.last_frame_step(plan, directory)
    for step, path in reversed(adapter.usable_checkpoints(plan, directory)):
        if checkpoint.verified(path):  # the newest whose content matches its seal
            return Resume(checkpoint.next_segment(directory, LOG_NAME), step, path.name, reached)
        checkpoint.set_aside(path)  # damaged: kept beside the run as checkpoint.<step>.<ext>.damaged
    return None


def resumable(directory: Path, case_dir: Path, plan: RunPlan | None = None) -> bool:
    """Whether the run in `directory` (of `plan`'s case, else its case.json, whose files are relative
    to case_dir) would continue from a checkpoint."""
    try:
        plan = plan or make_plan(rundir.saved_case(directory), case_dir)
    except (OSError, ValueError):
        return False
    return resume_point(plan, directory) is not None


def run_locked(case: Case, case_dir: Path, directory: Path, progress: ProgressCallback | None, timeout: float | None,
               adapter: EngineAdapter | None = None, plan: RunPlan | None = None) -> dict[str, Any]:
    """run_case for a caller that already holds the directory's lock (a campaign worker, ensure_run)."""
    adapter = adapter or get_adapter(case.engine.value)
    plan = plan or make_plan(case, case_dir)
    build = build_stamp(case.engine.value)
    files = rundir.file_digests(case, case_dir)
    identity = rundir.run_id(case, build, files=files)
    directory.mkdir(parents=True, exist_ok=True)
    plan = plan.resumed(resume_point(plan, directory, adapter, identity))
    if plan.resume is None and (directory / RUN_RECORD).exists():
        rundir.retire(directory, directory.parent)  # an earlier attempt's files: kept in ../attic, never mixed with this one's
    large = check_machine(plan.output, directory)  # CaseError when it would not fit this machine
    rundir.save_inputs(directory, case)
    deck = adapter.write_input(plan, directory)
    record = _running_record(plan, directory, identity, build, files, deck, adapter.warnings(plan) + ((large,) if large else ()))
    rundir.write_record(directory, record)
    started = time.perf_counter()
    try:
        adapter.execute(plan, directory, progress=progress, timeout=timeout)
        trajectory = adapter.read_output(plan, directory)
        lost = check_inside(plan, trajectory, deck)
    except EngineError as error:
        record.update(status="failed", error=error.summary, log_tail=error.tail, wall_time_s=time.perf_counter() - started)
        rundir.write_record(directory, record)
        raise
    engine_seconds = time.perf_counter() - started
    trajectory.attrs.update(engine=build["engine"], engine_version=build["version"] or "unknown", case_name=case.name)
    write_results(directory / RESULTS, trajectory)
    state = capabilities(case.engine.value).state_file if case.save_state else None
    record.update(
        sealed=rundir.seal_outputs(directory, [RESULTS] + ([state] if state else [])),
        status="completed",
        finished=rundir.now(),
        wall_time_s=time.perf_counter() - started,
        engine_wall_time_s=engine_seconds,
        frames=trajectory.n_frames,
        bodies=trajectory.n_bodies,
        metrics=summary.summary(trajectory),
    )
    engine_summary = adapter.engine_summary(plan, directory)
    if engine_summary:
        record.update(engine_summary=engine_summary)
    if lost:
        record.update(lost_bodies=lost["lost_bodies"], warnings=[*record.get("warnings", []), lost["warning"]])
    audit = audit_overlaps(plan, trajectory)
    if audit:
        record.update(overlaps=audit)
        breaches = overlaps.warnings(audit)
        if breaches:
            record.update(warnings=[*record.get("warnings", []), *breaches])
    rundir.write_record(directory, record)
    if adapter.checkpoint_ext is not None:  # only now: a run killed before its record says completed can still continue
        checkpoint.clear(directory, adapter.checkpoint_ext)
    return record


def _running_record(plan: RunPlan, directory: Path, identity: str, build: dict[str, Any], files: dict[str, str], deck: Path,
                    warnings: tuple[str, ...]) -> dict[str, Any]:
    """The record of a run about to start (its segments so far, this one last)."""
    segments = _segments(plan, directory)
    return {
        "orchestrator_version": __version__,
        "kind": "case",
        "run_id": identity,
        "build": build,
        "files": files,
        "engine": build["engine"],
        "engine_version": build["version"],
        "deck": deck.name,
        "status": "running",
        "started": segments[0]["started"],
        "segments": segments,
        # A cut-off segment reached further than the checkpoint the next one starts from: that is lost.
        "simulated_time_lost_s": sum(cut["reached_time_s"] - following["from_time_s"] for cut, following in zip(segments, segments[1:])),
        **({"warnings": list(warnings)} if warnings else {}),
    }


def _segments(plan: RunPlan, directory: Path) -> list[dict[str, Any]]:
    """The run's segments so far, this one last: when each started and, for a continued run, the
    simulated time it starts from and the one its cut-off predecessor had reached (the difference is lost)."""
    resume = plan.resume
    if resume is None:
        return [{"segment": 0, "started": rundir.now(), "from_time_s": 0.0}]
    dt = plan.schedule.dt
    previous = rundir.read_record(directory) or {}
    segments = list(previous.get("segments") or [{"segment": 0, "started": previous.get("started"), "from_time_s": 0.0}])
    segments[-1] = {**segments[-1], "reached_time_s": (resume.reached_step or 0) * dt}
    return segments + [{"segment": resume.segment, "started": rundir.now(), "from_time_s": resume.step * dt}]


def check_inside(plan: RunPlan, trajectory: Trajectory, deck: Path) -> dict[str, Any]:
    """Every engine ends a run whose bodies left the domain the same way (LIGGGHTS drops such bodies,
    YADE and cocd would carry them on), counting them by one rule (post.lost): an EngineError, or with
    the case's `lost_bodies: drop` their states NaN from then on and the record's entries (lost
    bodies, a warning) returned."""
    lost = lost_bodies(trajectory, plan.domain.lower, plan.domain.upper)
    if len(lost) and plan.case.lost_bodies == "drop":
        drop_lost(trajectory, lost)
        return {"lost_bodies": lost.as_records(), "warning": lost.message("dropped from then on (lost_bodies: drop)")}
    if len(lost):
        log = deck.parent / checkpoint.segment_name(LOG_NAME, plan.segment)
        raise EngineError(lost.message(), deck, log, log_tail(log)[-TAIL_LINES:])
    return {}


def audit_overlaps(plan: RunPlan, trajectory: Trajectory, frames: slice = slice(None)) -> dict[str, Any] | None:
    """The overlap audit (post.overlaps) of the plan's shaped bodies over the trajectory's frames
    (`frames` of them); None for a run without shaped bodies."""
    if not plan.shapes:
        return None
    dt = plan.schedule.dt
    walls = [(wall.name, triangles, plan.removals[wall.name] * dt if wall.name in plan.removals else None)
             for wall, triangles in zip(plan.case.walls, plan.wall_triangles)]
    first = trajectory.n_bodies - len(plan.shapes)  # shaped bodies come after the spheres
    return overlaps.audit(plan.shapes, first, trajectory.time[frames], trajectory.position[frames], trajectory.orientation[frames], walls)


def ensure_run(
    case: Case,
    root: Path,
    what: str,
    state_file: Callable[[Path], Path | None] = lambda directory: None,
    progress: Callable[[float, float], None] | None = None,
    timeout: float | None = None,
    options: RunOptions | None = None,
) -> tuple[Path, bool]:
    """Run `case` once under root/<run id>/ and reuse it afterwards. Returns (directory, reused).

    The directory's lock serialises processes that need the same run (campaign workers, say): the
    first runs it, the others wait and reuse it. A run is reused only when it is completed and
    current (rundir.status: the run of this very id, its sealed results and saved state intact) and
    the state file it must leave (`state_file(directory)`, if any) exists; an interrupted attempt
    with a checkpoint continues from it, any other failed, interrupted or stale attempt is moved to
    root/attic, and the new run's record says so (`set_aside`: where, and why). `what` names the run
    in errors ("the packing run failed: …").
    """
    directory = root / rundir.run_id(case, build_stamp(case.engine.value), case_dir=root)
    try:
        with rundir.locked(directory, wait=True):
            return _ensure_locked(case, root, directory, what, state_file, progress, timeout, options)
    except rundir.Unlockable as error:
        required = state_file(directory)
        if directory.is_dir() and rundir.status(directory, builds=build_stamp, held=True, expected_id=directory.name) == "completed" \
                and (required is None or required.is_file()):
            return directory, True  # a finished run in a read-only directory: read, never written
        raise CaseError(f"the {what} directory: {error}; give a writable one") from None


def _ensure_locked(case: Case, root: Path, directory: Path, what: str, state_file: Callable[[Path], Path | None],
                   progress: Callable[[float, float], None] | None, timeout: float | None,
                   options: RunOptions | None) -> tuple[Path, bool]:
    """ensure_run with the directory's lock held."""
    required = state_file(directory)
    state = rundir.status(directory, builds=build_stamp, held=True, expected_id=directory.name)
    if state == "completed" and (required is None or required.is_file()):
        return directory, True
    plan = make_plan(case, root)
    set_aside = None
    if rundir.holds_attempt(directory) and resume_point(plan, directory) is None:
        why = (rundir.why_stale(directory, rundir.read_record(directory) or {}, builds=build_stamp, expected_id=directory.name)
               if state == "stale" else "its saved state is missing" if state == "completed" else f"it was {state}")
        set_aside = {"attic": str(rundir.retire(directory, root)), "why": why}
    try:
        record = run_locked(case, root, directory, progress, timeout, get_adapter(case.engine.value, options), plan)
    except EngineError as error:
        raise EngineError(f"the {what} run failed: {error.summary}", error.deck, error.log, error.tail) from None
    if set_aside:  # one line in its record: what was there before, why it no longer stood, where it went
        rundir.write_record(directory, {**record, "set_aside": set_aside})
    return directory, False
