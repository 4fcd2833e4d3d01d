"""What a submitted job runs (`demorch slurm-job`): the case in its run directory, stopped before the
job's time limit, and the same job script submitted again while the run is unfinished.

The run itself is `demorch run CASE -o RUNDIR` in a process group of its own, so it continues from
the newest checkpoint a cut-off job left (runner.resume_point). SLURM sends USR1 to the job's batch
shell (this process, which took the shell's place) `margin` seconds before the limit: the run and
its engine get SIGTERM, then SIGKILL after GRACE_S; the run directory then holds a cut-off run
(run.json `running`, the lock free), as after any kill. The job then submits its own script again,
to start once it has ended (--dependency=afterany), when all of these hold: the run is unfinished,
it made progress in this job (a sealed checkpoint newer than the one it started from: else the next
job would only do the same again) and fewer than `max_restarts` resubmissions came before. TERM or
INT (scancel, or the limit reached without the early signal) stop the run without a resubmission.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path
from types import FrameType

from orchestrator import rundir
from orchestrator.engines import build_stamp
from orchestrator.engines.base import die_with_parent
from orchestrator.engines.options import RunOptions
from orchestrator.plan import RunPlan
from orchestrator.runner import resume_point
from orchestrator.slurm import record
from orchestrator.slurm.commands import SlurmError, sbatch
from orchestrator.slurm.script import demorch

GRACE_S = 60.0  # s a stopped run gets to end before it is killed (well within the margin, at least 120 s)
POLL_S = 1.0  # s between looks at the run while it is being stopped
OUTSIDE_SLURM = "local"  # the job id of the script run by hand, outside SLURM


@dataclass(frozen=True)
class Outcome:
    """How the job ended: `outcome` as recorded (slurm.record), a line for the job's log, the exit code."""

    outcome: str
    message: str
    code: int


def run_command(case: Path, engine: str, directory: Path, options: RunOptions) -> list[str]:
    """`demorch run` of the case in `directory` with the run options (MPI processes, checkpoint interval)."""
    return [*demorch(options.processes(), options.checkpoint_interval), "run", str(case), "--engine", engine, "--output", str(directory)]


class _Stop:
    """The signal handler: USR1 stops the run for a resubmission (`cut`), TERM and INT for good (`stopped`)."""

    def __init__(self) -> None:
        self.reason: str | None = None
        self.child: subprocess.Popen | None = None

    def __call__(self, signum: int, frame: FrameType | None) -> None:
        self.reason = self.reason or ("cut" if signum == signal.SIGUSR1 else "stopped")
        self.signal(signal.SIGTERM)

    def signal(self, signum: int) -> None:
        """Send `signum` to the run and its engine (one process group), if they still run."""
        if self.child is not None and self.child.poll() is None:
            os.killpg(self.child.pid, signum)


def _run(command: list[str], stop: _Stop) -> int:
    """Run `command` in a process group of its own until it ends; once stopped, kill it after GRACE_S."""
    stop.child = subprocess.Popen(command, start_new_session=True, preexec_fn=die_with_parent, stdin=subprocess.DEVNULL)
    if stop.reason is not None:  # the signal came before the run started
        stop.signal(signal.SIGTERM)
    stopped_at: float | None = None
    while True:
        try:
            return stop.child.wait(timeout=POLL_S)
        except subprocess.TimeoutExpired:
            if stop.reason is not None:
                stopped_at = stopped_at or time.monotonic()
                if time.monotonic() - stopped_at > GRACE_S:
                    stop.signal(signal.SIGKILL)


def _checkpoint_step(plan: RunPlan, directory: Path) -> int:
    """The step of the checkpoint a run in `directory` would continue from (-1: none)."""
    point = resume_point(plan, directory)
    return -1 if point is None else point.step


def run_job(command: list[str], plan: RunPlan, directory: Path, max_restarts: int, job_id: str | None = None) -> Outcome:
    """Run `command` (run_command) in this job and conclude: record the outcome, resubmit if due.

    plan: the case's plan (to find the checkpoint the run continues from). job_id: this job's
    (default $SLURM_JOB_ID; OUTSIDE_SLURM when unset)."""
    stop = _Stop()  # first: a signal from now on stops the run (before the run starts: it does not start)
    for signum in (signal.SIGUSR1, signal.SIGTERM, signal.SIGINT):
        signal.signal(signum, stop)
    job_id = job_id or os.environ.get("SLURM_JOB_ID") or OUTSIDE_SLURM
    known = any(job.get("job_id") == job_id for job in record.read(directory)["jobs"])
    entry = record.update(directory, job_id, started=rundir.now(), **({} if known else {"restart": 0}))
    if rundir.status(directory, builds=build_stamp) == "completed":
        return _finish(directory, job_id, Outcome("completed", f"{directory}: the run is complete already; nothing to do", 0))
    started_from = _checkpoint_step(plan, directory)
    returncode = _run(command, stop) if stop.reason is None else 0
    return _finish(directory, job_id, _conclude(plan, directory, job_id, int(entry.get("restart", 0)), max_restarts, stop.reason,
                                                returncode, started_from))


def _conclude(plan: RunPlan, directory: Path, job_id: str, restart: int, max_restarts: int, reason: str | None, returncode: int,
              started_from: int) -> Outcome:
    if rundir.status(directory, builds=build_stamp) == "completed":
        return Outcome("completed", f"{directory}: the run is complete (results.h5)", 0)
    if reason == "stopped":
        return Outcome("stopped", f"{directory}: the run was stopped (cancelled, or the time limit came without the early signal); "
                                  "`demorch submit` again continues it", 1)
    if reason is None:
        return Outcome("failed", f"{directory}: the run failed (exit status {returncode}); see run.json and this job's .err log",
                       returncode or 1)
    if _checkpoint_step(plan, directory) <= started_from:
        return Outcome("cut", f"{directory}: the job ended before the run wrote a new checkpoint; not resubmitted (a longer --time "
                              "or a shorter --checkpoint-interval lets it progress)", 1)
    if restart >= max_restarts:
        return Outcome("cut", f"{directory}: cut at the time limit after {restart} restarts (--max-restarts {max_restarts}); "
                              "`demorch submit` again continues it", 1)
    script = record.jobs_dir(directory) / record.SCRIPT
    try:
        following = sbatch(script, after=None if job_id == OUTSIDE_SLURM else job_id)
    except SlurmError as error:
        return Outcome("cut", f"{directory}: cut at the time limit; the resubmission failed: {error}", 1)
    record.update(directory, following, restart=restart + 1, submitted=rundir.now())
    record.update(directory, job_id, next=following)
    return Outcome("cut", f"{directory}: cut at the time limit; job {following} continues it (restart {restart + 1} of {max_restarts})", 0)


def _finish(directory: Path, job_id: str, outcome: Outcome) -> Outcome:
    """Record how the job ended."""
    fields = {"ended": rundir.now(), "outcome": outcome.outcome}
    if outcome.code != 0:
        fields["note"] = outcome.message
    record.update(directory, job_id, **fields)
    return outcome
