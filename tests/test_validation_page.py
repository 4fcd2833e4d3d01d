"""The validation page is written from the recorded runs (docs/validation/record.json), never by hand."""

from __future__ import annotations

import copy
import json
from pathlib import Path

from orchestrator.studies import brick_drop
from orchestrator.studies.validation_page import CHECKS, DEMO_METRICS, demo_reference, render_page

REPO = Path(__file__).resolve().parent.parent
RECORD = REPO / "docs" / "validation" / "record.json"


def test_the_committed_page_is_the_one_its_record_gives(tmp_path: Path) -> None:
    record = json.loads(RECORD.read_text())
    committed = (REPO / "docs" / "validation.md").read_text()
    assert render_page(record, tmp_path, figures_link="validation") == committed, "run `demorch validation --page-only`"
    assert (tmp_path / "brick_drops.png").stat().st_size > 10_000


def test_the_record_holds_every_checked_drop_on_each_engine() -> None:
    """Each engine's default brick, and its rounded box where the engine takes the kind."""
    from orchestrator.capabilities import capabilities
    from orchestrator.studies.validation_page import ROUNDED_BOX

    record = json.loads(RECORD.read_text())
    rounded = {f"{name}, {ROUNDED_BOX}" for name in record["versions"] if "rounded_box" in capabilities(name).shape_kinds}
    assert rounded and set(record["drops"]) == set(record["versions"]) | rounded
    for drops in record["drops"].values():
        assert {check.drop for check in CHECKS} <= set(drops)
        for drop in drops.values():
            assert len(drop["time"]) == len(drop["lowest"]) == len(drop["centre_z"]) > 100


def _record_at_reference() -> dict:
    """A record whose engine 'exact' measures exactly the study code's values, and 'off' 5 % more."""
    reference = brick_drop.reference()
    metrics = {
        "flat_A": {"rebound_ratios": reference["flat"]["rebound_ratio_A"], "apex_lowest_point": reference["flat"]["apex_lowest_point_A"]},
        "flat_B": {"rebound_ratios": reference["flat"]["rebound_ratio_B"], "apex_lowest_point": reference["flat"]["apex_lowest_point_B"]},
        "tilted_A": {"first_contact": reference["tilted"]["first_contact_time"], "centre_apex": reference["tilted"]["A_centre_apex"][0],
                     "second_landing": reference["tilted"]["A_second_landing"]},
        "tilted_B": {"rest_time": reference["tilted"]["B_rest_time"], "rest_travel": reference["tilted"]["B_horizontal_travel"], "lying_flat": True},
    }
    curve = {"time": [0.0, 0.1, 0.2], "lowest": [0.05, 0.02, 0.0], "centre_z": [0.1, 0.05, 0.004]}
    exact = {key: {"metrics": value, **curve} for key, value in metrics.items()}
    off = copy.deepcopy(exact)
    for drop in off.values():
        for key, value in drop["metrics"].items():
            if not isinstance(value, bool):
                drop["metrics"][key] = [1.05 * v for v in value] if isinstance(value, list) else 1.05 * value
    demo = {key: sum(span) / 2 for key, span in demo_reference().items() if isinstance(span, list)}
    return {"recorded": "2026-11-30", "versions": {"exact": "1", "off": "2"}, "drops": {"exact": exact, "off": off},
            "demo": {"exact": [{"seed": 1, "deposit": demo, "apparent_density": 650.0}],
                     "off": [{"seed": 1, "deposit": {k: 10 * v for k, v in demo.items()}, "apparent_density": 700.0}]}}


def test_verdicts_follow_the_tolerances(tmp_path: Path) -> None:
    page = render_page(_record_at_reference(), tmp_path)
    rows = [line for line in page.splitlines() if line.startswith("| flat A: 1st rebound ratio")]
    assert len(rows) == 1 and rows[0].count("✓") == 1 and rows[0].count("✗") == 1  # 5 % off misses 1 %
    apex = next(line for line in page.splitlines() if line.startswith("| tilted A: centre apex"))
    assert apex.count("✓") == 2  # 5 % off is inside 10 %
    demo_rows = [line for line in page.splitlines() if line.startswith("| L (m)")]
    assert len(demo_rows) == 1 and demo_rows[0].count("✓") == 1 and demo_rows[0].count("✗") == 1
    assert len([line for line in page.splitlines() if line.startswith("| ") and "–" in line]) >= len(DEMO_METRICS)
    assert (tmp_path / "avalanche_demo.png").stat().st_size > 10_000


def test_recording_one_engine_keeps_the_others_rows_and_dates() -> None:
    """`demorch validation -e liggghts` adds to the record: YADE's rows, its date and the collapse row stay."""
    from orchestrator.studies.validation_page import merge_records

    committed = json.loads(RECORD.read_text())
    new = {"recorded": {"liggghts": "2030-01-01"}, "versions": {"liggghts": "X"}, "drops": {"liggghts": {"new": 1}},
           "demo": {"liggghts": {"new": 2}}}
    merged = merge_records(committed, new)
    assert merged["drops"]["yade"] == committed["drops"]["yade"] and merged["demo"]["yade"] == committed["demo"]["yade"]
    assert merged["drops"]["liggghts"] == {"new": 1} and merged["versions"] == {**committed["versions"], "liggghts": "X"}
    earlier = committed["recorded"] if isinstance(committed["recorded"], str) else committed["recorded"]["yade"]
    assert merged["recorded"] == {**merged["recorded"], "liggghts": "2030-01-01", "yade": earlier}
    assert merged["collapse"] == committed["collapse"]
