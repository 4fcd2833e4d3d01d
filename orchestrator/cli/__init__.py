"""The `demorch` command line: one module per command group (see main)."""

from orchestrator.cli.main import entry, main

__all__ = ["entry", "main"]
