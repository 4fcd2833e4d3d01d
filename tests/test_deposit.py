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
    assert m.outliers == 0 and m.length_raw == m.length


def test_fahrboschung_starts_at_the_rear_of_the_base_on_the_slope_as_fig9_draws_it() -> None:
    """A slab of two layers of bodies resting on a 45° slope, s from 1.414 to 2.014 m up the slope (the
    experiment's box: its base's upper end at about (−1.42, 1.42) m), one body perched 0.1 m above the
    slab's middle. φ_app runs from the rear of the slab's base (s_max + R on the slope) to the distal
    end on the board, whatever stands above the slab; a perched body would set the old 'top of the
    mass' line (atan of a higher point), not this one."""
    c = math.cos(math.radians(45.0))
    s = np.linspace(1.414, 2.014, 31)
    layers = [np.stack([-si * c + n * c * np.ones_like(si), np.zeros_like(si), si * c + n * c * np.ones_like(si)], axis=1)
              for si, n in ((s, R), (s, 3 * R))]
    perched = np.array([[-1.714 * c + 0.1 * c, 0.0, 1.714 * c + 0.1 * c]])
    initial = np.concatenate(layers + [perched])
    final = grid((0.5, 1.0), (0.0, 0.0), (R, R), step=0.5 / (len(initial) - 1))[: len(initial)]
    m = deposit_metrics(initial, final, np.ones(len(final)), np.full(len(final), R), slope_deg=45.0)
    rear = 2.014 + R
    expected = math.degrees(math.atan2(rear * c, m.runout + rear * c))
    assert m.runout == pytest.approx(1.0 + R)
    assert m.fahrboschung_deg == pytest.approx(expected, abs=1e-9)
    # On a 30° slope the same centres sit elsewhere on it: the rule follows the slope it is given.
    assert deposit_metrics(initial, final, np.ones(len(final)), np.full(len(final), R), slope_deg=30.0).fahrboschung_deg != pytest.approx(expected)


def test_a_mass_released_from_the_flat_has_no_fahrboschung() -> None:
    final = grid((0.5, 1.0), (-0.1, 0.1), (0.005, 0.025))
    initial = final - [0.4, 0.0, 0.0]  # on the board, nothing on the slope
    assert math.isnan(deposit_metrics(initial, final, np.ones(len(final)), np.full(len(final), R)).fahrboschung_deg)


def test_wedge_deposit_centre_of_mass() -> None:
    """A wedge thinning downstream: height 0.1 (1 - x/1); its centre of mass sits at one third of its length."""
    points = grid((0.0, 1.0), (0.0, 0.0), (0.0, 0.1), step=0.002)
    wedge = points[points[:, 2] <= 0.1 * (1 - points[:, 0])]
    m = deposit_metrics(released(wedge), wedge, np.ones(len(wedge)), np.full(len(wedge), 1e-4), link_distance=0.01)
    assert m.x_cm == pytest.approx(1.0 / 3.0, rel=0.01)  # discretisation of the wedge: 1 %
    assert m.height == pytest.approx(0.1 + 1e-4)


def test_bodies_resting_upslope_of_the_toe_are_counted_on_the_slope() -> None:
    final = grid((0.0, 0.3), (-0.05, 0.05), (0.005, 0.005))
    final[:7, 0] -= 0.2  # seven bodies left on the slope (x < 0), the rest on the board
    m = deposit_metrics(released(final), final, np.ones(len(final)), np.full(len(final), R))
    assert m.bodies_on_slope == int((final[:, 0] < 0).sum()) == 7


def test_outliers_do_not_set_the_extents() -> None:
    final = grid((0.5, 1.0), (-0.1, 0.1), (0.005, 0.025))
    strays = np.array([[2.5, 0.0, 0.005], [1.0, 1.5, 0.005]])
    everything = np.concatenate([final, strays])
    m = deposit_metrics(released(everything), everything, np.ones(len(everything)), np.full(len(everything), R))
    assert m.outliers == 2
    assert m.runout == pytest.approx(1.0 + R) and m.runout_raw == pytest.approx(2.5 + R)
    assert m.width == pytest.approx(0.2 + 2 * R) and m.width_raw == pytest.approx(1.6 + 2 * R)
    assert m.x_cm == pytest.approx(0.75)


def test_the_thickness_map_holds_the_highest_top_above_the_ground() -> None:
    """Two spheres stacked on the board and one on the 45° slope: the board cell holds the top of the
    upper sphere, the slope cell the sphere's top above the slope surface, other cells nothing."""
    from orchestrator.post.deposit import thickness_map

    points = np.array([[0.105, 0.005, 0.004], [0.105, 0.005, 0.012], [-0.045, 0.005, 0.05]])
    radii = np.array([0.004, 0.004, 0.004])
    x_edges, y_edges, grid = thickness_map(points, radii, 45.0, 0.01)
    i = np.searchsorted(x_edges, 0.105) - 1
    k = np.searchsorted(x_edges, -0.045) - 1
    assert grid[i, 0] == pytest.approx(0.016)
    assert grid[k, 0] == pytest.approx(0.054 - 0.045)
    assert np.isfinite(grid).sum() == 2


def test_the_deposit_picture_draws_a_thickness_map(tmp_path) -> None:
    """A constructed deposit of 40 bricks on the board and one far ahead: the picture is written."""
    from orchestrator.shapes.clump import brick_clump
    from orchestrator.results import Trajectory
    from orchestrator.studies.avalanche.report import plot_deposit

    rng = np.random.default_rng(3)
    n = 41
    final = np.column_stack([rng.uniform(0.0, 0.2, n), rng.uniform(-0.1, 0.1, n), np.full(n, 0.004)])
    final[-1] = [0.9, 0.0, 0.004]
    initial = final - [0.5, 0.0, -0.5]
    zeros = np.zeros((2, n, 3))
    orientation = np.tile([1.0, 0.0, 0.0, 0.0], (2, n, 1))
    trajectory = Trajectory(np.array([0.0, 1.0]), np.arange(n), np.array(["brick"] * n), np.full(n, 6.2e-3), np.full(n, 0.0162),
                            np.ones((n, 3)), np.stack([initial, final]), zeros, zeros, orientation)
    plot_deposit(trajectory, brick_clump(0.031, 0.015, 0.008, 1700.0, (4, 2, 1), rounding=0.001), tmp_path / "deposit.png")
    assert (tmp_path / "deposit.png").stat().st_size > 10_000
