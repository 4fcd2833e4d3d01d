"""A study over seeds: its members run as the points of a campaign, their numbers gathered per metric.

A study file with `seeds:` (studies/seeds.py) is launched as a campaign of one point whose members
are its seeds (campaign.spec.expand makes one run per seed): each member is its own content-addressed
study directory (<outdir>/runs/<id>), run on the campaign's local pool or Dask, resumable, and a
member already run is reused, so adding a seed runs only it. A campaign over a study with seeds is
the same thing with more points. `gather` groups a campaign's newest points by everything but the
seed; ensemble.json in the campaign directory keeps every group with its numbers (studies.ensemble:
each metric's mean, standard deviation, range and per-seed values).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from orchestrator import rundir
from orchestrator.campaign import store
from orchestrator.campaign.spec import Campaign, CampaignSpec
from orchestrator.campaign.execute import Counts
from orchestrator.case import CaseError, read_yaml
from orchestrator.engines import RunOptions
from orchestrator.studies.registry import launch_kind
from orchestrator.results import REPORT, read_json
from orchestrator.studies.base import STUDY_RECORD
from orchestrator.studies.ensemble import summarize

ENSEMBLE = "ensemble.json"


@dataclass(frozen=True)
class Member:
    """One seed of an ensemble: its run directory, status (campaign.store.status) and report (None
    until it completes)."""

    seed: int
    directory: Path
    status: str
    report: dict[str, Any] | None


@dataclass(frozen=True)
class Group:
    """The members of one point of a campaign (every parameter but the seed the same)."""

    parameters: dict[str, Any]
    members: list[Member]

    @property
    def reports(self) -> dict[int, dict[str, Any]]:
        """seed → report of each completed member, by seed."""
        return {m.seed: m.report for m in sorted(self.members, key=lambda m: m.seed) if m.report is not None}


def study_campaign(kind: str, path: Path, engine: str | None = None) -> Campaign:
    """A study file with seeds as a campaign of one point (its members: the seeds)."""
    base_path = path.resolve()
    base = read_yaml(base_path, f"{kind} study")
    return Campaign(CampaignSpec(name=str(base.get("name", path.stem)), base=str(base_path), kind=kind, engine=engine), base, base_path)


def gather(campaign_dir: Path) -> list[Group]:
    """The newest launch's points of `campaign_dir` grouped by their parameters other than `seed`,
    each member with its status and, when completed (or stale: made by another build), its report."""
    points = rundir.read_json(campaign_dir / store.POINTS) or {}
    latest = store.latest_ids(campaign_dir)
    groups: dict[str, Group] = {}
    for identifier, parameters in sorted(points.items()):
        if (latest is not None and identifier not in latest) or not isinstance(parameters, dict):
            continue
        rest = {k: v for k, v in parameters.items() if k != "seed"}
        directory = store.run_dir(campaign_dir, identifier)
        state = store.status(directory)
        # a stale member (another build made it, or its point was superseded) still shows its numbers, flagged
        report = read_json(directory / REPORT) if state in ("completed", "stale") else None
        seed = int(parameters.get("seed", (report or {}).get("study", {}).get("seed", 0)))
        group = groups.setdefault(json.dumps(rest, sort_keys=True), Group(rest, []))
        group.members.append(Member(seed, directory, state, report))
    for group in groups.values():
        group.members.sort(key=lambda member: member.seed)
    return list(groups.values())


def write_ensembles(campaign_dir: Path, groups: list[Group], kind: Any) -> Path:
    """ensemble.json: each group's parameters, members (seed, run directory, status) and the
    summary of its metrics (summarize over the completed members; kind.metrics flattens a report)."""
    document = {"groups": [
        {"parameters": group.parameters,
         "members": [{"seed": m.seed, "directory": str(m.directory.relative_to(campaign_dir)), "status": m.status} for m in group.members],
         "metrics": summarize({seed: kind.metrics(report) for seed, report in group.reports.items()})}
        for group in groups]}
    path = campaign_dir / ENSEMBLE
    rundir.write_json_atomic(path, document)
    return path


def run_ensemble(kind: str, path: Path, outdir: Path, engine: str | None = None, jobs: int = 1, executor: str = "local",
                 dask_address: str | None = None, shared: Path | None = None, on_update: Callable[..., None] | None = None,
                 options: RunOptions | None = None) -> tuple[Counts, list[Group]]:
    """Run the study file `path` (with seeds) over its seeds in `outdir` (a campaign directory), `jobs`
    members at once; members already completed are reused, failed ones are tried again. Returns the
    launch's counts and the groups (one here), and writes ensemble.json. CaseError (nothing run) when
    `outdir` holds a single study's products: an ensemble and a study do not share a directory."""
    from orchestrator.campaign.execute import run_campaign

    if (outdir / STUDY_RECORD).exists():
        raise CaseError(f"--output: {outdir} holds a study of one seed ({STUDY_RECORD}); an ensemble keeps its seeds in a directory "
                        "of its own: choose another -o")
    counts = run_campaign(study_campaign(kind, path, engine), outdir, jobs, executor, True, dask_address, on_update, options, shared=shared)
    groups = gather(outdir)
    write_ensembles(outdir, groups, launch_kind(kind))
    return counts, groups
