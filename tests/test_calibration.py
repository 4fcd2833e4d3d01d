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
from orchestrator.results import RESULTS
from orchestrator.runner import run_case

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


def calibrate_drop(tmp_path: Path, start: tuple[float, float], max_runs: int) -> tuple[dict, Path]:
    """Launch the shipped YADE brick drop (with spin) as the 'measurement', then calibrate e_n² and μ
    brick/board from `start`; returns the result and the calibration file."""
    truth = run_case(load_case(DROP), DROP.parent, tmp_path / "truth")
    assert truth["status"] == "completed"
    trajectory = read_results(tmp_path / "truth" / RESULTS)
    assert np.abs(trajectory.angular_velocity[1:, 0]).max() > 1.0  # the brick spins (YADE keeps a clump's spin)
    simulated = corners(trajectory, 0, corner_offsets(0.031, 0.015, 0.008))
    keep = trajectory.time <= 0.12  # ≈ 10 τ_ref after the impact, as in the paper
    write_measured(tmp_path / "measured.csv", trajectory.time[keep], simulated[keep])
    spec = {
        "name": "drop",
        "base": str(DROP),
        "measured": "measured.csv",
        "parameters": [
            {"path": "contacts.1.en2", "start": start[0], "low": 0.05, "high": 0.95},
            {"path": "contacts.1.mu", "start": start[1], "low": 0.1, "high": 1.2},
        ],
        "method": "cma",
        "max_runs": max_runs,
        "jobs": 2,
    }
    (tmp_path / "calibration.yaml").write_text(yaml.safe_dump(spec))
    result = calibrate(load_calibration(tmp_path / "calibration.yaml", tmp_path / "out"))
    print(json.dumps(result))
    return result, tmp_path / "calibration.yaml"


@requires_yade
@pytest.mark.engine
def test_cma_es_closes_in_on_en2_and_mu_and_resumes(tmp_path: Path) -> None:
    """From 0.1 off, CMA-ES stops after the generation that passes 24 runs (30): both parameters
    within 0.05 of the launch's (measured 2026-11-30: 0.516, 0.478; 67 s on 2 cores), a convergence
    plot, and a resumed calibration replays the finished runs without new ones. The recovery from
    far off runs under `-m slow`."""
    result, spec = calibrate_drop(tmp_path, (0.43, 0.56), max_runs=24)
    assert result["best"]["contacts.1.en2"] == pytest.approx(0.53, abs=0.05)
    assert result["best"]["contacts.1.mu"] == pytest.approx(0.46, abs=0.05)
    assert (tmp_path / "out" / "convergence.png").exists()
    runs_before = len(list((tmp_path / "out" / "runs").iterdir()))
    again = calibrate(load_calibration(spec, tmp_path / "out"))
    assert again["best"] == result["best"]
    assert len(list((tmp_path / "out" / "runs").iterdir())) == runs_before


@requires_yade
@pytest.mark.engine
@pytest.mark.slow
def test_cma_es_recovers_en2_and_mu(tmp_path: Path) -> None:
    """From far off (0.3, 0.7): (0.5325, 0.4635) after 66 runs (measured 2026-11-30, 145 s on 2 cores)."""
    result, _ = calibrate_drop(tmp_path, (0.3, 0.7), max_runs=60)
    assert result["best"]["contacts.1.en2"] == pytest.approx(0.53, abs=0.05)
    assert result["best"]["contacts.1.mu"] == pytest.approx(0.46, abs=0.05)
