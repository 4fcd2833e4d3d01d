"""Mass front on constructed flows with known fronts."""

from __future__ import annotations

import numpy as np
import pytest

from orchestrator.front import front_curve, front_position


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
