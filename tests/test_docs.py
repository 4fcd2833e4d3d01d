"""The documentation site builds without a warning, and its generated pages are current."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from orchestrator.case import Case
from orchestrator.cli.schema import _rows, models, reference, schema

REPO = Path(__file__).resolve().parent.parent


def test_the_site_builds_strictly(tmp_path: Path) -> None:
    """`mkdocs build --strict`: a broken link, a page outside the nav or an API entry that no longer
    exists fails here."""
    result = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-d", str(tmp_path / "site")],
                            cwd=REPO, capture_output=True, text=True, env={"NO_MKDOCS_2_WARNING": "1", "PATH": "/usr/bin:/bin"}, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    assert (tmp_path / "site" / "reference" / "case" / "index.html").is_file()


@pytest.mark.parametrize("kind", sorted(models()))
def test_the_field_references_are_current(kind: str) -> None:
    committed = (REPO / "docs" / "reference" / f"{kind}.md").read_text()
    assert committed == reference(kind), "run `demorch schema -o schemas --reference docs/reference`"


def test_every_case_field_is_in_the_reference() -> None:
    text = (REPO / "docs" / "reference" / "case.md").read_text()
    for name in Case.model_fields:
        assert f"| {name} |" in text, name


@pytest.mark.parametrize("kind", sorted(models()))
def test_every_number_field_states_its_unit(kind: str) -> None:
    """Real numbers carry a unit ("1" when dimensionless); integers are counts and seeds."""
    document = schema(kind)
    rows = [row for row in _rows(document, document.get("$defs", {}), "") if "number" in row[1]]
    assert rows
    assert [row[0] for row in rows if not row[2]] == []


def test_the_readme_is_short_and_starts_with_the_two_commands() -> None:
    lines = (REPO / "README.md").read_text().splitlines()
    assert len(lines) <= 150
    assert lines[3:5] == ["bash scripts/setup.sh && .venv/bin/demorch demo", "bash scripts/setup.sh && .venv/bin/python -m pytest"]
