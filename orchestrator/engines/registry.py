"""The engine table (orchestrator.capabilities) and the adapter class of each engine, imported on first use."""

from __future__ import annotations

import importlib
from enum import Enum

from orchestrator.capabilities import (DEFAULT_ENGINE, ENGINE_NAMES, ENGINES, Capabilities, Engine, EngineEntry, UnknownEngine,  # noqa: F401
                                       capabilities, engines_with, entry)


def adapter_class(name: str | Enum) -> type:
    module, _, cls = entry(name).adapter.partition(":")
    return getattr(importlib.import_module(module), cls)
