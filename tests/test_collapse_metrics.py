"""Collapse metrics on constructed grains and curves whose fronts, phases and interfaces are known."""

from __future__ import annotations

import math

import numpy as np
import pytest

from orchestrator.post import collapse as cm

D = 0.002  # mean grain diameter of the constructed deposits
FRACTION = 0.8


def planar_layer(x_from: float, x_to: float, thickness: float) -> tuple[np.ndarray, np.ndarray]:
    """Grains (2D: y = 0) on a square lattice filling x_from..x_to, 0..thickness; radii chosen so
    that the layer's solid fraction is FRACTION exactly (π r² per d² cell)."""
    xs = np.arange(x_from + D / 2, x_to, D)
    zs = np.arange(D / 2, thickness, D)
    positions = np.array([(x, 0.0, z) for z in zs for x in xs])
    radius = math.sqrt(FRACTION * D * D / math.pi)
    return positions, np.full(len(positions), radius)


def grid(length: float = 0.4, column_measure: float = 0.0) -> cm.ProfileGrid:
    return cm.profile_grid(length, D, 1.0, FRACTION, True, column_measure)


def test_thickness_of_a_uniform_layer_is_its_height() -> None:
    positions, radii = planar_layer(0.0, 0.1, 0.01)
    h = cm.thickness_profile(positions[:, 0], cm.grain_measure(radii, True), grid().edges, 1.0, FRACTION)
    assert h[:50] == pytest.approx(0.01, rel=1e-9)  # 5 rows of d = 2 mm
    assert not h[50:].any()


def test_front_of_a_wedge_with_an_ejected_grain() -> None:
    """A wedge from the gate to x = 0.15 m (2 mm thick at its tip) and one grain thrown to 0.3 m:
    the front is at the wedge's tip (within the 3 d smoothing window), not at the lone grain."""
    parts = [planar_layer(0.0, 0.15, 0.002)[0], planar_layer(0.0, 0.08, 0.010)[0]]
    positions = np.concatenate(parts + [np.array([[0.3, 0.0, D / 2]])])
    radii = np.full(len(positions), math.sqrt(FRACTION * D * D / math.pi))
    g = grid()
    behind_the_gate = positions - [1.0, 0.0, 0.0]  # frame 0: nothing on the channel yet
    everyone = np.ones(len(radii), bool)
    front = cm.front_positions(cm.profiles(np.stack([behind_the_gate, positions]), radii, everyone, g), g)
    assert front[0] == 0.0
    assert abs(front[1] - 0.15) <= 1.5 * D
    without = cm.profiles(np.stack([behind_the_gate[:-1], positions[:-1]]), radii[:-1], everyone[:-1], g)
    assert cm.front_positions(without, g)[1] == front[1]


def test_a_small_cluster_ahead_is_ignored_but_a_big_one_counts() -> None:
    edges = grid().edges
    added = np.zeros(len(edges) - 1)
    added[:40] = 0.01  # the flow: 1 cm over 8 cm
    added[100:103] = 0.003  # three slices of a few grains, far ahead
    amount = 5 * math.pi * D**2 / 4 / FRACTION  # five grains' worth
    assert cm.front_from_profile(edges, added, D, amount) == pytest.approx(edges[41])
    added[100:130] = 0.004  # a real surge ahead (30 slices): it is the front
    assert cm.front_from_profile(edges, added, D, amount) == pytest.approx(edges[131])


def test_grains_piled_at_the_end_wall_are_not_the_front() -> None:
    """Grains that rolled away one by one collect against the end wall (a stopped mass at 2.7 R0
    read as 7 R0 in a 22° trial): a detached pile there is not the front, a flow reaching it is."""
    edges = grid().edges
    added = np.zeros(len(edges) - 1)
    added[:40] = 0.01  # the stopped mass
    added[-4:] = 0.004  # the pile against the end wall: 4 slices, far more than five grains
    amount = 5 * math.pi * D**2 / 4 / FRACTION
    assert cm.front_from_profile(edges, added, D, amount) == pytest.approx(edges[41])
    added[40:] = 0.004  # the flow itself reaches the end wall
    assert cm.front_from_profile(edges, added, D, amount) == pytest.approx(edges[-1])


def test_a_scoured_bed_behind_the_flow_does_not_cut_the_front() -> None:
    edges = grid().edges
    added = np.zeros(len(edges) - 1)
    added[:20] = -0.004  # bed eroded near the gate (negative added thickness)
    added[20:60] = 0.006  # the flowing mass further down
    assert cm.front_from_profile(edges, added, D, 1e-6) == pytest.approx(edges[61])


def test_front_velocity_of_a_known_motion() -> None:
    times = np.linspace(0.0, 1.0, 101)
    front = 0.3 * times**2
    velocity = cm.front_velocity(times, front)
    assert velocity[10:-10] == pytest.approx(0.6 * times[10:-10], abs=1e-9)


def piecewise(times: np.ndarray, knots: list[tuple[float, float]]) -> np.ndarray:
    return np.interp(times, [t for t, _ in knots], [v for _, v in knots])


def test_three_phases_are_found_where_they_switch() -> None:
    """Acceleration to 1.6 m/s at 0.3 s, fast deceleration to 0.2 m/s at 0.6 s, slow phase to
    0.15 m/s at 1.2 s, rest from 1.3 s: switches found within two output intervals."""
    times = np.linspace(0.0, 2.0, 201)
    velocity = piecewise(times, [(0.0, 0.0), (0.3, 1.6), (0.6, 0.2), (1.2, 0.15), (1.3, 0.0), (2.0, 0.0)])
    front = np.concatenate([[0.0], np.cumsum(0.5 * (velocity[1:] + velocity[:-1]) * np.diff(times))])
    phases = cm.front_phases(times, velocity, front)
    assert phases["t_max"] == pytest.approx(0.3, abs=0.02)
    assert phases["slow_phase"] is True
    assert phases["t_slow"] == pytest.approx(0.6, abs=0.02)
    assert phases["v_slow"] == pytest.approx(0.17, abs=0.03)
    assert phases["t_stop"] == pytest.approx(1.3, abs=0.02)
    assert phases["at_rest"] is True
    assert phases["x_stop"] == pytest.approx(np.interp(phases["t_stop"], times, front), abs=1e-12)


def test_no_slow_phase_when_the_front_decelerates_to_rest() -> None:
    times = np.linspace(0.0, 1.5, 151)
    velocity = piecewise(times, [(0.0, 0.0), (0.2, 1.0), (0.8, 0.0), (1.5, 0.0)])
    front = np.concatenate([[0.0], np.cumsum(0.5 * (velocity[1:] + velocity[:-1]) * np.diff(times))])
    phases = cm.front_phases(times, velocity, front)
    assert phases["slow_phase"] is False
    assert phases["t_stop"] == pytest.approx(0.8, abs=0.03)


def test_a_front_still_moving_is_not_at_rest() -> None:
    times = np.linspace(0.0, 1.0, 101)
    phases = cm.front_phases(times, piecewise(times, [(0.0, 0.0), (0.3, 1.0), (1.0, 0.3)]), times)
    assert phases["at_rest"] is False


def test_static_flowing_interface_of_a_sheared_stack() -> None:
    """Ten layers at x = 0.1 m: the lower six static, the upper four flowing at 0.5 m/s."""
    z = np.array([D / 2 + k * D for k in range(10)])
    ux = np.where(np.arange(10) < 6, 0.0, 0.5)
    x = np.full(10, 0.1)
    radii = np.full(10, D / 2)
    assert cm.static_flowing_interface(z, ux, x, radii, 0.1, D) == pytest.approx(6 * D)
    assert cm.static_flowing_interface(z, np.zeros(10), x, radii, 0.1, D) == pytest.approx(10 * D)  # all static: the surface
    assert cm.static_flowing_interface(z, np.full(10, 0.5), x, radii, 0.1, D) == 0.0  # all flowing
    assert math.isnan(cm.static_flowing_interface(z, ux, x, radii, 0.3, D))  # nobody there


def test_bed_energy_ratio_and_entrained_mass() -> None:
    masses = np.array([1.0, 2.0, 3.0])
    bed = np.array([False, True, True])
    z = np.array([0.5, 0.1, 0.2])
    velocity = np.array([[9.0, 0, 0], [1.0, 0, 0], [0.0, 0, 2.0]])
    expected = (0.5 * 2 * 1 + 0.5 * 3 * 4) / (9.81 * (2 * 0.1 + 3 * 0.2))
    assert cm.bed_energy_ratio(z, velocity, masses, bed, 9.81) == pytest.approx(expected)
    assert math.isnan(cm.bed_energy_ratio(z, velocity, masses, np.zeros(3, bool), 9.81))
    start = np.zeros((3, 3))
    now = np.array([[1.0, 0, 0], [0.5 * D, 0, 0], [3 * D, 0, 0]])
    assert cm.entrained_mass(now, start, masses, bed, D) == 3.0  # only the grain moved by more than d


def test_column_fraction() -> None:
    _, radii = planar_layer(-0.1, 0.0, 0.07)
    assert cm.column_fraction(radii, 0.1, 0.07, 0.0, True) == pytest.approx(FRACTION, rel=0.03)
