"""A study over seeds (studies/seeds.py, studies/ensemble.py, cli/ensemble.py): each seed its own
content-addressed study, run as a campaign's points; the table gives each seed, the mean and the range,
and the references beside the mean; adding a seed runs only that seed."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from conftest import requires_liggghts, tiny_study
from orchestrator import rundir
from orchestrator.campaign.execute import plan_campaign
from orchestrator.case import CaseError
from orchestrator.cli.main import main as cli
from orchestrator.studies.avalanche.study import KIND, load_study
from orchestrator.campaign.ensemble import study_campaign
from orchestrator.studies.ensemble import mean_report, summarize
from orchestrator.studies.seeds import member_seeds


def _study_file(tmp_path: Path, name: str = "tiny.yaml", **fields: object) -> Path:
    data = tiny_study("liggghts").model_dump(mode="json", exclude_defaults=True)
    data["release"]["duration"] = 1.0
    data["packing"]["settle_time"] = 0.3
    data.update(fields)
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("value, message", [
    (0, "seeds: 0 seeds; allowed: a count 1–1000"),
    ([3, 3], "seeds: [3] given more than once; allowed"),
    ([], "seeds: [] is not a list of 1–1000 seeds"),
    ("three", "seeds: 'three' is neither a count nor a list"),
    (True, "seeds: True is neither a count nor a list"),
    (2.5, "seeds: 2.5 is neither a count nor a list"),
])
def test_bad_seeds_are_one_line_naming_the_field_and_the_range(tmp_path: Path, value: object, message: str) -> None:
    with pytest.raises(CaseError) as error:
        load_study(_study_file(tmp_path, seeds=value))
    assert message in str(error.value) and "\n" not in str(error.value)


def test_a_count_of_seeds_starts_at_the_study_seed_and_may_not_run_past_the_largest() -> None:
    assert member_seeds(2009, 3) == [2009, 2010, 2011]
    assert member_seeds(2009, [7, 5]) == [7, 5]
    assert member_seeds(2009, None) == [2009]
    with pytest.raises(ValueError, match="run past"):
        member_seeds(2**31 - 1, 2)


def test_a_study_with_seeds_is_a_campaign_of_its_members_and_a_new_seed_adds_only_its_member(tmp_path: Path) -> None:
    """Each seed is a point of its own (`seed` its only parameter) whose id is the id of the study of
    that seed alone: the seeds already there keep their ids, so they are reused."""
    two = plan_campaign(study_campaign("avalanche", _study_file(tmp_path, seeds=[1, 2])), tmp_path / "out")
    assert sorted(p["seed"] for p in two.points.values()) == [1, 2]
    for identifier, study in two.cases.items():
        assert study.seeds is None
        single = load_study(_study_file(tmp_path, "single.yaml", seed=study.seed))
        assert rundir.run_id(single, rundir_build(single)) == identifier  # the member is the study of that seed, hashed alike
    three = plan_campaign(study_campaign("avalanche", _study_file(tmp_path, seeds=3, seed=1)), tmp_path / "out")
    assert set(two.points) < set(three.points) and len(three.points) == 3


def rundir_build(study: object) -> object:
    from orchestrator.engines import build_stamp

    return build_stamp(study.engine.value)  # type: ignore[attr-defined]


def test_a_campaign_over_a_study_with_seeds_runs_every_point_at_every_seed(tmp_path: Path) -> None:
    base = _study_file(tmp_path, seeds=2, seed=5)
    campaign = tmp_path / "c.yaml"
    campaign.write_text(yaml.safe_dump({"name": "c", "base": base.name,
                                        "designs": [{"kind": "grid", "parameters": {"contacts.brick_board.mu": [0.4, 0.5]}}]}))
    plan = plan_campaign(campaign, tmp_path / "out")
    assert sorted((p["contacts.brick_board.mu"], p["seed"]) for p in plan.points.values()) == [(0.4, 5), (0.4, 6), (0.5, 5), (0.5, 6)]
    campaign.write_text(yaml.safe_dump({"name": "c", "base": base.name, "replicates": 2}))
    with pytest.raises(CaseError, match="seeds: the study has seeds and the campaign replicates 2; give one of them"):
        plan_campaign(campaign, tmp_path / "other")


def test_the_summary_gives_mean_spread_range_and_each_seed_and_the_mean_report_averages_numbers_only() -> None:
    summary = summarize({1: {"L": 1.0, "H": float("nan")}, 2: {"L": 2.0, "H": 0.1}, 3: {"L": 4.0}})
    assert summary["L"] == {"n": 3, "mean": pytest.approx(7 / 3), "std": pytest.approx(np.std([1, 2, 4], ddof=1)), "min": 1.0, "max": 4.0,
                            "by_seed": {"1": 1.0, "2": 2.0, "3": 4.0}}
    assert summary["H"]["n"] == 1 and summary["H"]["std"] == 0.0  # a NaN is left out, not averaged in
    mean = mean_report([{"deposit": {"length": 1.0, "kind": "a"}, "ok": True, "box": 0.148, "curve": [1, 2]},
                        {"deposit": {"length": 2.0, "kind": "b"}, "ok": False, "box": 0.148, "curve": [3, 4]},
                        {"deposit": {"length": 4.5, "kind": "c"}, "ok": True, "box": 0.148, "curve": [5, 6]}])
    assert mean == {"deposit": {"length": 2.5, "kind": "a"}, "ok": False, "box": 0.148, "curve": [1, 2]}


def test_a_study_of_one_seed_and_an_ensemble_never_share_a_directory(tmp_path: Path) -> None:
    """Each is refused in one line before any engine starts when the directory holds the other."""
    runner = CliRunner()
    single, ensemble = tmp_path / "single", tmp_path / "ensemble"
    single.mkdir()
    (single / "study.json").write_text(json.dumps({"study_id": "0" * 16, "kind": "avalanche"}))
    result = runner.invoke(cli, ["avalanche", str(_study_file(tmp_path, seeds=2)), "-o", str(single)])
    assert result.exit_code == 2 and "holds a study of one seed" in result.output
    ensemble.mkdir()
    (ensemble / "campaign.json").write_text("{}")
    result = runner.invoke(cli, ["avalanche", str(_study_file(tmp_path, "one.yaml")), "-o", str(ensemble)])
    assert result.exit_code == 2 and "holds a study over seeds or a campaign" in result.output


@pytest.mark.engine
@requires_liggghts
def test_an_avalanche_over_seeds_prints_each_seed_the_mean_and_the_range_and_a_new_seed_runs_alone(tmp_path: Path) -> None:
    """Two seeds of the tiny study, then a third: the second launch runs only the third seed. The
    ensemble's numbers are the members' own (each member's report.json), their mean and range."""
    runner = CliRunner()
    out = tmp_path / "ensemble"
    first = runner.invoke(cli, ["avalanche", str(_study_file(tmp_path, seeds=[1, 2])), "-o", str(out), "-j", "2"], env={"COLUMNS": "250"})
    assert first.exit_code == 0, first.output
    assert "2 seed(s) run, 0 already there, 0 failed" in first.output
    second = runner.invoke(cli, ["avalanche", str(_study_file(tmp_path, seeds=[1, 2, 3])), "-o", str(out), "-j", "1"], env={"COLUMNS": "250"})
    assert second.exit_code == 0, second.output
    assert "1 seed(s) run, 2 already there, 0 failed" in second.output
    for column in ("seed 1", "seed 2", "seed 3", "mean", "range"):
        assert column in second.output
    group = json.loads((out / "ensemble.json").read_text())["groups"][0]
    assert [m["seed"] for m in group["members"]] == [1, 2, 3] and {m["status"] for m in group["members"]} == {"completed"}
    lengths = {str(m["seed"]): json.loads((out / m["directory"] / "report.json").read_text())["deposit"]["length"] for m in group["members"]}
    metric = group["metrics"]["deposit.length"]
    assert metric["by_seed"] == lengths
    assert metric["mean"] == pytest.approx(np.mean(list(lengths.values())), rel=1e-12)
    assert (metric["min"], metric["max"]) == (min(lengths.values()), max(lengths.values()))
    assert len(set(lengths.values())) == 3  # three draws, three deposits: the seeds do change the packing
    rows = {row[0]: row for row in KIND.ensemble_rows({int(s): json.loads((out / m["directory"] / "report.json").read_text())
                                                        for s, m in zip(lengths, group["members"])})}
    assert math.isclose(rows["L (m)"][2], metric["mean"], rel_tol=1e-12) and "ensemble.md" in second.output
    (out / "ensemble.md").unlink()
    post = runner.invoke(cli, ["post", str(out)], env={"COLUMNS": "250"})  # the ensemble's table, written again
    assert post.exit_code == 0 and "seed 3" in post.output and (out / "ensemble.md").exists(), post.output
