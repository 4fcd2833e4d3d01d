"""`demorch schema`: JSON Schemas of the files users write (case, studies, campaign, calibration),
generated from the pydantic models that validate them, for editors with a YAML language server.

A shipped YAML file names its schema in its first line,
`# yaml-language-server: $schema=<relative path>/schemas/<kind>.schema.json`, so such an editor
completes and checks its fields while typing; `tests/test_schema.py` checks that the committed
schemas are the generated ones and that every shipped file validates.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click
from pydantic import BaseModel

from orchestrator.cli.common import console

TITLE = "dem-orchestrator {kind} file"


def models() -> dict[str, type[BaseModel]]:
    """Schema name → the model that validates such a file."""
    from orchestrator.campaign.calibrate import CalibrationSpec
    from orchestrator.campaign.spec import CampaignSpec
    from orchestrator.case import Case
    from orchestrator.studies.registry import STUDY_KINDS

    return {"case": Case, **{name: kind.model for name, kind in STUDY_KINDS.items()}, "campaign": CampaignSpec,
            "calibration": CalibrationSpec}


def schema(kind: str) -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of one kind of file; field docs come from the models."""
    document = models()[kind].model_json_schema(mode="validation")
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", "title": TITLE.format(kind=kind), **document}


def render(kind: str) -> str:
    return json.dumps(schema(kind), indent=2, sort_keys=True, ensure_ascii=False) + "\n"


@click.command("schema")
@click.argument("kind", type=click.Choice(["all", *models()]), default="all")
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), help="Write KIND.schema.json files here (default: print).")
def schema_command(kind: str, output: Path | None) -> None:
    """JSON Schema of a case, study, campaign or calibration file (all of them with -o DIR)."""
    kinds = list(models()) if kind == "all" else [kind]
    if output is None:
        if len(kinds) > 1:
            console.print_json(json.dumps({k: schema(k) for k in kinds}))
        else:
            click.echo(render(kinds[0]), nl=False)
        return
    output.mkdir(parents=True, exist_ok=True)
    for name in kinds:
        (output / f"{name}.schema.json").write_text(render(name))
    console.print(f"{len(kinds)} schemas in {output}: " + ", ".join(f"{k}.schema.json" for k in kinds))
