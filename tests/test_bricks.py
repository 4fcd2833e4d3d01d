"""Brick clumps: true mass and inertia, spheres inside the box, deviation shrinking with resolution."""

from __future__ import annotations

import numpy as np
import pytest

from orchestrator.bricks import BrickClump, quaternion_matrix, world_sphere_centres

L, W, T, RHO = 0.031, 0.015, 0.008, 1700.0


def test_mass_and_inertia_are_those_of_the_full_box() -> None:
    brick = BrickClump(L, W, T, RHO, (4, 2, 1))
    assert brick.mass == pytest.approx(RHO * L * W * T)
    assert brick.mass == pytest.approx(6.3e-3, rel=0.01)  # "mass ≈ 6.3 g" in the 2012 study
    # Monte-Carlo check of I_x = ∫ ρ (y² + z²) dV over the box, 1e6 points: ±0.5 %.
    rng = np.random.default_rng(1)
    points = (rng.random((1_000_000, 3)) - 0.5) * np.array([L, W, T])
    numeric = brick.mass * np.mean(np.stack([points[:, 1] ** 2 + points[:, 2] ** 2, points[:, 0] ** 2 + points[:, 2] ** 2, points[:, 0] ** 2 + points[:, 1] ** 2], axis=1), axis=0)
    np.testing.assert_allclose(brick.principal_inertia, numeric, rtol=5e-3)


@pytest.mark.parametrize("layout", [(4, 2, 1), (8, 2, 1), (6, 3, 2)])
def test_spheres_stay_inside_and_touch_the_box(layout: tuple[int, int, int]) -> None:
    brick = BrickClump(L, W, T, RHO, layout)
    reach = np.abs(brick.centres) + brick.radius
    half = np.array([L, W, T]) / 2
    assert np.all(reach <= half + 1e-12)
    np.testing.assert_allclose(reach.max(axis=0), half, rtol=1e-12)
    assert len(brick.centres) == brick.n_spheres


def test_surface_deviation_falls_with_resolution() -> None:
    coarse = BrickClump(L, W, T, RHO, (4, 2, 1)).surface_deviation()
    fine = BrickClump(L, W, T, RHO, (12, 6, 2)).surface_deviation()
    assert fine[0] < coarse[0] and fine[1] < coarse[1]
    assert coarse[1] == pytest.approx(1.12e-3, rel=0.05)  # measured once; 2x4 spheres: ~1.1 mm mean gap


def test_quaternion_rotation_and_placement() -> None:
    quarter_turn_z = (np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4))
    np.testing.assert_allclose(quaternion_matrix(quarter_turn_z) @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    brick = BrickClump(L, W, T, RHO, (4, 2, 1))
    centres = world_sphere_centres(brick, np.array([1.0, 2.0, 3.0]), np.array(quarter_turn_z))
    np.testing.assert_allclose(centres.mean(axis=0), [1.0, 2.0, 3.0], atol=1e-15)
    np.testing.assert_allclose(np.ptp(centres[:, 1]), L - 2 * brick.radius, rtol=1e-12)  # length now along y


def test_batched_kabsch_recovers_known_rotations() -> None:
    """The dump reader's batched fit gives back the rotations that placed the template."""
    from scipy.spatial.transform import Rotation

    from orchestrator.engines.liggghts import kabsch_quaternions

    template = BrickClump(0.031, 0.015, 0.008, 1700.0, (4, 2, 1)).centres
    truth = Rotation.random(200, random_state=3)
    world = np.stack([r.apply(template) for r in truth])
    x, y, z, w = truth.as_quat().T
    expected = np.stack([w, x, y, z], axis=1)
    expected[expected[:, 0] < 0] *= -1
    found = kabsch_quaternions(world, np.broadcast_to(template, world.shape))
    np.testing.assert_allclose(found, expected, atol=1e-12)
