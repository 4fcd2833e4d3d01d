"""The job script of one run (`demorch submit`): SLURM's directives and the one command the job runs.

The job asks for `ntasks` tasks (the run's MPI processes), the wall time, and USR1 to its batch
shell `margin` seconds before the limit. The script's command (`demorch slurm-job`, in place of the
shell, so it receives the signal) runs the case in the run directory, continuing from its newest
checkpoint, stops it on USR1 and submits the same script again while the run is unfinished
(orchestrator.slurm.job). Every value in the script is checked (slurm.values) or shell-quoted.
"""

from __future__ import annotations

import shlex
import sys
from dataclasses import dataclass
from pathlib import Path

from orchestrator.engines.options import MAX_PROCESSES
from orchestrator.slurm import record
from orchestrator.slurm.values import MAX_SIGNAL_S, check_name, check_path, margin_seconds, walltime_seconds
from orchestrator.validation import CaseError

MAX_RESTARTS = 1000


def demorch(processes: int, checkpoint_interval: float | None, python: Path | str = sys.executable) -> list[str]:
    """`demorch` as `python -m orchestrator.cli` (no virtual environment to activate in a job), with the
    run options: MPI processes, simulated seconds between checkpoints (None: the default)."""
    words = [str(python), "-m", "orchestrator.cli", "--mpi", str(processes)]
    return words + (["--checkpoint-interval", repr(checkpoint_interval)] if checkpoint_interval is not None else [])


@dataclass(frozen=True)
class JobRequest:
    """One run as a SLURM job.

    case: the case file. engine: the engine that runs it. directory: the run directory (absolute, on
    a file system the nodes share). name: the job's name (the case's). ntasks: SLURM tasks = MPI
    processes of the run. walltime: each job's limit, [D-]HH:MM:SS. nodes: nodes to spread the tasks
    over (None: SLURM's choice). partition, account: SLURM's -p and -A (None: the cluster's default).
    max_restarts: resubmissions after the first job. checkpoint_interval: simulated seconds between
    checkpoints (None: the run options' default, a tenth of the run). python: the interpreter that
    has this package (default: this one).
    """

    case: Path
    engine: str
    directory: Path
    name: str
    ntasks: int
    walltime: str
    nodes: int | None = None
    partition: str | None = None
    account: str | None = None
    max_restarts: int = 10
    checkpoint_interval: float | None = None
    python: Path = Path(sys.executable)

    def check(self) -> None:
        """A one-line CaseError naming the option of the first value that cannot go into the script."""
        walltime_seconds(self.walltime, "--time")
        check_name(self.name, "case name")
        check_path(self.directory, "--output")
        for option, value in (("--partition", self.partition), ("--account", self.account)):
            if value is not None:
                check_name(value, option)
        if not 1 <= self.ntasks <= MAX_PROCESSES:
            raise CaseError(f"--ntasks={self.ntasks}: allowed range: 1 to {MAX_PROCESSES}")
        if self.nodes is not None and not 1 <= self.nodes <= self.ntasks:
            raise CaseError(f"--nodes={self.nodes}: allowed range: 1 to --ntasks ({self.ntasks})")
        if not 0 <= self.max_restarts <= MAX_RESTARTS:
            raise CaseError(f"--max-restarts={self.max_restarts}: allowed range: 0 to {MAX_RESTARTS}")

    def margin(self) -> int:
        """Seconds before the limit at which the run is stopped (slurm.values.margin_seconds)."""
        return min(MAX_SIGNAL_S, margin_seconds(walltime_seconds(self.walltime, "--time")))

    def path(self) -> Path:
        return record.jobs_dir(self.directory) / record.SCRIPT

    def command(self) -> list[str]:
        """What the job runs: this package's `demorch slurm-job` on the case, with the MPI processes."""
        return [*demorch(self.ntasks, self.checkpoint_interval, self.python), "slurm-job", str(self.case), "--engine", self.engine,
                "--output", str(self.directory), "--max-restarts", str(self.max_restarts)]

    def text(self) -> str:
        """The job script."""
        self.check()
        logs = record.jobs_dir(self.directory)
        directives = [f"--job-name={self.name}", f"--ntasks={self.ntasks}", f"--time={self.walltime}",
                      f"--signal=B:USR1@{self.margin()}", f"--output={logs}/slurm-%j.out", f"--error={logs}/slurm-%j.err"]
        optional = {"--nodes": self.nodes, "--partition": self.partition, "--account": self.account}
        directives += [f"{option}={value}" for option, value in optional.items() if value is not None]
        return "\n".join([
            "#!/bin/bash",
            *(f"#SBATCH {directive}" for directive in directives),
            "# Written by `demorch submit`. The job runs the case on its tasks (MPI processes), continuing the",
            "# run from its newest checkpoint. SLURM sends USR1 shortly before the time limit: the run is",
            f"# stopped and, unless it is finished, this script is submitted again (at most {self.max_restarts} times).",
            f"exec {shlex.join(self.command())}",
            "",
        ])

    def write(self) -> Path:
        """Write the script into the run directory's jobs/ (executable) and return its path."""
        path = self.path()
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(self.text())
        path.chmod(0o755)
        return path
