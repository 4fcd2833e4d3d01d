"""Coulomb friction: a block (rotation-locked sphere, and a clumped brick) on an incline sticks below μ and slides above it.

The linear law's block is a case of the parity matrix (tests/test_parity.py); here the bilinear law's."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from orchestrator.case import Case, parse_case
from orchestrator.results import Trajectory, read_results
from orchestrator.results import RESULTS
from orchestrator.runner import run_case
from orchestrator.parity import slope_vectors, sliding_case

from conftest import engine_params

MU = 0.46  # brick/support, Richefeu et al. (2012)


def downslope_acceleration(trajectory: Trajectory, angle_deg: float, start: float, end: float = math.inf) -> tuple[float, float]:
    """(fitted acceleration along the slope between start and end, Coulomb's g (sin α − μ cos α))."""
    down, _ = slope_vectors(angle_deg)
    window = (trajectory.time >= start) & (trajectory.time <= end)
    speed = trajectory.velocity[window, 0, :] @ np.asarray(down)
    fitted = np.polyfit(trajectory.time[window], speed, 1)[0]
    return float(fitted), 9.81 * (math.sin(math.radians(angle_deg)) - MU * math.cos(math.radians(angle_deg)))


@pytest.mark.parametrize("law", ["bilinear"])
@pytest.mark.parametrize("engine", engine_params())
def test_block_sticks_when_tan_alpha_is_below_mu(engine: str, law: str, tmp_path: Path) -> None:
    angle = math.degrees(math.atan(MU - 0.02))
    run_case(sliding_case(engine, angle, MU, duration=0.3, law=law), tmp_path, tmp_path / "run")
    trajectory = read_results(tmp_path / "run" / RESULTS)
    down, _ = slope_vectors(angle)
    travel = (trajectory.position[-1, 0] - trajectory.position[0, 0]) @ np.asarray(down)
    # At rest the tangential spring holds m g sin α / k_t ≈ 2e-7 m of elastic creep; 1e-5 m
    # (50 × that) separates sticking from sliding, which would cover ~1 cm in 0.3 s.
    assert abs(travel) < 1e-5
    assert np.linalg.norm(trajectory.velocity[-1, 0]) < 1e-4


@pytest.mark.parametrize("law", ["bilinear"])
@pytest.mark.parametrize("engine", engine_params())
def test_block_slides_with_kinetic_acceleration_above_mu(engine: str, law: str, tmp_path: Path) -> None:
    angle = math.degrees(math.atan(MU + 0.05))
    run_case(sliding_case(engine, angle, MU, duration=0.3, law=law), tmp_path, tmp_path / "run")
    acceleration, expected = downslope_acceleration(read_results(tmp_path / "run" / RESULTS), angle, start=0.05)
    assert acceleration == pytest.approx(expected, rel=0.02)  # within 2 %


def brick_on_incline_case(engine: str, angle_deg: float, mu: float, duration: float = 0.4) -> Case:
    """A real brick (4 × 2 × 1 clump, true mass and inertia) lying flat on an incline, length downslope.

    It starts 1.5 mm above the board (LIGGGHTS places a clump within 1 mm of where it is asked),
    lands, and then either sticks or slides; the bilinear law of the 2012 study, brick/support.
    """
    down, normal = slope_vectors(angle_deg)
    half = math.radians(angle_deg) / 2.0
    start = [0.05 * d + (0.004 + 0.0015) * n for d, n in zip(down, normal)]
    contact = {"law": "bilinear", "en2": 0.53, "mu": mu, "kn": 1e5, "kt_over_kn": 0.42}
    return parse_case(
        {
            "name": "brick_slide",
            "engine": engine,
            "time": {"duration": duration, "output_interval": 0.01},
            "materials": [{"name": "brick", "density": 1700.0}, {"name": "board", "density": 1400.0}],
            "contacts": [{"materials": ["brick", "brick"], **contact}, {"materials": ["brick", "board"], **contact}],
            "shapes": [{"name": "brick", "length": 0.031, "width": 0.015, "thickness": 0.008, "layout": [4, 2, 1]}],
            # Rotation about y by the slope angle: body x down the slope, body z along its normal.
            "bodies": {"clumps": [{"shape": "brick", "material": "brick", "position": start, "orientation": [math.cos(half), 0.0, math.sin(half), 0.0]}]},
            "walls": [{"type": "rectangle", "name": "slope", "material": "board", "origin": [0.0, -0.1, 0.0], "edge1": list(down), "edge2": [0.0, 0.2, 0.0]}],
        }
    )


@pytest.mark.parametrize("engine", engine_params())
def test_brick_clump_sticks_below_mu_and_slides_above(engine: str, tmp_path: Path) -> None:
    """A clumped brick: at rest for tan α = μ − 0.02, kinetic acceleration for tan α = μ + 0.05.

    Below μ the brick lands from 1.5 mm with some downslope speed (rebounds, rocking), which kinetic
    friction removes at g(sin α − μ cos α) ≈ −0.18 m/s²; once stopped it must stay stopped.
    """
    stick_angle = math.degrees(math.atan(MU - 0.02))
    run_case(brick_on_incline_case(engine, stick_angle, MU, duration=0.8), tmp_path, tmp_path / "stick")
    trajectory = read_results(tmp_path / "stick" / RESULTS)
    down, _ = slope_vectors(stick_angle)
    speed = np.linalg.norm(trajectory.velocity[:, 0, :], axis=1)
    still = np.flatnonzero((trajectory.time >= 0.1) & (speed < 1e-4))
    assert still.size, "the brick never came to rest below μ"
    rest = int(still[0])
    assert trajectory.time[rest] < 0.6  # measured: 0.37 s (YADE) to 0.47 s (LIGGGHTS)
    deceleration, expected = downslope_acceleration(trajectory, stick_angle, start=0.15, end=trajectory.time[rest] - 0.03)
    assert deceleration == pytest.approx(expected, rel=0.02)  # kinetic friction while it still slides
    travel = (trajectory.position[-1, 0] - trajectory.position[rest, 0]) @ np.asarray(down)
    # Elastic creep of the tangential springs is ~1e-7 m; sliding would cover ~1 cm in 0.2 s.
    assert abs(travel) < 1e-5
    assert speed[-1] < 1e-4

    slide_angle = math.degrees(math.atan(MU + 0.05))
    run_case(brick_on_incline_case(engine, slide_angle, MU), tmp_path, tmp_path / "slide")
    acceleration, expected = downslope_acceleration(read_results(tmp_path / "slide" / RESULTS), slide_angle, start=0.15)
    assert acceleration == pytest.approx(expected, rel=0.02)  # within 2 %
