"""The study kinds a campaign can vary, by name: one dict, one error listing them."""

from __future__ import annotations

from orchestrator.case import CaseError
from orchestrator.studies.avalanche.study import KIND as AVALANCHE
from orchestrator.studies.base import StudyKind
from orchestrator.studies.collapse.study import KIND as COLLAPSE

# Order matters for detection: a collapse study file also has `release`, so its keys are tried first.
STUDY_KINDS: dict[str, StudyKind] = {kind.name: kind for kind in (COLLAPSE, AVALANCHE)}


def study_kind(name: str) -> StudyKind:
    try:
        return STUDY_KINDS[name]
    except KeyError:
        raise CaseError(f"kind: unknown study kind {name!r}; allowed: case, {', '.join(STUDY_KINDS)}") from None


def detect(data: object) -> str:
    """`case`, or the study kind whose keys a study file has (a file with `bodies` is a case)."""
    if not isinstance(data, dict) or "bodies" in data:
        return "case"
    for kind in STUDY_KINDS.values():
        if kind.detect_keys & set(data):
            return kind.name
    return "case"
