"""The SLURM commands a run needs: sbatch (submit a job script, read its job id), squeue and sacct
(a job's state). Each failure is a SlurmError of one line."""

from __future__ import annotations

import os
import re
import subprocess
from collections.abc import Mapping
from pathlib import Path

from orchestrator.validation import bounded

TIMEOUT_S = 60.0  # s a scheduler command may take before it counts as failed
_JOB_ID = re.compile(r"^(\d+)(?:;\S+)?$")  # sbatch --parsable: "ID" or "ID;CLUSTER"
_SUBMITTED = re.compile(r"Submitted batch job (\d+)")
KEPT_VARIABLES = ("SLURM_CONF",)  # the only SLURM_* variables a job passes to a job it submits


class SlurmError(RuntimeError):
    """A SLURM command is missing, failed or answered what cannot be read; the message is one line."""


def _call(command: list[str], env: Mapping[str, str] | None = None) -> str:
    """The command's standard output; SlurmError when it is missing, fails or hangs."""
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=TIMEOUT_S, env=None if env is None else dict(env),
                              stdin=subprocess.DEVNULL)
    except FileNotFoundError:
        raise SlurmError(f"{command[0]} is not on PATH: run this on a SLURM login node (or use --dry-run)") from None
    except subprocess.TimeoutExpired:
        raise SlurmError(f"{command[0]} gave no answer in {TIMEOUT_S:.0f} s") from None
    if done.returncode != 0:
        raise SlurmError(f"{command[0]} failed: {bounded(done.stderr or done.stdout, 300) or f'exit status {done.returncode}'}")
    return done.stdout


def parse_job_id(output: str) -> str:
    """The job id in sbatch's answer (`--parsable`: "ID" or "ID;CLUSTER"; else "Submitted batch job ID")."""
    lines = [line.strip() for line in output.splitlines() if line.strip()]
    parsable = _JOB_ID.match(lines[-1]) if lines else None
    found = parsable or _SUBMITTED.search(output)
    if found is None:
        raise SlurmError(f"sbatch answered no job id: {bounded(output, 200)!r}")
    return found.group(1)


def submission_environment(environ: Mapping[str, str]) -> dict[str, str]:
    """`environ` without the SLURM_* variables of the job that submits (its memory and task settings
    would be taken for the new job's), KEPT_VARIABLES excepted."""
    return {key: value for key, value in environ.items() if not key.startswith("SLURM_") or key in KEPT_VARIABLES}


def sbatch(script: Path, after: str | None = None) -> str:
    """Submit `script` and return its job id. after: a job id; the new job starts once that job has
    ended, however it ended (--dependency=afterany)."""
    command = ["sbatch", "--parsable"] + ([f"--dependency=afterany:{after}"] if after else []) + [str(script)]
    return parse_job_id(_call(command, submission_environment(os.environ)))


def job_state(job_id: str) -> str:
    """SLURM's state of a job: PENDING, RUNNING (squeue) or, once it left the queue, its final state
    (sacct: COMPLETED, TIMEOUT, CANCELLED, FAILED, …); "unknown" when neither knows it."""
    try:
        queued = _call(["squeue", "--noheader", "--jobs", job_id, "--format", "%T"]).split()
    except SlurmError:
        queued = []  # squeue fails for a job that has left the queue
    if queued:
        return queued[0]
    try:
        accounted = _call(["sacct", "--noheader", "--allocations", "--parsable2", "--jobs", job_id, "--format", "State"]).split()
    except SlurmError:
        accounted = []
    return accounted[0] if accounted else "unknown"


def is_live(state: str) -> bool:
    """Whether a job in this state may still run (queued, running, or being requeued)."""
    return state in ("PENDING", "RUNNING", "CONFIGURING", "COMPLETING", "REQUEUED", "RESIZING", "SUSPENDED")
