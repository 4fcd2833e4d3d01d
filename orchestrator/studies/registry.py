"""The kinds a campaign can launch, by name: one dict, one error listing them (studies.launch).

A plain case is one kind among the studies: campaigns launch every kind the same way.
"""

from __future__ import annotations

from orchestrator.case import CaseError
from orchestrator.studies.avalanche.study import KIND as AVALANCHE
from orchestrator.studies.collapse.study import KIND as COLLAPSE
from orchestrator.studies.launch import CASE, LaunchKind

# Order matters for detection: a case file (`bodies`) is a case whatever else it has; a collapse
# study file also has `release`, so its keys are tried before the avalanche's.
LAUNCH_KINDS: dict[str, LaunchKind] = {kind.name: kind for kind in (CASE, COLLAPSE, AVALANCHE)}


def launch_kind(name: str) -> LaunchKind:
    """The kind named `name`; CaseError listing the kinds there are."""
    try:
        return LAUNCH_KINDS[name]
    except KeyError:
        raise CaseError(f"kind: unknown kind {name!r}; allowed: {', '.join(LAUNCH_KINDS)}") from None


def detect(data: object) -> str:
    """The name of the first kind whose keys a file's mapping has; a case when none does."""
    if isinstance(data, dict):
        for kind in LAUNCH_KINDS.values():
            if kind.detect(data):
                return kind.name
    return CASE.name
