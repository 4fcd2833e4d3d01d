"""Engine adapters by name."""

from __future__ import annotations

import os

from ..case import CaseError
from .base import EngineAdapter, EngineError, EngineInfo
from .cocd import CocdAdapter
from .liggghts import LiggghtsAdapter
from .yade import YadeAdapter

ENGINE_NAMES = ("liggghts", "yade", "cocd")
# MPI processes per LIGGGHTS run (`mpirun -np N`). An environment setting, not a case field: it
# changes how fast a case runs, not what it computes, so cases (and packing keys) stay the same.
MPI_ENV = "DEMORCH_LIGGGHTS_MPI"


def liggghts_processes() -> int:
    """N of DEMORCH_LIGGGHTS_MPI (default 1); a bad value is an error that names the variable."""
    value = os.environ.get(MPI_ENV, "1").strip() or "1"
    if not value.isdigit() or not 1 <= int(value) <= 256:
        raise CaseError(f"{MPI_ENV}={value!r}: must be a whole number of MPI processes; allowed range: 1 to 256")
    return int(value)


def get_adapter(name: str) -> EngineAdapter:
    if name == "liggghts":
        return LiggghtsAdapter(mpi_processes=liggghts_processes())
    if name == "yade":
        return YadeAdapter()
    if name == "cocd":
        return CocdAdapter()
    raise ValueError(f"unknown engine {name!r}; allowed: {', '.join(ENGINE_NAMES)}")


__all__ = ["ENGINE_NAMES", "MPI_ENV", "liggghts_processes", "EngineAdapter", "EngineError", "EngineInfo", "get_adapter"]
