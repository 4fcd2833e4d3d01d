"""MPI settings of the engines that split one run over processes (capability `mpi`).

Environment settings, not case fields: they change how fast a case runs, not what it computes, so
cases (and run ids) stay the same.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

from orchestrator.case import CaseError

# MPI processes per LIGGGHTS run (`mpirun -np N`). An environment setting, not a case field: it
# changes how fast a case runs, not what it computes, so cases (and packing keys) stay the same.
MPI_ENV = "DEMORCH_LIGGGHTS_MPI"


def mpi_processes() -> int:
    """N of DEMORCH_LIGGGHTS_MPI (default 1); a bad value is an error that names the variable."""
    value = os.environ.get(MPI_ENV, "1").strip() or "1"
    if not value.isdigit() or not 1 <= int(value) <= 256:
        raise CaseError(f"{MPI_ENV}={value!r}: must be a whole number of MPI processes; allowed range: 1 to 256")
    return int(value)


GRID_ENV = "DEMORCH_LIGGGHTS_GRID"


def processor_grid() -> str:
    """The MPI processor grid of DEMORCH_LIGGGHTS_GRID ("Px Py Pz", each a count or *; default "* * *",
    LIGGGHTS' own choice). A split across the flow ("1 * 1") balances a flow symmetric about y = 0."""
    value = " ".join(os.environ.get(GRID_ENV, "* * *").split())
    parts = value.split(" ")
    if len(parts) != 3 or not all(p == "*" or (p.isdigit() and 1 <= int(p) <= 256) for p in parts):
        raise CaseError(f"{GRID_ENV}={value!r}: must be three processor counts or * (e.g. '1 * 1'); allowed range: 1 to 256 each")
    return value


@contextmanager
def default_grid(grid: str) -> Iterator[None]:
    """Within: DEMORCH_LIGGGHTS_GRID is `grid` unless the user set it (a study that knows its
    symmetry picks the split, the user's word wins)."""
    if GRID_ENV in os.environ:
        yield
        return
    os.environ[GRID_ENV] = grid
    try:
        yield
    finally:
        os.environ.pop(GRID_ENV, None)


