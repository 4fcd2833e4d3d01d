"""What a campaign launches, whatever its kind: a point (validated inputs) run in its own directory.

Every kind in the registry (studies.registry: a plain case, an avalanche study, a collapse study)
turns a point's canonical JSON into a `Point`, which says whether a cut-off attempt in its directory
goes on from a checkpoint and runs it there, leaving the directory's run.json (rundir.write_record).
The campaign does the rest the same way for every kind: the lock, the status, the attic, failures.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol

from pydantic import BaseModel

from orchestrator.case import Case, CaseError, parse_case
from orchestrator.engines import RunOptions, get_adapter
from orchestrator.plan import RunPlan, make_plan
from orchestrator.runner import resumable, run_locked


class Point(Protocol):
    """One point of a campaign, validated: `inputs` are what its run id hashes."""

    inputs: BaseModel

    def continues(self, directory: Path) -> bool:
        """Whether the attempt cut off in `directory` goes on from its checkpoint (else it is retired)."""
        ...

    def run(self, directory: Path, campaign_dir: Path, timeout: float | None, options: RunOptions,
            shared: Path | None = None) -> dict[str, Any]:
        """Run the point in `directory` (lock held) and return its run.json record; EngineError or
        CaseError when it fails. campaign_dir holds what points of one campaign share; shared, when
        given, is where they share preparations instead."""
        ...


class LaunchKind(Protocol):
    """A kind of point a campaign varies (the campaign's `kind:`)."""

    name: str
    model: type[BaseModel]
    fill_defaults: bool  # vary the point with every field present (a study), or as written (a case)

    def parse(self, data: object, source: str) -> BaseModel: ...

    def detect(self, data: dict[str, Any]) -> bool:
        """Whether a file's top-level mapping is of this kind."""
        ...

    def point(self, point_json: str, case_dir: Path) -> Point: ...


class CasePoint:
    """A plain case: run as it is, in the point's directory (runner.run_locked writes its record)."""

    def __init__(self, case: Case, case_dir: Path) -> None:
        self.inputs, self.case_dir = case, case_dir
        try:  # made once for the point; None: the case does not pass its checks (running it records that)
            self.plan: RunPlan | None = make_plan(case, case_dir)
        except (CaseError, ValueError):
            self.plan = None

    def continues(self, directory: Path) -> bool:
        return self.plan is not None and resumable(directory, self.case_dir, self.plan)

    def run(self, directory: Path, campaign_dir: Path, timeout: float | None, options: RunOptions,
            shared: Path | None = None) -> dict[str, Any]:
        case = self.inputs
        assert isinstance(case, Case)
        return run_locked(case, self.case_dir, directory, None, timeout, get_adapter(case.engine.value, options), self.plan)


class CaseKind:
    """The plain case (a case file: `bodies`, walls, contacts) as a launch kind."""

    name = "case"
    model = Case
    fill_defaults = False

    def parse(self, data: object, source: str) -> Case:
        return parse_case(data, source=source)

    def detect(self, data: dict[str, Any]) -> bool:
        return "bodies" in data

    def point(self, point_json: str, case_dir: Path) -> CasePoint:
        return CasePoint(Case.model_validate_json(point_json), case_dir)


CASE = CaseKind()
