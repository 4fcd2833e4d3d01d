"""The engines: a registry of what each can do, and one adapter per engine behind one protocol.

Import adapters through `get_adapter(name)`; outside this package nothing names an engine.
"""

from __future__ import annotations

from typing import Any

from orchestrator.engines.base import ContactBuildError, EngineAdapter, EngineError, EngineInfo
from orchestrator.engines.options import RunOptions
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


def get_adapter(name: str, options: RunOptions | None = None) -> EngineAdapter:
    """The adapter of engine `name`, set up with the run options (MPI processes, say)."""
    return adapter_class(name).from_options(options or RunOptions())


def build_stamp(engine: str) -> dict[str, Any]:
    """What turns inputs into results besides the inputs (part of every run id, rundir.run_id): the
    engine, its version (asked of the engine), the hash of the code and templates that write its deck,
    and of its compiled contact plugin."""
    adapter = get_adapter(engine)
    return {"engine": engine, "version": adapter.info().version, **adapter.build_inputs()}


__all__ = ["ContactBuildError", "DEFAULT_ENGINE", "ENGINE_NAMES", "ENGINES", "Capabilities", "Engine", "EngineAdapter", "EngineError", "EngineInfo",
           "RunOptions", "UnknownEngine", "adapter_class", "build_stamp", "capabilities", "engines_with", "get_adapter"]
