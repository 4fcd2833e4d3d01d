"""One skeleton for every study: prepare once → release → measure → report.

A study kind (avalanche, collapse) says how its study file becomes a preparation case (bricks
packed in the release box, a column rained behind its gate) and a release case, and how a release
is measured; this module does the rest the same way for all of them:

1. the preparation runs once under a content address (`runner.ensure_run`) in a shared directory
   (default: beside the study's directory), so studies that differ only after it reuse it;
2. the release runs in outdir/run (a finished release is reused: a rerun only measures again);
3. the kind measures the release: the report (report.json) and arrays too large for JSON;
4. report.json records the preparation, the study and whether the release was already there.

A study directory is content-addressed like a run: `study.json` holds the study's id (rundir.run_id
of the study, with today's build) from before its release starts, and a finished release is reused
only under the same id. A directory holding another study's products (the study file was edited
since, or the code that runs it changed) has them set aside in the attic beside it, with one line
in the report (`set_aside`) saying why, and the study runs again.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import shutil
import time
from pathlib import Path
from typing import Any, Callable, ClassVar

import numpy as np
from pydantic import BaseModel

from orchestrator import rundir
from orchestrator.case import Case, CaseError, parse_model, read_yaml
from orchestrator.engines import RunOptions, build_stamp
from orchestrator.results import (CAMPAIGN_RECORD, RELEASE_DIR, REPORT, RESULTS, RUN_RECORD, STUDY_RECORD, Trajectory, read_json,  # noqa: F401  (the study layout, re-exported)
                                  read_results)
from orchestrator.plan import make_plan
from orchestrator.post import overlaps
from orchestrator.runner import audit_overlaps, ensure_run, resumable, run_case



StageProgress = Callable[[str], Callable[[float, float], None] | None]
# A row of an ensemble's table: metric, seed → value, the members' mean, lowest, highest, the
# reference beside the mean and its verdict (studies.ensemble).
EnsembleRow = tuple[str, dict[int, float], float, float, float, str, str]


def ensemble_row(name: str, values: dict[int, float], mean: float, reference: str, verdict: str) -> EnsembleRow:
    """One ensemble row; its range over the members' finite values (NaN when none is)."""
    finite = [float(v) for v in values.values() if np.isfinite(v)]
    return (name, values, mean, min(finite) if finite else float("nan"), max(finite) if finite else float("nan"), reference, verdict)


class StudyKind:
    """What a kind of study supplies to the skeleton; subclasses set the class attributes."""

    name: ClassVar[str]  # the campaign `kind:` value
    model: ClassVar[type[BaseModel]]  # the validated study file
    detect_keys: ClassVar[frozenset[str]]  # top-level keys that mark a study file of this kind
    preparation: ClassVar[str]  # what the preparation is called ("packing"): report key and errors
    shared_dir: ClassVar[str]  # default directory of the shared preparations, beside the study's
    lost_bodies: ClassVar[str]  # the error when bodies left the domain while preparing
    arrays_file: ClassVar[str | None] = None  # npz beside report.json for arrays too big for JSON
    processor_grid: ClassVar[str | None] = None  # default MPI split (the user's setting wins)

    def preparation_case(self, study: Any) -> Case:
        raise NotImplementedError

    def prepare(self, study: Any, root: Path, progress: StageProgress | None, timeout: float | None,
                options: RunOptions) -> tuple[Case, Path, bool, dict[str, Any]]:
        """Run (or reuse) the preparation under `root`: (the case that made it, its directory, whether
        it was reused, what else the preparation's record keeps). One case by default; a kind may run
        several and keep one (a search)."""
        prepared = self.preparation_case(study)
        directory, reused = ensure_run(prepared, root, self.preparation, lambda d: self.state_file(study, d),
                                       progress(self.preparation) if progress else None, timeout, options)
        return prepared, directory, reused, {}

    def state_file(self, study: Any, directory: Path) -> Path | None:
        """The state file the preparation must leave for the release (None: none)."""
        return None

    def release_case(self, study: Any, prepared: Case, packed: Trajectory, state: Path | None) -> Case:
        raise NotImplementedError

    def measure(self, study: Any, trajectory: Trajectory, release_dir: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """The report (JSON-able) and the arrays (saved to `arrays_file`)."""
        raise NotImplementedError

    def metrics(self, report: dict[str, Any]) -> dict[str, float]:
        """The report's scalar numbers, flat, for campaign tables and plots."""
        raise NotImplementedError

    def ensemble_rows(self, reports: dict[int, dict[str, Any]]) -> list["EnsembleRow"]:
        """The rows of an ensemble's table (seed → report of each member): by default every scalar
        metric, without references; a kind with references puts them beside the mean."""
        by_seed = {seed: self.metrics(report) for seed, report in reports.items()}
        rows: list[EnsembleRow] = []
        for name in sorted({name for values in by_seed.values() for name in values}):
            values = {seed: metrics[name] for seed, metrics in by_seed.items() if name in metrics}
            rows.append(ensemble_row(name, values, float(np.nanmean(list(values.values()))) if values else float("nan"), "", ""))
        return rows

    # -- shared ---------------------------------------------------------------------------------
    def parse(self, data: object, source: str) -> Any:
        return parse_model(self.model, data if data is not None else {}, source)

    def load(self, path: Path) -> Any:
        return self.parse(read_yaml(path, f"{self.name} study"), str(path))

    # -- as a campaign's launch kind (studies.launch) ---------------------------------------------
    fill_defaults: ClassVar[bool] = True  # a campaign varies a study with every field present

    def detect(self, data: dict[str, Any]) -> bool:
        return bool(self.detect_keys & set(data))

    def point(self, point_json: str, case_dir: Path) -> "StudyPoint":
        return StudyPoint(self, self.model.model_validate_json(point_json))

    def run(self, study: Any, outdir: Path, progress: StageProgress | None = None, shared: Path | None = None,
            timeout: float | None = None, options: RunOptions | None = None, held: bool = False) -> dict[str, Any]:
        """Prepare (or reuse the preparation in `shared`), release, measure; returns the report.
        options: how the engines run (the kind's processor_grid is the default split). The study holds
        outdir's lock throughout (rundir.Busy when another process holds it); held: the caller holds it."""
        options = dataclasses.replace(options or RunOptions(), default_grid=self.processor_grid)
        return run_study(self, study, outdir, progress, shared, timeout, options, held)


class StudyPoint:
    """A study as one campaign point: its products in the point's directory, its preparation shared
    by the campaign's points (<campaign>/<kind.shared_dir>), and a summary run.json that points at the
    release's results and holds the study's scalar metrics (so the index and plots treat it as any run)."""

    def __init__(self, kind: StudyKind, study: BaseModel) -> None:
        self.kind, self.inputs = kind, study

    def continues(self, directory: Path) -> bool:
        return resumable(directory / RELEASE_DIR, directory)

    def run(self, directory: Path, campaign_dir: Path, timeout: float | None, options: RunOptions,
            shared: Path | None = None) -> dict[str, Any]:
        started = time.perf_counter()
        study, kind = self.inputs, self.kind
        rundir.save_inputs(directory, study)
        report = kind.run(study, directory, shared=shared or campaign_dir / kind.shared_dir, timeout=timeout, options=options, held=True)
        release = rundir.read_record(directory / RELEASE_DIR) or {}
        shared = report[kind.preparation]
        record = {
            "status": "completed",
            "kind": kind.name,
            "run_id": report["study_id"],  # rundir.run_id of the study with today's build, as the study computed it
            "build": report["build"],
            "results": f"{RELEASE_DIR}/{RESULTS}",
            # the point stands for its release as sealed: results changed since make it stale (run again)
            "sealed": rundir.seal_outputs(directory, [f"{RELEASE_DIR}/{RESULTS}"]),
            "engine": release.get("engine"),
            "engine_version": release.get("engine_version"),
            "wall_time_s": time.perf_counter() - started,
            "preparation": shared.get("directory"),
            "preparation_reused": shared.get("reused"),
            "metrics": kind.metrics(report),
        }
        rundir.write_record(directory, record)
        return record




def run_study(kind: StudyKind, study: Any, outdir: Path, progress: StageProgress | None, shared: Path | None,
              timeout: float | None, options: RunOptions, held: bool = False) -> dict[str, Any]:
    refuse_foreign(kind, outdir, probe_lock=not held)
    created = not outdir.exists()
    try:
        outdir.mkdir(parents=True, exist_ok=True)
        lock = contextlib.nullcontext() if held else rundir.locked(outdir, wait=False)
    except OSError as error:
        raise _unwritable(outdir, error) from None
    try:
        with lock:  # one owner: taken before anything is set aside, held until the report is written
            refuse_foreign(kind, outdir, probe_lock=False)
            return _run_study(kind, study, outdir, progress, shared, timeout, options)
    except rundir.Busy:
        raise
    except BaseException:
        if created and not any(entry.name not in (STUDY_RECORD, *rundir.KEPT) for entry in outdir.iterdir()):
            shutil.rmtree(outdir, ignore_errors=True)  # a study that failed before making anything leaves no directory
        raise


def refuse_foreign(kind: StudyKind, outdir: Path, probe_lock: bool = True) -> None:
    """CaseError (one line) when `outdir` belongs to something else than a study of this kind: a
    campaign or a study over seeds (campaign.json), a run (its run.json not a study point's), or a
    study of the other kind (study.json); rundir.Busy when another process holds it (a study running there)."""
    if probe_lock and outdir.is_dir() and rundir.is_locked(outdir):  # probe_lock False: the caller holds it
        raise rundir.Busy(f"{outdir} is in use by another process")
    if (outdir / CAMPAIGN_RECORD).exists():
        raise CaseError(f"--output: {outdir} holds a study over seeds or a campaign ({CAMPAIGN_RECORD}); a study of one seed keeps a "
                        "directory of its own: choose another -o")
    run_kind = (read_json(outdir / RUN_RECORD) or {}).get("kind") if (outdir / RUN_RECORD).exists() else kind.name
    if run_kind != kind.name:
        raise CaseError(f"--output: {outdir} holds a run ({RUN_RECORD}), not a study; a study keeps a directory of its own: choose another -o")
    study_kind = (read_json(outdir / STUDY_RECORD) or {}).get("kind", kind.name)
    if study_kind != kind.name:
        raise CaseError(f"--output: {outdir} holds a {study_kind} study, not a {kind.name} one: choose another -o")


def _unwritable(outdir: Path, error: OSError) -> CaseError:
    return CaseError(f"{outdir}: the study directory cannot be made or written ({error.strerror or error}); give another -o")


def study_products(kind: StudyKind) -> tuple[str, ...]:
    """What a study writes in its directory (a campaign point's own record and inputs are not among them)."""
    return (RELEASE_DIR, REPORT, f"{kind.preparation}.json", "report", STUDY_RECORD) + ((kind.arrays_file,) if kind.arrays_file else ())


def _set_aside_other_study(kind: StudyKind, outdir: Path, study_id: str) -> dict[str, str] | None:
    """Move another study's products out of `outdir` (to the attic beside it) when its recorded id is
    not `study_id`; returns where and why, or None when the directory holds this study or nothing."""
    products = [name for name in study_products(kind) if (outdir / name).exists()]
    recorded = (read_json(outdir / STUDY_RECORD) or {}).get("study_id")
    if recorded == study_id or not (set(products) - {STUDY_RECORD}):
        return None
    why = (f"it holds the study {recorded}, made from other inputs or by another build than today's {study_id}" if recorded
           else "it holds a study with no id (made before studies were recorded)")
    attic = rundir.retire(outdir, outdir.resolve().parent, only=tuple(products))
    return {"attic": str(attic), "why": why}


def _unsound_release(release_dir: Path) -> str | None:
    """Why a finished release may not be measured again (its record is not a completed run's, it was
    never sealed, or a sealed output changed since: rundir.why_stale), or None when it may."""
    record = rundir.read_record(release_dir) or {}
    if record.get("status") != "completed":
        return f"has no completed record (status {str(record.get('status'))[:20]!r})"
    if not record.get("sealed"):
        return "was never sealed"
    return rundir.why_stale(release_dir, record)


def _resumed(stages: dict[str, Path | None]) -> dict[str, dict[str, float]]:
    """The stages run now that continued from a checkpoint (a run cut off earlier): how many segments
    each took and the simulated time computed twice (their run.json `segments`)."""
    resumed = {}
    for stage, directory in stages.items():
        record = (rundir.read_record(directory) or {}) if directory is not None else {}
        segments = record.get("segments") if isinstance(record.get("segments"), list) else []
        if len(segments) > 1:
            resumed[stage] = {"segments": len(segments), "simulated_time_lost_s": float(record.get("simulated_time_lost_s", 0.0))}
    return resumed


def _refuse_nested(kind: StudyKind, prepared: Case, directory: Path, packed: Trajectory) -> None:
    """CaseError (one line) when the preparation's last frame holds bodies inside each other: its
    run's overlap audit, or one made now of that frame for a run recorded without one."""
    audit = (rundir.read_record(directory) or {}).get("overlaps")
    if audit is None:
        audit = audit_overlaps(make_plan(prepared, directory.parent), packed, frames=slice(-1, None))
    refused = overlaps.refusal(audit, f"{kind.preparation} {directory}") if audit else None
    if refused:
        raise CaseError(refused)


def _run_study(kind: StudyKind, study: Any, outdir: Path, progress: StageProgress | None, shared: Path | None,
               timeout: float | None, options: RunOptions) -> dict[str, Any]:
    release_dir = outdir / RELEASE_DIR
    record = outdir / f"{kind.preparation}.json"
    build = build_stamp(study.engine.value)
    study_id = rundir.run_id(study, build)
    set_aside = _set_aside_other_study(kind, outdir, study_id)
    try:
        rundir.write_json_atomic(outdir / STUDY_RECORD, {"study_id": study_id, "kind": kind.name})
    except OSError as error:
        raise _unwritable(outdir, error) from None
    finished_before = (release_dir / RESULTS).exists()
    unsound = _unsound_release(release_dir) if finished_before else None
    if unsound:  # never re-reported from results changed since the release sealed them: set aside, run again
        set_aside = {"attic": str(rundir.retire(release_dir, outdir.resolve().parent)), "why": f"its release {unsound}"}
        finished_before = False
    if not finished_before:
        root = shared if shared is not None else outdir.resolve().parent / kind.shared_dir
        prepared, directory, reused, extra = kind.prepare(study, root, progress, timeout, options)
        packed = read_results(directory / RESULTS)
        if not np.isfinite(packed.position[-1]).all():
            raise CaseError(f"{kind.preparation} {directory}: {kind.lost_bodies}")
        _refuse_nested(kind, prepared, directory, packed)
        record.write_text(json.dumps({"directory": str(directory), "reused": reused, **extra}, indent=2) + "\n")
        release = kind.release_case(study, prepared, packed, kind.state_file(study, directory))
        run_case(release, outdir, release_dir, progress=progress("release") if progress else None, timeout=timeout, options=options)
    trajectory = read_results(release_dir / RESULTS)
    report, arrays = kind.measure(study, trajectory, release_dir)
    shared_record = json.loads(record.read_text()) if record.exists() else {}
    report[kind.preparation] = {**report.get(kind.preparation, {}), **shared_record}
    audits = {stage: (rundir.read_record(path) or {}).get("overlaps")
              for stage, path in ((kind.preparation, Path(shared_record.get("directory", ""))), ("release", release_dir))}
    if any(audits.values()):
        report["overlaps"] = {stage: overlaps.summary(audit) for stage, audit in audits.items() if audit}
    resumed = _resumed({kind.preparation: None if shared_record.get("reused") else Path(shared_record.get("directory", "")),
                        "release": None if finished_before else release_dir})
    if resumed:
        report["resumed"] = resumed
    report["study"] = study.model_dump(mode="json")
    report["study_id"] = study_id
    report["build"] = build
    report["finished_before"] = finished_before  # a rerun's reader: nothing ran now
    if set_aside:
        report["set_aside"] = set_aside
    if kind.arrays_file and arrays:
        np.savez_compressed(outdir / kind.arrays_file, **arrays)
    (outdir / REPORT).write_text(json.dumps(report, indent=2) + "\n")
    return report
