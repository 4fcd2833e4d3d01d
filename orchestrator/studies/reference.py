"""The reference numbers of the studies (reference.toml): one reader for the avalanche, collapse and
brick studies. Where they are: $DEMORCH_REFERENCE, else the project's shared/reference, else the copy
packaged with the orchestrator (installs without shared/)."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any

from orchestrator.case import CaseError

SHARED_REFERENCE = Path(__file__).resolve().parents[3] / "shared" / "reference" / "reference.toml"
PACKAGED_REFERENCE = Path(__file__).resolve().parents[1] / "data" / "reference.toml"  # a copy, for installs without shared/


def reference_path() -> Path:
    """The reference numbers: $DEMORCH_REFERENCE, else the project's shared/reference, else the packaged copy."""
    if "DEMORCH_REFERENCE" in os.environ:
        return Path(os.environ["DEMORCH_REFERENCE"])
    return SHARED_REFERENCE if SHARED_REFERENCE.is_file() else PACKAGED_REFERENCE


def load_reference() -> dict[str, Any]:
    path = reference_path()
    try:
        with open(path, "rb") as stream:
            return tomllib.load(stream)
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise CaseError(f"reference numbers: cannot read {path} ({error}); unset DEMORCH_REFERENCE to use the packaged copy") from None


def demo_reference() -> dict[str, Any]:
    """The demo's deposits by the study's own code, released from the demo's own slab packings
    (reference.toml [avalanche.demo.richefeu_code_slab]: [lowest, highest] per metric over its runs,
    `runs`, `seeds`, `mean_over_seeds`)."""
    return load_reference()["avalanche"]["demo"]["richefeu_code_slab"]
