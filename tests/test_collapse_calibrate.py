"""The μ bisection of the horizontal-collapse calibration, on a stand-in runout law (no engine:
this checks the search, the real runs are in docs/studies/collapse.md)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from orchestrator.studies.collapse import calibrate as collapse_calibrate
from orchestrator.studies.collapse.spec import parse_collapse

STUDY = parse_collapse({"name": "h", "channel": {"slope_deg": 0.0, "length": 0.3}})


def fake_runs(monkeypatch: pytest.MonkeyPatch, law) -> list[float]:
    """Replace the engine runs by `law(mu)` → ΔL/L0; returns the list of μ asked for."""
    asked: list[float] = []

    def run(study, outdir, preparations=None, options=None):
        asked.append(study.contacts.mu)
        assert study.contacts.mu_wall is None  # grain/wall friction follows μ
        return {"runout_over_R0": law(study.contacts.mu), "front": {"at_rest": True}}

    monkeypatch.setattr(collapse_calibrate, "run_collapse", run)
    return asked


def test_bisection_finds_the_mu_of_the_law(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    asked = fake_runs(monkeypatch, lambda mu: 0.3 / mu)  # target 0.84 at mu = 0.357
    result = collapse_calibrate.calibrate_mu(STUDY, tmp_path, (0.1, 0.9), tolerance=0.01, max_runs=20)
    assert result["target_runout_over_R0"] == pytest.approx(0.84)
    assert result["mu"] == pytest.approx(0.3 / 0.84, rel=0.01)
    assert result["in_band"] is True
    assert asked[0] == 0.5 and asked[1] == 0.3  # too short at 0.5: lower μ next
    assert json.loads((tmp_path / "calibration.json").read_text())["mu"] == result["mu"]


def test_a_law_out_of_reach_is_reported_outside_the_band(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    fake_runs(monkeypatch, lambda mu: 1.4)  # the 2D case: runout does not depend on μ
    result = collapse_calibrate.calibrate_mu(STUDY, tmp_path, max_runs=4)
    assert result["in_band"] is False
    assert len(result["history"]) == 4
