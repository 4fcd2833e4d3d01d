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
    from orchestrator.studies.registry import LAUNCH_KINDS

    return {**{name: kind.model for name, kind in LAUNCH_KINDS.items()}, "campaign": CampaignSpec,
            "calibration": CalibrationSpec}


BOUNDS = {"gt": "exclusiveMinimum", "ge": "minimum", "lt": "exclusiveMaximum", "le": "maximum"}


def _standard_bounds(node: Any) -> Any:
    """The package's bounded numbers (case.Real) come out of pydantic with its own keywords (gt, le);
    JSON Schema says exclusiveMinimum, maximum: rename them so that editors check the ranges."""
    if isinstance(node, dict):
        return {BOUNDS.get(key, key) if key in BOUNDS and "type" in node else key: _standard_bounds(value) for key, value in node.items()}
    if isinstance(node, list):
        return [_standard_bounds(value) for value in node]
    return node


def schema(kind: str) -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of one kind of file; field docs come from the models."""
    document = _standard_bounds(models()[kind].model_json_schema(mode="validation"))
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", "title": TITLE.format(kind=kind), **document}


def _resolve(node: dict[str, Any], defs: dict[str, Any]) -> dict[str, Any]:
    while "$ref" in node:
        node = {**defs[node["$ref"].rsplit("/", 1)[-1]], **{k: v for k, v in node.items() if k != "$ref"}}
    return node


def _choices(node: dict[str, Any], defs: dict[str, Any]) -> list[dict[str, Any]]:
    """The alternatives of a field (anyOf / oneOf), resolved; null left out (it means: optional)."""
    options = node.get("anyOf") or node.get("oneOf") or [node]
    return [_resolve(o, defs) for o in options if o.get("type") != "null"]


def _describe(node: dict[str, Any]) -> str:
    """Type and allowed range of one (resolved) alternative, e.g. 'number in (0, 1]'."""
    if "const" in node:
        return repr(node["const"])
    if "enum" in node:
        return " | ".join(repr(v) for v in node["enum"])
    kind = node.get("type", "object")
    if kind == "array":
        items = node.get("prefixItems")
        return f"[{', '.join(_describe(i) for i in items)}]" if items else f"list of {_describe(node.get('items', {}))}"
    low = f"({node['exclusiveMinimum']:g}" if "exclusiveMinimum" in node else f"[{node['minimum']:g}" if "minimum" in node else None
    high = f"{node['exclusiveMaximum']:g})" if "exclusiveMaximum" in node else f"{node['maximum']:g}]" if "maximum" in node else None
    if low or high:
        return f"{kind} in {low or '(-inf'}, {high or 'inf)'}"
    return kind + (f" matching `{node['pattern']}`" if "pattern" in node else "")


def unit(node: dict[str, Any], defs: dict[str, Any]) -> str:
    """The unit of a number field (case.Real: "1" dimensionless), of a vector's items, or ""."""
    if node.get("unit"):
        return str(node["unit"])
    for choice in _choices(node, defs):
        items = choice.get("prefixItems") or ([choice["items"]] if isinstance(choice.get("items"), dict) else [])
        found = choice.get("unit") or next((unit(i, defs) for i in items if unit(i, defs)), "")
        if found:
            return str(found)
    return ""


def _rows(node: dict[str, Any], defs: dict[str, Any], path: str) -> list[tuple[str, str, str, str, str]]:
    """(field path, type and range, unit, default, description) of every field under an object schema."""
    rows = []
    for name, field in node.get("properties", {}).items():
        here = f"{path}.{name}" if path else name
        choices = _choices(field, defs)
        default = "required" if name in node.get("required", []) else f"`{field['default']!r}`" if "default" in field else ""
        text = field.get("description") or next((c.get("description", "") for c in choices if c.get("type", "object") == "object"), "")
        rows.append((here, " or ".join(_describe(c) for c in choices), unit(field, defs), default, " ".join(text.split())))
        for choice in choices:
            inner = _resolve(choice.get("items", {}), defs) if choice.get("type") == "array" else choice
            for alternative in _choices(inner, defs) if "properties" not in inner else [inner]:
                if "properties" in alternative:
                    tags = [f"{key}={value['const']}" for key, value in alternative["properties"].items() if "const" in value]
                    sub = here + (f"[{tags[0]}]" if tags else "[]" if choice.get("type") == "array" else "")
                    rows += _rows(alternative, defs, sub)
    return rows


def reference(kind: str) -> str:
    """Markdown reference of one kind of file: every field with its type, range, default and doc."""
    document = schema(kind)
    lines = [f"# {kind.capitalize()} file reference", "",
             f"Generated from the models by `demorch schema --reference docs/reference` (JSON Schema: `schemas/{kind}.schema.json`). "
             "Units are SI; `1` marks a dimensionless number, `[]` a list item.", "",
             "| field | type and range | unit | default | meaning |", "|---|---|---|---|---|"]
    for row in _rows(document, document.get("$defs", {}), ""):
        lines.append("| " + " | ".join(cell.replace("|", "\\|") for cell in row) + " |")
    return "\n".join(lines) + "\n"


def render(kind: str) -> str:
    return json.dumps(schema(kind), indent=2, sort_keys=True, ensure_ascii=False) + "\n"


@click.command("schema")
@click.argument("kind", type=click.Choice(["all", *models()]), default="all")
@click.option("--output", "-o", type=click.Path(file_okay=False, path_type=Path), help="Write KIND.schema.json files here (default: print).")
@click.option("--reference", "reference_dir", type=click.Path(file_okay=False, path_type=Path),
              help="Also write the Markdown field reference, KIND.md, here.")
def schema_command(kind: str, output: Path | None, reference_dir: Path | None) -> None:
    """JSON Schema of a case, study, campaign or calibration file (all of them with -o DIR)."""
    kinds = list(models()) if kind == "all" else [kind]
    if reference_dir is not None:
        reference_dir.mkdir(parents=True, exist_ok=True)
        for name in kinds:
            (reference_dir / f"{name}.md").write_text(reference(name))
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
