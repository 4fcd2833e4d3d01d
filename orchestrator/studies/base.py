"""One skeleton for every study: prepare once → release → measure → report.

A study kind (avalanche, collapse) says how its study file becomes a preparation case (bricks
packed in the release box, a column rained behind its gate) and a release case, and how a release
is measured; this module does the rest the same way for all of them:

1. the preparation runs once under a content address (`runner.ensure_run`) in a shared directory
   (default: beside the study's directory), so studies that differ only after it reuse it;
2. the release runs in outdir/run (a finished release is reused: a rerun only measures again);
3. the kind measures the release: the report (report.json) and arrays too large for JSON;
4. report.json records the preparation, the study and whether the release was already there.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any, Callable, ClassVar

import numpy as np
from pydantic import BaseModel

from orchestrator.case import Case, CaseError, parse_model, read_yaml
from orchestrator.engines import RunOptions
from orchestrator.results import RELEASE_DIR, REPORT, Trajectory, read_results  # noqa: F401  (the study layout, re-exported)
from orchestrator.runner import RESULTS, ensure_run, run_case



StageProgress = Callable[[str], Callable[[float, float], None] | None]


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

    # -- shared ---------------------------------------------------------------------------------
    def parse(self, data: object, source: str) -> Any:
        return parse_model(self.model, data if data is not None else {}, source)

    def load(self, path: Path) -> Any:
        return self.parse(read_yaml(path, f"{self.name} study"), str(path))

    def run(self, study: Any, outdir: Path, progress: StageProgress | None = None, shared: Path | None = None,
            timeout: float | None = None, options: RunOptions | None = None) -> dict[str, Any]:
        """Prepare (or reuse the preparation in `shared`), release, measure; returns the report.
        options: how the engines run (the kind's processor_grid is the default split)."""
        options = dataclasses.replace(options or RunOptions(), default_grid=self.processor_grid)
        return run_study(self, study, outdir, progress, shared, timeout, options)


def run_study(kind: StudyKind, study: Any, outdir: Path, progress: StageProgress | None, shared: Path | None,
              timeout: float | None, options: RunOptions) -> dict[str, Any]:
    outdir.mkdir(parents=True, exist_ok=True)
    release_dir = outdir / RELEASE_DIR
    record = outdir / f"{kind.preparation}.json"
    finished_before = (release_dir / RESULTS).exists()
    if not finished_before:
        root = shared if shared is not None else outdir.resolve().parent / kind.shared_dir
        prepared = kind.preparation_case(study)
        directory, reused = ensure_run(prepared, root, kind.preparation, lambda d: kind.state_file(study, d),
                                       progress(kind.preparation) if progress else None, timeout, options)
        packed = read_results(directory / RESULTS)
        if not np.isfinite(packed.position[-1]).all():
            raise CaseError(f"{kind.preparation} {directory}: {kind.lost_bodies}")
        record.write_text(json.dumps({"directory": str(directory), "reused": reused}, indent=2) + "\n")
        release = kind.release_case(study, prepared, packed, kind.state_file(study, directory))
        run_case(release, outdir, release_dir, progress=progress("release") if progress else None, timeout=timeout, options=options)
    trajectory = read_results(release_dir / RESULTS)
    report, arrays = kind.measure(study, trajectory, release_dir)
    shared_record = json.loads(record.read_text()) if record.exists() else {}
    report[kind.preparation] = {**report.get(kind.preparation, {}), **shared_record}
    report["study"] = study.model_dump(mode="json")
    report["finished_before"] = finished_before  # a rerun's reader: nothing ran now
    if kind.arrays_file and arrays:
        np.savez_compressed(outdir / kind.arrays_file, **arrays)
    (outdir / REPORT).write_text(json.dumps(report, indent=2) + "\n")
    return report
