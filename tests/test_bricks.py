"""Brick clumps: true mass and inertia, spheres inside the box, deviation shrinking with resolution."""

from __future__ import annotations

import numpy as np
import pytest

from orchestrator.shapes.clump import BrickClump, world_sphere_centres
from orchestrator.shapes.rigid import quaternion_matrix

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

    from orchestrator.engines.liggghts.dump import kabsch_quaternions

    template = BrickClump(0.031, 0.015, 0.008, 1700.0, (4, 2, 1)).centres
    truth = Rotation.random(200, random_state=3)
    world = np.stack([r.apply(template) for r in truth])
    x, y, z, w = truth.as_quat().T
    expected = np.stack([w, x, y, z], axis=1)
    expected[expected[:, 0] < 0] *= -1
    found = kabsch_quaternions(world, np.broadcast_to(template, world.shape))
    np.testing.assert_allclose(found, expected, atol=1e-12)


BEVELLED = BrickClump(L, W, T, RHO, (4, 2, 1), bevel_deg=2.0)


def face_planes(brick: BrickClump) -> list[tuple[np.ndarray, float]]:
    """(outward unit normal n, offset d) of the six faces, n · p ≤ d inside, in the body frame."""
    corners = brick.vertices - brick.centroid_offset
    planes = []
    for axis in range(3):
        for side in (0, 1):
            face = np.take(corners, side, axis=axis).reshape(-1, 3)
            normal = np.cross(face[1] - face[0], face[2] - face[0])
            normal /= np.linalg.norm(normal)
            inward = corners.reshape(-1, 3).mean(axis=0) - face[0]
            normal = -normal if normal @ inward > 0 else normal
            planes.append((normal, float(normal @ face[0])))
    return planes


def test_bevelled_brick_mass_centre_and_inertia_match_a_monte_carlo_count() -> None:
    """The hexahedron's closed-form moments against 2e6 random points tested against its six faces.

    Tolerances: volume and moments ± 0.5 % (sampling error ≈ 0.1 %), centre ± 0.05 mm (≈ 5 σ).
    """
    rng = np.random.default_rng(5)
    box = 1.2 * np.array([L, W, T])
    points = (rng.random((2_000_000, 3)) - 0.5) * box  # about the nominal box centre
    planes = face_planes(BEVELLED)
    normals, offsets = np.stack([n for n, _ in planes]), np.array([d for _, d in planes])
    inside = np.all((points - BEVELLED.centroid_offset) @ normals.T <= offsets, axis=1)
    volume = inside.mean() * np.prod(box)
    assert BEVELLED.volume == pytest.approx(volume, rel=5e-3)
    assert BEVELLED.volume == pytest.approx(L * W * T, rel=2e-3)  # faces turned about their centre lines
    centre = points[inside].mean(axis=0)
    np.testing.assert_allclose(BEVELLED.centroid_offset, centre, atol=5e-5)
    assert BEVELLED.centroid_offset[0] < -4e-4  # thick end at −x: the centre moves that way (0.53 mm)
    local = points[inside] - centre
    covariance = local.T @ local / inside.sum() * volume
    inertia = RHO * (np.trace(covariance) * np.eye(3) - covariance)
    np.testing.assert_allclose(BEVELLED.inertia_tensor, inertia, rtol=0, atol=5e-3 * np.abs(inertia).max())
    assert abs(BEVELLED.inertia_tensor[0, 1]) > 0.05 * BEVELLED.inertia_tensor[0, 0]  # not a box: products of inertia


@pytest.mark.parametrize("layout", [(4, 2, 1), (8, 2, 1), (6, 3, 2)])
def test_bevelled_spheres_stay_inside_and_touch_every_face(layout: tuple[int, int, int]) -> None:
    brick = BrickClump(L, W, T, RHO, layout, bevel_deg=2.0)
    for normal, offset in face_planes(brick):
        clearance = offset - brick.centres @ normal - brick.radii  # ≥ 0: the sphere is inside that face
        assert clearance.min() >= -1e-12
        assert clearance.min() == pytest.approx(0.0, abs=1e-12)  # and some sphere touches it
    assert brick.radii.min() < 0.95 * brick.radii.max()  # thinner at the +x end: smaller spheres there


def test_bevel_zero_is_the_box_and_a_bevel_is_reported_in_the_deviation() -> None:
    box, flat = BrickClump(L, W, T, RHO, (4, 2, 1)), BrickClump(L, W, T, RHO, (4, 2, 1), bevel_deg=0.0)
    np.testing.assert_array_equal(box.centres, flat.centres)
    np.testing.assert_allclose(box.extent, [L, W, T])
    np.testing.assert_allclose(BEVELLED.extent - [L, W, T], 2 * np.array([0.2619, 0.5413, 0.5413]) * 1e-3, atol=2e-7)
    assert BEVELLED.mass == pytest.approx(box.mass, rel=2e-3)
    assert BEVELLED.surface_deviation()[0] > box.surface_deviation()[0]  # the tilted faces fit the spheres less well
