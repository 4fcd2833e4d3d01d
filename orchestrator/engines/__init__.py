"""The engines: a registry of what each can do, and one adapter per engine behind one protocol.

Import adapters through `get_adapter(name)`; outside this package nothing names an engine.
"""

from __future__ import annotations

from orchestrator.engines.base import ContactBuildError, EngineAdapter, EngineError, EngineInfo
from orchestrator.engines.registry import (
    DEFAULT_ENGINE,
    ENGINE_NAMES,
    ENGINES,
    Capabilities,
    Engine,
    UnknownEngine,
    adapter_class,
    capabilities,
    engines_with,
)


def get_adapter(name: str) -> EngineAdapter:
    """The adapter of engine `name`, set up from the environment (MPI processes, say)."""
    return adapter_class(name).from_environment()


__all__ = ["ContactBuildError", "DEFAULT_ENGINE", "ENGINE_NAMES", "ENGINES", "Capabilities", "Engine", "EngineAdapter", "EngineError", "EngineInfo",
           "UnknownEngine", "adapter_class", "capabilities", "engines_with", "get_adapter"]
