"""One owner per output directory, and the machine's foreseeable conditions as one line: a run, a
study and a campaign never write into each other's directories; a study holds its directory's lock
from before it sets anything aside until its report is written; a campaign never overwrites files
no campaign wrote; a name too long, a folder missing or an engine that cannot run a command's cases
is one line (exit 2) before any engine starts; `demorch status` says what a directory holds."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from conftest import assert_one_line_error, case_data, run_cli
from orchestrator import rundir

REPO = Path(__file__).resolve().parent.parent
SMALL = REPO / "cases" / "avalanche" / "small.yaml"


def study_dir(directory: Path, kind: str = "avalanche") -> Path:
    directory.mkdir(parents=True)
    (directory / "study.json").write_text(json.dumps({"study_id": "0123456789abcdef", "kind": kind}))
    return directory


def test_a_run_is_refused_a_study_directory_and_a_campaign_directory(tmp_path: Path, no_engine_process: None) -> None:
    """`demorch run -o` into a finished study wrote a run beside it (exit 0); now one line, nothing written."""
    case = tmp_path / "case.yaml"
    case.write_text(yaml.safe_dump(case_data()))
    study = study_dir(tmp_path / "study")
    assert_one_line_error(*run_cli(["run", str(case), "-o", str(study)]), expected_code=2, field="holds a study (study.json), not a run")
    assert sorted(p.name for p in study.iterdir()) == ["study.json"]
    campaign = tmp_path / "campaign"
    campaign.mkdir()
    (campaign / "campaign.json").write_text("{}")
    assert_one_line_error(*run_cli(["run", str(case), "-o", str(campaign)]), expected_code=2, field="holds a campaign or a study over seeds")


@pytest.mark.parametrize("held", ["run", "collapse study"])
def test_a_study_is_refused_a_directory_of_another_kind(held: str, tmp_path: Path, no_engine_process: None) -> None:
    out = tmp_path / "out"
    if held == "run":
        out.mkdir()
        (out / "run.json").write_text(json.dumps({"kind": "case", "status": "completed"}))
    else:
        study_dir(out, "collapse")
    before = sorted(p.name for p in out.iterdir())
    expected = "holds a run (run.json), not a study" if held == "run" else "holds a collapse study, not a avalanche one"
    assert_one_line_error(*run_cli(["avalanche", str(SMALL), "-o", str(out)]), expected_code=2, field=expected)
    assert sorted(p.name for p in out.iterdir()) == before


def test_a_second_study_into_a_directory_in_use_is_refused_before_it_sets_anything_aside(tmp_path: Path, no_engine_process: None) -> None:
    """Two different studies into one -o at once: the second moved the first's live directory to the
    attic and both failed. The study holds the directory's lock throughout; the second is one line."""
    out = study_dir(tmp_path / "out")
    (out / "report.json").write_text("{}")  # a product the second study would have set aside
    with rundir.locked(out):  # the first study, running
        assert_one_line_error(*run_cli(["avalanche", str(SMALL), "-o", str(out)]), expected_code=2, field="in use by another process")
    assert (out / "report.json").exists() and not (tmp_path / "attic").exists()


def test_a_campaign_never_overwrites_files_no_campaign_wrote(tmp_path: Path) -> None:
    """Planning asks dpkg the engines' versions; no engine starts (the suite's guard fails a test that starts one)."""
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(case_data()))
    campaign = tmp_path / "campaign.yaml"
    campaign.write_text(yaml.safe_dump({"name": "c", "base": "base.yaml", "designs": [{"kind": "grid", "parameters": {"contacts.0.mu": [0.3]}}]}))
    for name, content in (("points.json", '{"my": "notes"}'), ("index.parquet", "not parquet")):
        out = tmp_path / f"out_{name}"
        out.mkdir()
        (out / name).write_text(content)
        assert_one_line_error(*run_cli(["campaign", "run", str(campaign), "-o", str(out)]), expected_code=2, field="that no campaign wrote")
        assert (out / name).read_text() == content and not (out / "campaign.json").exists()


def test_a_campaign_of_one_kind_over_a_study_of_another_says_so(tmp_path: Path, no_engine_process: None) -> None:
    """It dumped the collapse schema's errors about an avalanche study's fields."""
    campaign = tmp_path / "campaign.yaml"
    campaign.write_text(yaml.safe_dump({"name": "c", "kind": "collapse", "base": str(SMALL),
                                        "designs": [{"kind": "grid", "parameters": {"seed": [1, 2]}}]}))
    assert_one_line_error(*run_cli(["campaign", "run", str(campaign), "-o", str(tmp_path / "out")]), expected_code=2,
                          field="kind: 'collapse', but its base small.yaml is an avalanche study")


def test_a_campaign_point_no_engine_can_run_is_refused_at_planning(tmp_path: Path, no_engine_process: None) -> None:
    """A rounded box on YADE passed planning and failed at run time (exit 3)."""
    campaign = tmp_path / "campaign.yaml"
    campaign.write_text(yaml.safe_dump({"name": "c", "base": str(SMALL),
                                        "designs": [{"kind": "grid", "parameters": {"engine": ["liggghts", "yade"], "brick.kind": ["rounded_box"]}}]}))
    assert_one_line_error(*run_cli(["campaign", "run", str(campaign), "-o", str(tmp_path / "out")]), expected_code=2,
                          field="brick.kind: yade takes clump bricks, not rounded_box")


def test_a_name_longer_than_the_file_system_allows_is_one_line(tmp_path: Path, no_engine_process: None) -> None:
    case = tmp_path / "case.yaml"
    case.write_text(yaml.safe_dump(case_data()))
    assert_one_line_error(*run_cli(["run", str(case), "-o", str(tmp_path / ("a" * 300))]), expected_code=2, field="File name too long")


def test_parity_markdown_into_a_missing_folder_is_refused_before_the_run(tmp_path: Path, no_engine_process: None) -> None:
    assert_one_line_error(*run_cli(["parity", "--markdown", str(tmp_path / "nope" / "parity.md")]), expected_code=2,
                          field="--markdown: the folder")


def test_the_drops_on_an_engine_of_spheres_are_one_line(tmp_path: Path, no_engine_process: None) -> None:
    assert_one_line_error(*run_cli(["validation", "-e", "cocd", "--record", str(tmp_path / "r.json")]), expected_code=2,
                          field="--engine: cocd cannot run the drops")


def test_status_says_what_a_directory_holds(tmp_path: Path) -> None:
    """It called a finished study, a folder of YAML files and / "incomplete"."""
    (tmp_path / "yamls").mkdir()
    (tmp_path / "yamls" / "a.yaml").write_text("name: a\n")
    code, output, _, _ = run_cli(["status", str(tmp_path / "yamls")])
    assert code == 0 and "not a run's directory" in output and "incomplete" not in output
    study = study_dir(tmp_path / "study")
    code, output, _, _ = run_cli(["status", str(study)])
    assert code == 0 and "avalanche study, not finished" in output and "incomplete" not in output
    (study / "report.json").write_text("{}")
    code, output, _, _ = run_cli(["status", str(study)])
    assert "its release is stale" in output  # a report without a completed release
    campaign = tmp_path / "campaign"
    campaign.mkdir()
    (campaign / "campaign.json").write_text("{}")
    code, output, _, _ = run_cli(["status", str(campaign)])
    assert "a campaign or a study over seeds" in output


def test_a_completed_record_without_seals_is_stale_not_trusted(tmp_path: Path) -> None:
    """A packing whose run.json lacked `sealed` was reused unchecked, then failed in LIGGGHTS' read_restart."""
    record = {"run_id": "x", "build": {"engine": "liggghts"}, "status": "completed"}
    (tmp_path / "case.json").write_text(json.dumps(case_data()))
    assert rundir.why_stale(tmp_path, record) == "its results were never sealed" or "hash" in str(rundir.why_stale(tmp_path, record))
    from orchestrator.rundir import run_id
    from orchestrator.case import parse_case
    record["run_id"] = run_id(parse_case(case_data()), record["build"])
    assert rundir.why_stale(tmp_path, record) == "its results were never sealed"
    assert rundir.why_stale(tmp_path, {**record, "sealed": {}}) == "its results were never sealed"
