"""The jobs of one run: RUNDIR/jobs/record.json, beside the job script and the jobs' logs.

    {"max_restarts": 10,
     "jobs": [{"job_id": "101", "restart": 0, "submitted": "…", "started": "…", "ended": "…",
               "outcome": "cut", "next": "102"}, …]}

restart: 0 for the job `demorch submit` sent, k for the k-th resubmission after it. outcome:
completed; cut (stopped before its time limit: `next` is the job that continues, else `note` says
why none does); failed (the run failed: its run.json says why); stopped (cancelled, or killed at the
limit without the early signal). A job without an outcome is queued or running (squeue tells which).
Written by `demorch submit` and by the jobs, under jobs/.lock, atomically; the directory is never
retired with an attempt (rundir.KEPT).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from orchestrator import rundir

RECORD = "record.json"
SCRIPT = "job.sbatch"


def jobs_dir(directory: Path) -> Path:
    """Where a run directory keeps its job script, its jobs' logs and their record."""
    return directory / rundir.JOBS


def read(directory: Path) -> dict[str, Any]:
    """The run's job record ({"jobs": []} when it has none, or an unreadable one)."""
    record = rundir.read_json(jobs_dir(directory) / RECORD) or {}
    jobs = record.get("jobs")
    return {**record, "jobs": [job for job in jobs if isinstance(job, dict)] if isinstance(jobs, list) else []}


def update(directory: Path, job_id: str, **fields: Any) -> dict[str, Any]:
    """Add `fields` to the job `job_id` (appended when new) and return its entry."""
    with rundir.locked(jobs_dir(directory), wait=True):
        record = read(directory)
        entry = next((job for job in record["jobs"] if job.get("job_id") == job_id), None)
        if entry is None:
            entry = {"job_id": job_id}
            record["jobs"].append(entry)
        entry.update(fields)
        rundir.write_json_atomic(jobs_dir(directory) / RECORD, record)
    return entry


def settle(directory: Path, **settings: Any) -> None:
    """Set the record's own fields (max_restarts), keeping its jobs."""
    with rundir.locked(jobs_dir(directory), wait=True):
        rundir.write_json_atomic(jobs_dir(directory) / RECORD, {**read(directory), **settings})


def last_job(directory: Path) -> dict[str, Any] | None:
    """The newest job of the run (None: none was submitted)."""
    jobs = read(directory)["jobs"]
    return jobs[-1] if jobs else None
