"""Engine adapters by name."""

from __future__ import annotations

from .base import EngineAdapter, EngineError, EngineInfo
from .cocd import CocdAdapter
from .liggghts import LiggghtsAdapter
from .yade import YadeAdapter

ENGINE_NAMES = ("liggghts", "yade", "cocd")


def get_adapter(name: str) -> EngineAdapter:
    if name == "liggghts":
        return LiggghtsAdapter()
    if name == "yade":
        return YadeAdapter()
    if name == "cocd":
        return CocdAdapter()
    raise ValueError(f"unknown engine {name!r}; allowed: {', '.join(ENGINE_NAMES)}")


__all__ = ["ENGINE_NAMES", "EngineAdapter", "EngineError", "EngineInfo", "get_adapter"]
