"""How engines run, as opposed to what they compute: MPI processes and the processor grid.

Never part of a case or a run id (a run computes the same on 1 or 4 processes). Passed explicitly
from the command line through studies and campaigns to the adapters, so a Dask worker on another
node gets the same settings as a local run. Precedence, each setting alone: the explicit option
(`demorch --mpi N`), then the environment (DEMORCH_LIGGGHTS_MPI, DEMORCH_LIGGGHTS_GRID), then a
study's preferred split (`default_grid`), then the engine's own choice.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass
from typing import Any

from orchestrator.validation import CaseError

MPI_ENV = "DEMORCH_LIGGGHTS_MPI"
GRID_ENV = "DEMORCH_LIGGGHTS_GRID"
MAX_PROCESSES = 256


@dataclass(frozen=True)
class RunOptions:
    """mpi_processes: MPI processes per run of an engine with capability `mpi` (None: environment, else 1).
    processor_grid: "Px Py Pz", each a count or * (None: environment, else default_grid, else "* * *").
    default_grid: a study's preferred split (the avalanche set-up is symmetric about y = 0: "1 * 1")."""

    mpi_processes: int | None = None
    processor_grid: str | None = None
    default_grid: str | None = None

    def processes(self) -> int:
        if self.mpi_processes is not None:
            return check_processes(str(self.mpi_processes), "--mpi")
        return check_processes(os.environ.get(MPI_ENV, "1").strip() or "1", MPI_ENV)

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
    if not value.isdigit() or not 1 <= int(value) <= MAX_PROCESSES:
        raise CaseError(f"{name}={value!r}: must be a whole number of MPI processes; allowed range: 1 to {MAX_PROCESSES}")
    return int(value)


def check_grid(value: str, name: str) -> str:
    """Three processor counts or * ("1 * 1"), or a CaseError naming the setting."""
    value = " ".join(value.split())
    parts = value.split(" ")
    if len(parts) != 3 or not all(p == "*" or (p.isdigit() and 1 <= int(p) <= MAX_PROCESSES) for p in parts):
        raise CaseError(f"{name}={value!r}: must be three processor counts or * (e.g. '1 * 1'); allowed range: 1 to {MAX_PROCESSES} each")
    return value
