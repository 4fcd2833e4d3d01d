"""A campaign directory: its content-addressed runs, their status, and the campaign index.

Each point runs in runs/<run id> (rundir.run_id: the canonical case or study, the schedule and the
engine build), so the same point always lands in the same directory: relaunching skips it when
complete, and a template or plugin change gives new ids, so those points run again while the old
runs are reported `stale`.
"""

from __future__ import annotations

import fcntl
import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pandas as pd
from pydantic import BaseModel

from orchestrator import rundir
from orchestrator.case import CaseError
from orchestrator.engines import build_stamp
from orchestrator.rundir import retire
from orchestrator.studies.registry import launch_kind

RUNS = "runs"
POINTS = "points.json"
LATEST = "latest.json"  # the run ids of the newest launch's points: every other point is superseded
INDEX = "index.parquet"
CAMPAIGN = "campaign.json"  # which campaign the directory holds: its name, base file and designs
CAMPAIGN_LOCK = ".campaign.lock"

__all__ = ["RUNS", "POINTS", "INDEX", "CAMPAIGN", "run_dir", "status", "retire", "claim", "write_points", "build_index",
           "campaign_lock"]


def run_dir(campaign_dir: Path, identifier: str) -> Path:
    return campaign_dir / RUNS / identifier


def status(directory: Path, held: bool = False, model: type[BaseModel] | None = None) -> str:
    """rundir.status of a campaign run against today's build, its inputs read as `model` (default: the
    kind its record names); the run must be the one its directory is named for (a point directory
    stands for its run id). held: the caller holds the directory's lock."""
    if model is None:
        try:
            model = launch_kind(str((rundir.read_record(directory) or {}).get("kind", "case"))).model
        except ValueError:
            return "incomplete"
    return rundir.status(directory, model, builds=build_stamp, held=held, expected_id=directory.name)


@contextmanager
def campaign_lock(campaign_dir: Path) -> Iterator[None]:
    """Serialise the short read-modify-write steps of concurrent launches (points.json, the index)."""
    campaign_dir.mkdir(parents=True, exist_ok=True)
    with open(campaign_dir / CAMPAIGN_LOCK, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def claim(campaign_dir: Path, identity: dict[str, Any], parameters: set[str]) -> None:
    """Record that `campaign_dir` holds the campaign `identity` ({"name", "base": the base file's
    absolute path, "designs"}) in campaign.json, or raise CaseError, writing nothing, when it holds
    another one: its points.json and index would be overwritten. A relaunch of the same campaign
    (its base case edited, say) goes on. A campaign directory from before campaign.json is taken when
    its points vary the same `parameters` (the names of the varied fields)."""
    identity = json.loads(json.dumps(identity))  # as it reads back from the file
    with campaign_lock(campaign_dir):
        recorded = rundir.read_json(campaign_dir / CAMPAIGN)
        if recorded is not None:
            differs = [key for key in ("name", "base", "designs") if recorded.get(key) != identity[key]]
            held = f"campaign {recorded.get('name')!r} (base {recorded.get('base')})"
        else:
            points = rundir.read_json(campaign_dir / POINTS) if (campaign_dir / POINTS).exists() else {}
            ours = isinstance(points, dict) and all(isinstance(values, dict) for values in points.values())  # run id → its parameters
            if not ours or (not points and (campaign_dir / INDEX).exists()):
                raise CaseError(f"--output: {campaign_dir} holds a {POINTS} or {INDEX} that no campaign wrote (no {CAMPAIGN}, and no points a campaign writes); they would be overwritten: choose another -o")
            varied = {name for values in points.values() for name in values}
            differs = ["varied parameters"] if points and varied != parameters else []
            held = f"another campaign (varying {sorted(varied)})"
        if differs:
            raise CaseError(f"--output: {campaign_dir} holds {held}, and campaign {identity['name']!r} differs in its {' and '.join(differs)}; "
                            f"its {POINTS} and {INDEX} would be overwritten: choose another -o (relaunching that campaign there resumes it)")
        if recorded is None:
            _write(campaign_dir / CAMPAIGN, json.dumps(identity, indent=1, sort_keys=True))


def write_points(campaign_dir: Path, points: dict[str, dict[str, Any]]) -> None:
    """Add points (run id → varied parameters) to points.json, and make them the latest launch's
    (latest.json). Points already there are kept: an edited base case or a new build gives new ids,
    and the index then shows the older points as superseded."""
    path = campaign_dir / POINTS
    with campaign_lock(campaign_dir):
        known = rundir.read_json(path) or {}
        known.update(points)
        _write(path, json.dumps(known, indent=1, sort_keys=True))
        _write(campaign_dir / LATEST, json.dumps({"run_ids": sorted(points)}, indent=1))


def _write(path: Path, text: str) -> None:
    temporary = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    temporary.write_text(text)
    os.replace(temporary, path)


def latest_ids(campaign_dir: Path) -> set[str] | None:
    """The run ids of the newest launch's points (None: a campaign directory from before latest.json)."""
    latest = rundir.read_json(campaign_dir / LATEST)
    ids = latest.get("run_ids") if isinstance(latest, dict) else None
    return set(ids) if isinstance(ids, list) else None


def build_index(campaign_dir: Path) -> pd.DataFrame:
    """One row per run: parameters, status, timings, versions and every scalar metric; saved as parquet.

    A point the newest launch no longer has (its base case, a file it names or the build changed
    since) is `stale` with `superseded` true, whatever its own run says: one current row per point."""
    points = rundir.read_json(campaign_dir / POINTS) or {}
    latest = latest_ids(campaign_dir)
    rows = []
    for identifier, parameters in points.items():
        if not isinstance(parameters, dict) or not all(c.isalnum() for c in identifier):
            continue  # a damaged points.json: its run ids are hex digits, its parameters a mapping
        directory = run_dir(campaign_dir, identifier)
        superseded = latest is not None and identifier not in latest
        row: dict[str, Any] = {"run_id": identifier, "status": "stale" if superseded else status(directory), "superseded": superseded}
        row.update({f"param.{k}": v for k, v in parameters.items()})
        record = rundir.read_record(directory)
        if record is not None:
            row.update(
                wall_time_s=record.get("wall_time_s"),
                engine=record.get("engine"),
                engine_version=record.get("engine_version"),
                build=json.dumps(record.get("build"), sort_keys=True) if record.get("build") else None,
                error=record.get("error"),
            )
            row.update({f"metric.{k}": v for k, v in (record.get("metrics") or {}).items()})
        rows.append(row)
    table = pd.DataFrame(rows)
    if not table.empty:
        temporary = campaign_dir / f"{INDEX}.{os.getpid()}.tmp"
        table.to_parquet(temporary, index=False)
        os.replace(temporary, campaign_dir / INDEX)
    return table
