"""Calibration recovers known contact parameters from a brick launch made by the project itself."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from orchestrator.campaign.calibrate import calibrate, corner_offsets, corners, e2_error, load_calibration, read_measured, write_measured
from orchestrator.case import load_case
from orchestrator.results import read_results
from orchestrator.runner import RESULTS, run_case

from conftest import requires_yade

REPO = Path(__file__).resolve().parent.parent
DROP = REPO / "campaigns" / "calibration" / "brick_drop.yaml"


def test_corner_order_and_e2_of_a_known_offset(tmp_path: Path) -> None:
    offsets = corner_offsets(0.031, 0.015, 0.008)
    np.testing.assert_allclose(offsets[0], [0.0155, 0.0075, 0.004])
    np.testing.assert_allclose(offsets[7], [-0.0155, -0.0075, -0.004])
    times = np.linspace(0.0, 0.1, 11)
    path = np.zeros((11, 8, 3)) + offsets
    write_measured(tmp_path / "m.csv", times, path)
    t, measured = read_measured(tmp_path / "m.csv")
    np.testing.assert_allclose(measured, path)
    # Every corner 1 mm off at every instant: E2 = 8 corners × 11 instants × 1 mm.
    assert e2_error(times, path + [0.001, 0.0, 0.0], t, measured) == pytest.approx(8 * 11 * 0.001)


@requires_yade
@pytest.mark.engine
def test_cma_es_recovers_en2_and_mu(tmp_path: Path) -> None:
    truth = run_case(load_case(DROP), DROP.parent, tmp_path / "truth")
    assert truth["status"] == "completed"
    trajectory = read_results(tmp_path / "truth" / RESULTS)
    simulated = corners(trajectory, 0, corner_offsets(0.031, 0.015, 0.008))
    keep = trajectory.time <= 0.12  # ≈ 10 τ_ref after the impact, as in the paper
    write_measured(tmp_path / "measured.csv", trajectory.time[keep], simulated[keep])
    spec = {
        "name": "drop",
        "base": str(DROP),
        "measured": "measured.csv",
        "parameters": [
            {"path": "contacts.1.en2", "start": 0.3, "low": 0.05, "high": 0.95},
            {"path": "contacts.1.mu", "start": 0.7, "low": 0.1, "high": 1.2},
        ],
        "method": "cma",
        "max_runs": 60,  # measured: (0.533, 0.453) after 66 runs (whole CMA-ES generations)
        "jobs": 2,
    }
    (tmp_path / "calibration.yaml").write_text(yaml.safe_dump(spec))
    calibration = load_calibration(tmp_path / "calibration.yaml", tmp_path / "out")
    result = calibrate(calibration)
    print(json.dumps(result))
    assert result["best"]["contacts.1.en2"] == pytest.approx(0.53, abs=0.05)
    assert result["best"]["contacts.1.mu"] == pytest.approx(0.46, abs=0.05)
    assert (tmp_path / "out" / "convergence.png").exists()
    # Resuming replays the same proposals from finished runs: no new engine run, same answer.
    runs_before = len(list((tmp_path / "out" / "runs").iterdir()))
    again = calibrate(load_calibration(tmp_path / "calibration.yaml", tmp_path / "out"))
    assert again["best"] == result["best"]
    assert len(list((tmp_path / "out" / "runs").iterdir())) == runs_before
