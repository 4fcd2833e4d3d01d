"""Malformed case files: each gives one line naming the field, and no engine process starts."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from orchestrator.case import CaseError, load_case
from orchestrator.cli.main import main

BAD_CASES = sorted((Path(__file__).parent / "cases" / "bad").glob("*.yaml"))


def expected_field(path: Path) -> str:
    """The first line of each bad case says which field the error must name: `# expect: FIELD`."""
    first = path.read_text().splitlines()[0]
    assert first.startswith("# expect: "), f"{path.name} lacks its '# expect:' line"
    return first.removeprefix("# expect: ").strip()


def test_there_are_at_least_fifteen_malformed_cases() -> None:
    assert len(BAD_CASES) >= 15


@pytest.mark.parametrize("path", BAD_CASES, ids=lambda p: p.stem)
def test_bad_case_names_its_field_on_one_line(path: Path) -> None:
    with pytest.raises(CaseError) as caught:
        load_case(path)
    message = str(caught.value)
    assert "\n" not in message, message
    assert message.startswith(str(path))
    assert expected_field(path) in message, message


@pytest.mark.parametrize("path", BAD_CASES, ids=lambda p: p.stem)
def test_cli_rejects_bad_case_before_any_engine_starts(path: Path, tmp_path: Path, no_engine_process: None) -> None:
    result = CliRunner().invoke(main, ["run", str(path), "-o", str(tmp_path / "run")])
    assert result.exit_code == 2, result.output
    assert expected_field(path) in " ".join(result.output.split())
    assert not (tmp_path / "run").exists(), "nothing may be written for an invalid case"


def test_bound_errors_state_the_allowed_range(tmp_path: Path) -> None:
    with pytest.raises(CaseError, match=r"contacts\.0\.en2: .*allowed range: \(0, 1\] \(got 1\.5\)"):
        load_case(Path(__file__).parent / "cases" / "bad" / "restitution_above_one.yaml")


def test_a_validators_message_shows_the_value_once_and_cites_only_what_applies() -> None:
    """A model validator's message that names the value already gets no second `(got …)` (the whole
    shape entry); a rounding too large on an unbevelled brick names its range, not bevel_deg."""
    from conftest import case_data
    from orchestrator.case import parse_case

    shape = {"name": "b", "length": 0.031, "width": 0.015, "thickness": 0.008, "rounding": 0.01}
    with pytest.raises(CaseError) as caught:
        parse_case({**case_data(), "shapes": [shape]})
    message = str(caught.value)
    assert message == "case: shapes.0: rounding: allowed: 0, or [1e-06, 0.004) m (below half the smallest side) (got 0.01)"
    with pytest.raises(CaseError) as caught:
        parse_case({**case_data(), "shapes": [{**shape, "rounding": 0.001, "bevel_deg": 2.0}]})
    assert str(caught.value).count("(got") == 1 and "rounding: needs bevel_deg 0" in str(caught.value)


def test_good_case_files_load() -> None:
    for path in sorted((Path(__file__).parent.parent / "cases").glob("*.yaml")):
        case = load_case(path)
        assert case.bodies.spheres, path


@pytest.mark.parametrize(
    "command",
    [["run"], ["render"], ["post"], ["paraview"], ["doctor"], ["build-contact"], ["demo"], ["avalanche"],
     ["campaign", "run"], ["campaign", "status"], ["campaign", "table"], ["campaign", "plot"], ["campaign", "calibrate"],
     ["collapse", "run"], ["collapse", "calibrate"], ["collapse", "plot"], ["submit"], ["status"], ["slurm-job"]],
    ids=" ".join,
)
def test_every_documented_command_exists(command: list[str]) -> None:
    """The command table of docs/commands.md is the CLI: a command lost in a refactor fails here, not in a user's hands."""
    result = CliRunner().invoke(main, [*command, "--help"])
    assert result.exit_code == 0, result.output
    assert "Usage:" in result.output


def test_brick_command_reports_each_resolution_and_refuses_a_bad_layout() -> None:
    """`demorch brick`: the fit of each clump resolution to the brick, before users pick one."""
    result = CliRunner().invoke(main, ["brick", "--bevel", "2", "--layout", "4", "2", "1", "--layout", "12", "6", "2"])
    assert result.exit_code == 0, result.output
    assert "3.24 / 1.12" in result.output and "1.64 / 0.41" in result.output  # max / mean gap (mm), bevelled
    assert "3.79–4.20" in result.output  # radii shrink towards the thin end
    refused = CliRunner().invoke(main, ["brick", "--layout", "0", "2", "1"])
    assert refused.exit_code == 2 and "--layout" in refused.output and "[1, 64]" in refused.output
