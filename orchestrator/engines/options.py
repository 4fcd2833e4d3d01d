"""How engines run, as opposed to what they compute: MPI processes, the processor grid, and how
often a run writes a checkpoint.

Never part of a case or a run id (a run computes the same on 1 or 4 processes). Passed explicitly
from the command line through studies and campaigns to the adapters, so a Dask worker on another
node gets the same settings as a local run. Precedence, each setting alone: the explicit option
(`demorch --mpi N`), then the environment (DEMORCH_LIGGGHTS_MPI, DEMORCH_LIGGGHTS_GRID), then a
study's preferred split (`default_grid`), then the engine's own choice.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import asdict, dataclass
from typing import Any

from orchestrator.validation import CaseError

MPI_ENV = "DEMORCH_LIGGGHTS_MPI"
CHECKPOINT_ENV = "DEMORCH_CHECKPOINT_INTERVAL"
# A run writes this many checkpoints by default (one per tenth of its duration): a killed run loses
# at most a tenth. The cost was measured (benchmarks/checkpoint_cost.py, docs/benchmarks.md).
CHECKPOINTS_PER_RUN = 10
GRID_ENV = "DEMORCH_LIGGGHTS_GRID"
MAX_PROCESSES = 256


@dataclass(frozen=True)
class RunOptions:
    """mpi_processes: MPI processes per run of an engine with capability `mpi` (None: environment, else 1).
    processor_grid: "Px Py Pz", each a count or * (None: environment, else default_grid, else "* * *").
    default_grid: a study's preferred split (the avalanche set-up is symmetric about y = 0: "1 * 1").
    checkpoint_interval: simulated seconds between checkpoints, 0 for none (None: environment, else
    a tenth of the run's duration); rounded to whole output intervals."""

    mpi_processes: int | None = None
    processor_grid: str | None = None
    default_grid: str | None = None
    checkpoint_interval: float | None = None

    def checkpoint_steps(self, duration: float, dt: float, output_every: int, total_steps: int) -> int | None:
        """Steps between checkpoints (a multiple of output_every), or None when the run writes none
        (interval 0, or not shorter than the run)."""
        if self.checkpoint_interval is not None:
            interval = check_interval(str(self.checkpoint_interval), "--checkpoint-interval")
        elif os.environ.get(CHECKPOINT_ENV, "").strip():
            interval = check_interval(os.environ[CHECKPOINT_ENV].strip(), CHECKPOINT_ENV)
        else:
            interval = duration / CHECKPOINTS_PER_RUN
        if interval <= 0.0:
            return None
        steps = max(1, round(interval / (output_every * dt))) * output_every  # the nearest frame, as wall removals
        return steps if steps < total_steps else None

    def processes(self) -> int:
        if self.mpi_processes is not None:
            return check_processes(str(self.mpi_processes), "--mpi")
        return check_processes(os.environ.get(MPI_ENV, "1").strip() or "1", MPI_ENV)

    def for_bodies(self, bodies: int) -> tuple["RunOptions", str | None]:
        """These options with at most one MPI process per body (a process without a body only adds
        start-up and communication), and a one-line warning when that lowered the count."""
        requested = self.processes()
        if requested <= max(1, bodies):
            return self, None
        used = max(1, bodies)
        return dataclasses.replace(self, mpi_processes=used), (
            f"--mpi {requested}: the case has {bodies} bod{'y' if bodies == 1 else 'ies'}, so {used} MPI "
            f"process{'es' if used > 1 else ''} (at most one per body)")

    def grid(self) -> str:
        if self.processor_grid is not None:
            return check_grid(self.processor_grid, "processor_grid")
        if GRID_ENV in os.environ:
            return check_grid(os.environ[GRID_ENV], GRID_ENV)
        return check_grid(self.default_grid or "* * *", "default_grid")

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def check_processes(value: str, name: str) -> int:
    """A whole number of MPI processes in [1, 256], or a CaseError naming the setting."""
    if not (value.isascii() and value.isdigit()) or not 1 <= int(value) <= MAX_PROCESSES:  # '²' is a digit to str.isdigit
        raise CaseError(f"{name}={value!r}: must be a whole number of MPI processes; allowed range: 1 to {MAX_PROCESSES}")
    return int(value)


def check_interval(value: str, name: str) -> float:
    """Simulated seconds between checkpoints, in [0, 1e4] (0: none), or a CaseError naming the setting."""
    try:
        interval = float(value)
    except ValueError:
        interval = math.nan
    if not 0.0 <= interval <= 1e4:
        raise CaseError(f"{name}={value!r}: must be simulated seconds between checkpoints; allowed range: 0 (none) to 10000")
    return interval


def check_grid(value: str, name: str) -> str:
    """Three processor counts or * ("1 * 1"), or a CaseError naming the setting."""
    value = " ".join(value.split())
    parts = value.split(" ")
    if len(parts) != 3 or not all(p == "*" or (p.isdigit() and 1 <= int(p) <= MAX_PROCESSES) for p in parts):
        raise CaseError(f"{name}={value!r}: must be three processor counts or * (e.g. '1 * 1'); allowed range: 1 to {MAX_PROCESSES} each")
    return value
