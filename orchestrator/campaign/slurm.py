"""Campaigns on a SLURM cluster through dask-jobqueue, with jobs that have a wall-time limit.

Each SLURM job is one Dask worker that runs one engine run at a time, with `processes` CPUs booked
for it (LIGGGHTS splits a run over that many MPI processes: the job script exports
DEMORCH_LIGGGHTS_MPI). A worker retires `margin` before its job's limit (Dask's --lifetime): the run
it held is cut off there, with its checkpoints on the shared file system, and the scheduler hands it
to a worker of a later job, which continues it from the last checkpoint (runner.resume_point). The
scheduler keeps `jobs` jobs queued or running (adapt), so a campaign goes on job after job, and lets
a run be cut off `max_cuts` times before it calls it failed (Dask's allowed-failures). The
scheduler runs in the process that calls start_cluster (the login node, say).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import Any

from orchestrator.slurm.values import check_name, margin_seconds, walltime_seconds


@dataclass(frozen=True)
class SlurmJobs:
    """What each SLURM job asks for and how many run at once.

    walltime: the job's limit, [D-]HH:MM:SS. jobs: jobs queued or running at once (one run each).
    processes: CPUs per job, the MPI processes of a run. memory: per job, e.g. "4GB".
    partition, account: SLURM's -p and -A. directives: more #SBATCH lines (e.g. "--exclusive").
    checkpoint_interval: simulated seconds between checkpoints (None: the run options' default);
    pick one a few minutes of wall time long. max_cuts: times a run may be cut off by a job's end.
    """

    walltime: str
    jobs: int
    processes: int = 1
    memory: str = "4GB"
    partition: str | None = None
    account: str | None = None
    directives: tuple[str, ...] = ()
    checkpoint_interval: float | None = None
    max_cuts: int = 100

    def seconds(self) -> int:
        """The wall-time limit in seconds; CaseError naming --walltime if malformed or too short."""
        return walltime_seconds(self.walltime, "--walltime")

    def check(self) -> None:
        """CaseError naming the option when the wall time, partition or account would not go into a job script as it is."""
        self.seconds()
        for option, value in (("--partition", self.partition), ("--account", self.account)):
            if value is not None:
                check_name(value, option)

    def margin(self) -> int:
        """Seconds before the limit at which a worker retires: 5 % of the wall time, at least 2 min
        (time for the engine to be stopped and the job to end cleanly)."""
        return margin_seconds(self.seconds())

    def cluster_options(self, environment: str = sys.prefix) -> dict[str, Any]:
        """Keyword arguments of dask_jobqueue.SLURMCluster; `environment`: the virtual environment
        the jobs activate (this one by default)."""
        prologue = [f"source {environment}/bin/activate", f"export DEMORCH_LIGGGHTS_MPI={self.processes}"]
        if self.checkpoint_interval is not None:
            prologue.append(f"export DEMORCH_CHECKPOINT_INTERVAL={self.checkpoint_interval!r}")
        lifetime = self.seconds() - self.margin()
        return {
            "cores": 1, "processes": 1,  # one Dask thread: one run at a time per job
            "job_cpu": self.processes, "memory": self.memory, "walltime": self.walltime,
            "queue": self.partition, "account": self.account, "job_extra_directives": list(self.directives),
            "job_script_prologue": prologue,
            "worker_extra_args": ["--lifetime", f"{lifetime}s", "--lifetime-stagger", "60s"],
            "scheduler_options": {"dashboard_address": None},
        }


def start_cluster(spec: SlurmJobs) -> Any:
    """A SLURMCluster whose scheduler runs here, adapting to `spec.jobs` jobs."""
    import dask
    from dask_jobqueue import SLURMCluster

    dask.config.set({"distributed.scheduler.allowed-failures": spec.max_cuts})
    cluster = SLURMCluster(**spec.cluster_options())
    cluster.adapt(minimum_jobs=spec.jobs, maximum_jobs=spec.jobs)
    return cluster


def job_script(spec: SlurmJobs) -> str:
    """The job script every job runs (what `demorch campaign slurm --dry-run` prints)."""
    from dask_jobqueue import SLURMCluster

    with SLURMCluster(**spec.cluster_options()) as cluster:
        return cluster.job_script()
