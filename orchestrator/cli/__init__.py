"""The `demorch` command line: one module per command group (see main)."""

from orchestrator.cli.main import main

__all__ = ["main"]
