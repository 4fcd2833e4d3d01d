"""Mass front on constructed flows with known fronts."""

from __future__ import annotations

import numpy as np
import pytest

from orchestrator.post.front import flat_phases, front_curve, front_position


def test_front_ignores_a_single_stray_body() -> None:
    x = np.concatenate([np.linspace(0.0, 1.0, 200), [3.0]])
    mass = np.ones_like(x)
    assert front_position(x, mass, window=0.05, min_fraction=0.01) == pytest.approx(1.0)


def test_front_of_a_block_moving_at_constant_acceleration() -> None:
    """A rigid block of bodies, x = x0 + a t²/2: front position and velocity are known exactly."""
    time = np.linspace(0.0, 1.0, 51)
    offsets = np.linspace(-0.3, 0.0, 100)
    acceleration = 2.0
    x = offsets[None, :] + 0.5 * acceleration * time[:, None] ** 2
    position, velocity = front_curve(time, x, np.ones(100), window=0.02)
    np.testing.assert_allclose(position, 0.5 * acceleration * time**2, atol=1e-12)
    # A quadratic Savitzky-Golay derivative is exact for a quadratic signal.
    np.testing.assert_allclose(velocity, acceleration * time, atol=1e-9)


def test_lost_bodies_are_ignored() -> None:
    x = np.array([0.0, 0.1, 0.2, np.nan])
    assert front_position(x, np.ones(4), window=0.15, min_fraction=0.5) == pytest.approx(0.2)


def test_flat_phases_find_the_switches_of_a_strong_slow_strong_front() -> None:
    """A front decelerating at 5, then 0.5, then 4 (m/s)/m with switches at 0.2 and 0.6 m, sampled every 2 cm.

    The switches are found within one sample (± 0.02 m) and the slopes exactly (the segments are lines).
    """
    x = np.linspace(-0.3, 0.8, 56)
    v = np.where(x < 0, 2.0, np.where(x < 0.2, 2.0 - 5.0 * x, np.where(x < 0.6, 1.0 - 0.5 * (x - 0.2), 0.8 - 4.0 * (x - 0.6))))
    phases = flat_phases(x, v)
    assert phases is not None and phases["strong_slow_strong"]
    assert phases["x_1"] == pytest.approx(0.2, abs=0.02) and phases["x_2"] == pytest.approx(0.6, abs=0.02)
    assert phases["x_stop"] == pytest.approx(0.8)
    assert (phases["slope_1"], phases["slope_2"], phases["slope_3"]) == pytest.approx((-5.0, -0.5, -4.0), abs=1e-9)


def test_flat_phases_refuse_a_pattern_that_is_not_there() -> None:
    """A front whose deceleration only grows (v = 2 - 3 x²) has no slow middle phase; a front that
    never reaches the flat has no phases; frames after the farthest point (a front receding) are cut."""
    x = np.linspace(0.0, 0.8, 41)
    phases = flat_phases(x, 2.0 - 3.0 * x**2)
    assert phases is not None and not phases["strong_slow_strong"]
    assert flat_phases(np.linspace(-1.0, -0.1, 20), np.ones(20)) is None
    receding = flat_phases(np.r_[x, 0.75, 0.7], np.r_[2.0 - 3.0 * x**2, -0.1, -0.1])
    assert receding is not None and receding["x_stop"] == pytest.approx(0.8)
