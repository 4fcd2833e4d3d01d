"""Summary metrics of a run, computed from results.h5 alone (any engine)."""

from __future__ import annotations

import numpy as np

from .results import Trajectory

REST_SPEED = 1e-3  # m/s: a body slower than this counts as at rest


def centre_of_mass(trajectory: Trajectory) -> np.ndarray:
    """(frames, 3) mass-weighted centre of the bodies present in each frame."""
    present = np.isfinite(trajectory.position[..., 0])
    weights = np.where(present, trajectory.mass[None, :], 0.0)
    positions = np.nan_to_num(trajectory.position)
    return np.einsum("fb,fbk->fk", weights, positions) / weights.sum(axis=1)[:, None]


def kinetic_energy(trajectory: Trajectory) -> np.ndarray:
    """(frames,) translational kinetic energy in J (rotation excluded: inertia is engine-specific)."""
    speed2 = np.nansum(trajectory.velocity**2, axis=2)
    return 0.5 * speed2 @ trajectory.mass


def summary(trajectory: Trajectory) -> dict[str, float]:
    """Scalars a person checks first: extent of motion, speeds, how much has come to rest."""
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
    }
