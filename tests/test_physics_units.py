"""Pure functions of physics.py, checked against independent integrations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from orchestrator.physics import contact_duration, linear_damping, schedule
from orchestrator.parity import sliding_case



@pytest.mark.parametrize("en2", [0.13, 0.53, 0.9])
def test_linear_damping_gives_the_requested_restitution(en2: float) -> None:
    """Integrate m x'' = -k x - c x' through one impact (force clipped at zero, as both engines do)."""
    mass, kn = 0.01, 1e5
    cn = linear_damping(kn, en2, mass)

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        overlap, rate = y
        force = max(kn * overlap + cn * rate, 0.0)
        return [rate, -force / mass]

    leaves = lambda _t, y: y[0] + 1e-15  # noqa: E731 - overlap back to zero
    leaves.terminal, leaves.direction = True, -1
    solution = solve_ivp(rhs, (0, 1.0), [0.0, 1.0], events=leaves, rtol=1e-10, atol=1e-14, max_step=1e-5)
    rebound = -solution.y_events[0][0][1]
    # The ODE solver's event location is the only error left: 1e-6 relative is far above it.
    assert rebound**2 == pytest.approx(en2, rel=1e-6)


def test_auto_time_step_is_a_hundredth_of_the_contact_duration() -> None:
    case = sliding_case("liggghts")
    mass = 2500.0 * 4 / 3 * math.pi * 0.005**3
    plan = schedule(case)
    # The sphere/sphere pair (reduced mass m/2) is the shortest contact, though only one sphere exists.
    assert plan.dt == pytest.approx(0.01 * contact_duration(1e5, mass / 2))
    assert plan.total_steps == plan.frames * plan.output_every
    assert plan.frames == math.ceil(case.time.duration / case.time.output_interval - 1e-9)
    assert abs(plan.end_time - case.time.duration) <= plan.frames * plan.dt / 2


def test_schedule_never_adds_an_output_interval_by_rounding() -> None:
    """0.1 s at 0.02 s output with a step that does not divide 0.02: five intervals, not six."""
    case = sliding_case("liggghts").model_copy(update={"time": sliding_case("liggghts").time.model_copy(update={"step": 1.975085e-6, "duration": 0.1, "output_interval": 0.02})})
    plan = schedule(case)
    assert plan.output_every == 10126 and plan.frames == 5
    assert plan.end_time == pytest.approx(0.1, abs=5 * plan.dt / 2)


def test_default_step_is_50_per_contact_for_the_bilinear_law_on_liggghts_only() -> None:
    """The compiled bilinear law needs no damping term: 50 steps per contact; dashpots keep 100."""
    bilinear = sliding_case("liggghts", law="bilinear")
    duration = schedule(bilinear).dt / 0.02
    assert schedule(sliding_case("yade", law="bilinear")).dt == pytest.approx(0.01 * duration)
    assert schedule(sliding_case("liggghts", law="linear")).dt == pytest.approx(0.01 * duration)
    chosen = bilinear.model_copy(update={"time": bilinear.time.model_copy(update={"safety_factor": 0.005})})
    assert schedule(chosen).dt == pytest.approx(0.005 * duration)  # a case's own factor wins
