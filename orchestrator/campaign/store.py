"""Content-addressed run directories of a campaign, their status, and the campaign index.

A run's id is the hash of its canonical (sorted, normalised) validated case, so the same case always
lands in the same directory: relaunching skips it when complete, and a crash never duplicates it.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import os
import shutil
from pathlib import Path
from typing import Any

import h5py
import pandas as pd
from pydantic import BaseModel

from ..runner import RESULTS, RUN_RECORD

RUNS = "runs"
ATTIC = "attic"
POINTS = "points.json"
INDEX = "index.parquet"
WORKER_PID = "worker.pid"


def run_id(case: BaseModel) -> str:
    """Hash of the canonical JSON of a validated case (or study): the same inputs, the same id."""
    canonical = json.dumps(case.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(canonical.encode()).hexdigest()[:16]


def run_dir(campaign_dir: Path, identifier: str) -> Path:
    return campaign_dir / RUNS / identifier


def _pid_alive(pid: int) -> bool:
    """True for a live process; a zombie (killed, not yet reaped by init) counts as dead."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return True
    return state not in ("Z", "X")


def status(directory: Path) -> str:
    """pending | completed | failed | running (a live worker holds it) | incomplete (its worker died)."""
    record_path = directory / RUN_RECORD
    if not record_path.exists():
        return "incomplete" if directory.exists() and any(directory.iterdir()) else "pending"
    try:
        record = json.loads(record_path.read_text())
    except (OSError, json.JSONDecodeError):
        return "incomplete"
    # A study's record points at its release's results (run/results.h5); a case's lie beside it.
    if record.get("status") == "completed" and _results_readable(directory / record.get("results", RESULTS)):
        return "completed"
    if record.get("status") == "failed":
        return "failed"
    pid_file = directory / WORKER_PID
    if pid_file.exists():
        try:
            if _pid_alive(int(pid_file.read_text())):
                return "running"
        except ValueError:
            pass
    return "incomplete"


def _results_readable(path: Path) -> bool:
    try:
        with h5py.File(path, "r") as store:
            return "frames/position" in store
    except (OSError, KeyError):
        return False


def retire(directory: Path, campaign_dir: Path) -> Path:
    """Move a dead or failed attempt aside (never delete what was computed) so it can be rerun."""
    attic = campaign_dir / ATTIC
    attic.mkdir(exist_ok=True)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S-%f")
    target = attic / f"{directory.name}-{stamp}"
    shutil.move(str(directory), target)
    return target


def write_points(campaign_dir: Path, points: dict[str, dict[str, Any]]) -> None:
    path = campaign_dir / POINTS
    known = json.loads(path.read_text()) if path.exists() else {}
    known.update(points)
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text(json.dumps(known, indent=1, sort_keys=True))
    os.replace(temporary, path)


def build_index(campaign_dir: Path) -> pd.DataFrame:
    """One row per run: parameters, status, timings, versions and every scalar metric; saved as parquet."""
    points_path = campaign_dir / POINTS
    points = json.loads(points_path.read_text()) if points_path.exists() else {}
    rows = []
    for identifier, parameters in points.items():
        directory = run_dir(campaign_dir, identifier)
        row: dict[str, Any] = {"run_id": identifier, "status": status(directory)}
        row.update({f"param.{k}": v for k, v in parameters.items()})
        record_path = directory / RUN_RECORD
        if record_path.exists():
            try:
                record = json.loads(record_path.read_text())
            except json.JSONDecodeError:
                record = {}
            row.update(
                wall_time_s=record.get("wall_time_s"),
                engine=record.get("engine"),
                engine_version=record.get("engine_version"),
                contact_build=record.get("contact_build"),
                error=record.get("error"),
            )
            row.update({f"metric.{k}": v for k, v in (record.get("metrics") or {}).items()})
        rows.append(row)
    table = pd.DataFrame(rows)
    if not table.empty:
        temporary = campaign_dir / (INDEX + ".tmp")
        table.to_parquet(temporary, index=False)
        os.replace(temporary, campaign_dir / INDEX)
    return table
