"""Summary metrics of a run, computed from results.h5 alone (any engine)."""

from __future__ import annotations

import numpy as np

from orchestrator.post.lost import require_bodies
from orchestrator.results import Trajectory

REST_SPEED = 1e-3  # m/s: a body slower than this counts as at rest


def centre_of_mass(trajectory: Trajectory) -> np.ndarray:
    """(frames, 3) mass-weighted centre of the bodies present in each frame."""
    present = np.isfinite(trajectory.position[..., 0])
    weights = np.where(present, trajectory.mass[None, :], 0.0)
    positions = np.nan_to_num(trajectory.position)
    return np.einsum("fb,fbk->fk", weights, positions) / weights.sum(axis=1)[:, None]


def kinetic_energy(trajectory: Trajectory) -> np.ndarray:
    """(frames,) translational plus rotational kinetic energy in J.

    Rotation: ½ Σ_k I_k ω_k² with ω in the body frame (ω_body = Rᵀ ω). Where the orientation is
    unknown (LIGGGHTS spheres) the inertia is isotropic, so the world-frame ω gives the same sum.
    """
    speed2 = np.nansum(trajectory.velocity**2, axis=2)
    translation = 0.5 * speed2 @ trajectory.mass
    omega = np.nan_to_num(trajectory.angular_velocity)
    q = trajectory.orientation
    known = np.isfinite(q).all(axis=2)
    body_omega = np.where(known[..., None], _rotate_inverse(np.where(known[..., None], q, [1.0, 0, 0, 0]), omega), omega)
    rotation = 0.5 * np.einsum("fbk,bk->f", body_omega**2, trajectory.inertia)
    return translation + rotation


def _rotate_inverse(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v by the inverse of unit quaternions q (w, x, y, z), elementwise over leading axes."""
    w, u = q[..., :1], -q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def summary(trajectory: Trajectory) -> dict[str, float]:
    """Scalars a person checks first: extent of motion, speeds, how much has come to rest; NoBodyLeft
    (a ValueError) when every body was lost by the last frame."""
    require_bodies(trajectory.position[-1], "results.h5")
    com = centre_of_mass(trajectory)
    speed = np.linalg.norm(trajectory.velocity, axis=2)
    final_speed = speed[-1]
    present = np.isfinite(final_speed)
    travel = com[-1] - com[0]
    return {
        "bodies": float(trajectory.n_bodies),
        "bodies_present_at_end": float(present.sum()),
        "end_time_s": float(trajectory.time[-1]),
        "com_travel_x_m": float(travel[0]),
        "com_travel_y_m": float(travel[1]),
        "com_travel_z_m": float(travel[2]),
        "com_travel_m": float(np.linalg.norm(travel)),
        "max_speed_m_s": float(np.nanmax(speed)),
        "final_mean_speed_m_s": float(np.nanmean(final_speed)),
        "final_kinetic_energy_J": float(kinetic_energy(trajectory)[-1]),
        "fraction_at_rest": float(np.mean(final_speed[present] < REST_SPEED)) if present.any() else 0.0,
        **({"final_coordination_number": float(trajectory.contacts.coordination(trajectory.position)[-1]),
            "final_contacts": float(np.diff(trajectory.contacts.offset)[-1])} if trajectory.contacts is not None else {}),
    }
