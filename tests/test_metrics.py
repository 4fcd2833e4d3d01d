"""Summary metrics on constructed trajectories with known answers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from orchestrator.post.summary import centre_of_mass, kinetic_energy
from orchestrator.results import Trajectory


def trajectory(position: np.ndarray, velocity: np.ndarray, omega: np.ndarray, orientation: np.ndarray, mass: np.ndarray, inertia: np.ndarray) -> Trajectory:
    frames, bodies = position.shape[:2]
    return Trajectory(
        time=np.arange(frames, dtype=float), ids=np.arange(bodies), material=np.array(["m"] * bodies), mass=mass,
        radius=np.ones(bodies), inertia=inertia, position=position, velocity=velocity, angular_velocity=omega, orientation=orientation,
    )


def test_kinetic_energy_includes_rotation_in_the_body_frame() -> None:
    rotation = Rotation.from_euler("xyz", [0.3, -1.1, 2.0])
    inertia = np.array([[1.0, 2.0, 5.0]])
    omega_world = np.array([0.7, -0.2, 1.3])
    xyzw = rotation.as_quat()
    q = np.array([[[xyzw[3], *xyzw[:3]]]])
    t = trajectory(np.zeros((1, 1, 3)), np.array([[[1.0, 0.0, 0.0]]]), omega_world[None, None], q, np.array([2.0]), inertia)
    matrix = rotation.as_matrix()
    expected = 0.5 * 2.0 * 1.0 + 0.5 * omega_world @ (matrix @ np.diag(inertia[0]) @ matrix.T) @ omega_world
    assert kinetic_energy(t)[0] == pytest.approx(expected, rel=1e-12)


def test_unknown_orientation_uses_isotropic_inertia_and_com_skips_lost_bodies() -> None:
    position = np.array([[[0.0, 0, 0], [2.0, 0, 0]], [[1.0, 0, 0], [np.nan, np.nan, np.nan]]])
    t = trajectory(position, np.zeros_like(position), np.ones_like(position), np.full((2, 2, 4), np.nan), np.array([1.0, 3.0]), np.full((2, 3), 0.1))
    np.testing.assert_allclose(centre_of_mass(t)[:, 0], [1.5, 1.0])
    assert kinetic_energy(t)[0] == pytest.approx(0.5 * 0.1 * 3 * 2)
