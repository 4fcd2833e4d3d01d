"""Deposit metrics on constructed deposits whose L, R, W, H, X_CM and angles are known exactly."""

from __future__ import annotations

import math

import numpy as np
import pytest

from orchestrator.post.deposit import deposit_metrics

R = 0.005  # body radius used for every constructed body


def grid(x: tuple[float, float], y: tuple[float, float], z: tuple[float, float], step: float = 0.01) -> np.ndarray:
    axes = [np.arange(lo, hi + step / 2, step) for lo, hi in (x, y, z)]
    return np.stack([a.ravel() for a in np.meshgrid(*axes, indexing="ij")], axis=1)


def released(final: np.ndarray) -> np.ndarray:
    """An initial mass: the same bodies as a block on the slope, top at z = 1.0 + R, x in [-1.2, -1.0]."""
    initial = final.copy()
    initial[:, 0] = -1.2 + (final[:, 0] - final[:, 0].min()) / np.ptp(final[:, 0]) * 0.2
    initial[:, 2] = 0.9 + (final[:, 2] - final[:, 2].min()) / max(np.ptp(final[:, 2]), 1e-12) * 0.1
    return initial


def test_box_deposit() -> None:
    final = grid((0.5, 1.0), (-0.1, 0.1), (0.005, 0.045))
    initial = released(final)
    m = deposit_metrics(initial, final, np.ones(len(final)), np.full(len(final), R))
    assert m.length == pytest.approx(0.5 + 2 * R)
    assert m.runout == pytest.approx(1.0 + R)
    assert m.width == pytest.approx(0.2 + 2 * R)
    assert m.height == pytest.approx(0.045 + R)
    assert m.x_cm == pytest.approx(0.75)
    cm0, cm1 = initial.mean(axis=0), final.mean(axis=0)
    assert m.travel_angle_cm_deg == pytest.approx(math.degrees(math.atan2(cm0[2] - cm1[2], cm1[0] - cm0[0])))
    assert m.fahrboschung_deg == pytest.approx(math.degrees(math.atan2(1.0 + R, 1.0 + R - initial[np.argmax(initial[:, 2]), 0])))
    assert m.outliers == 0 and m.length_raw == m.length


def test_wedge_deposit_centre_of_mass() -> None:
    """A wedge thinning downstream: height 0.1 (1 - x/1); its centre of mass sits at one third of its length."""
    points = grid((0.0, 1.0), (0.0, 0.0), (0.0, 0.1), step=0.002)
    wedge = points[points[:, 2] <= 0.1 * (1 - points[:, 0])]
    m = deposit_metrics(released(wedge), wedge, np.ones(len(wedge)), np.full(len(wedge), 1e-4), link_distance=0.01)
    assert m.x_cm == pytest.approx(1.0 / 3.0, rel=0.01)  # discretisation of the wedge: 1 %
    assert m.height == pytest.approx(0.1 + 1e-4)


def test_outliers_do_not_set_the_extents() -> None:
    final = grid((0.5, 1.0), (-0.1, 0.1), (0.005, 0.025))
    strays = np.array([[2.5, 0.0, 0.005], [1.0, 1.5, 0.005]])
    everything = np.concatenate([final, strays])
    m = deposit_metrics(released(everything), everything, np.ones(len(everything)), np.full(len(everything), R))
    assert m.outliers == 2
    assert m.runout == pytest.approx(1.0 + R) and m.runout_raw == pytest.approx(2.5 + R)
    assert m.width == pytest.approx(0.2 + 2 * R) and m.width_raw == pytest.approx(1.6 + 2 * R)
    assert m.x_cm == pytest.approx(0.75)
