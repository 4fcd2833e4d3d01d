"""JSON Schemas of the files users write (`demorch schema`): committed, current, and naming every
shipped file's fields; a misspelt field is an error there as in the package."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner
from jsonschema import Draft202012Validator

from orchestrator.cli.main import main
from orchestrator.cli.schema import models, render, schema

REPO = Path(__file__).resolve().parent.parent
SHIPPED = sorted([*(REPO / "cases").rglob("*.yaml"), *(REPO / "campaigns").rglob("*.yaml")])
MODELINE = re.compile(r"^# yaml-language-server: \$schema=(\S+)$")


class Yaml12(yaml.SafeLoader):
    """What an editor's YAML 1.2 language server reads: `1.0e5` is a number (PyYAML's 1.1 rules make
    it a string, which the package's models accept as a number too)."""


Yaml12.add_implicit_resolver("tag:yaml.org,2002:float", re.compile(r"^[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?$"), list("-+0123456789."))


def load(path: Path) -> object:
    return yaml.load(path.read_text(), Loader=Yaml12)


@pytest.mark.parametrize("kind", sorted(models()))
def test_the_committed_schema_is_the_generated_one(kind: str) -> None:
    committed = REPO / "schemas" / f"{kind}.schema.json"
    assert committed.read_text() == render(kind), f"run `demorch schema -o schemas` after changing {models()[kind].__name__}"
    Draft202012Validator.check_schema(schema(kind))


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: str(p.relative_to(REPO)))
def test_every_shipped_file_names_its_schema_and_validates(path: Path) -> None:
    first = path.read_text().splitlines()[0]
    match = MODELINE.match(first)
    assert match, f"{path}: the first line must be the yaml-language-server modeline"
    target = (path.parent / match.group(1)).resolve()
    assert target.parent == REPO / "schemas" and target.is_file()
    kind = target.name.removesuffix(".schema.json")
    errors = list(Draft202012Validator(schema(kind)).iter_errors(load(path)))
    assert not errors, [f"{'.'.join(map(str, e.path))}: {e.message}" for e in errors]


def test_a_misspelt_field_is_rejected() -> None:
    case = load(REPO / "cases" / "free_fall.yaml")
    validator = Draft202012Validator(schema("case"))
    assert validator.is_valid(case)
    assert not validator.is_valid({**case, "gravty": [0, 0, -9.81]})
    case["materials"][0]["densty"] = case["materials"][0].pop("density")
    assert not validator.is_valid(case)


def test_the_command_prints_one_schema() -> None:
    result = CliRunner().invoke(main, ["schema", "case"])
    assert result.exit_code == 0 and result.output == render("case")


def test_ranges_are_checked_by_the_schema_too() -> None:
    case = load(REPO / "cases" / "free_fall.yaml")
    validator = Draft202012Validator(schema("case"))
    case["contacts"][0]["en2"] = 1.5
    assert not validator.is_valid(case)
    case["contacts"][0]["en2"] = 0.0
    assert not validator.is_valid(case)  # (0, 1]
