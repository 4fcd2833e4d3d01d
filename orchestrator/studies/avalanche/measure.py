"""What an avalanche release is measured by: the mass at the opening (Fig. 9's initial state), the
deposit (post/deposit.py), the mass front (post/front.py) and the energy left, and a packing's
apparent density (geometry.apparent_density)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from orchestrator.case import CaseError
from orchestrator.post import deposit, front
from orchestrator.post.summary import kinetic_energy
from orchestrator.results import RESULTS, Trajectory, read_results
from orchestrator.shapes import BodyShape
from orchestrator.studies.avalanche.geometry import AvalancheGeometry, apparent_density
from orchestrator.studies.avalanche.spec import AvalancheStudy

LOST_WHILE_PACKING = "some bricks left the box while settling; check the study geometry"

def packed_density(study: AvalancheStudy, directory: Path) -> float:
    """Apparent density (kg/m³) of the settled packing in `directory` (its last frame)."""
    packed = read_results(directory / RESULTS)
    if not np.isfinite(packed.position[-1]).all():
        raise CaseError(f"packing {directory}: {LOST_WHILE_PACKING}")
    return apparent_density(study.geometry.build(), packed.position[-1], packed.orientation[-1], study.brick_spec.build())


def initial_state(geometry: AvalancheGeometry, trajectory: Trajectory, density: float, volume: float) -> dict[str, float]:
    """The mass at the opening, as Fig. 9 of the 2012 study draws it: centre of mass (x, z), the rear
    of its base on the slope (where φ_app starts), bulk volume (m³: mass over apparent density),
    apparent density (kg/m³), bricks whose centre lies outside the box, and the same points for a
    slab of `volume` flat on the box's base (the experiment's state; for the full-scale box about
    (−1.15, 1.27) and (−1.41, 1.41) m)."""
    start = trajectory.position[0]
    cm = np.average(start, axis=0, weights=trajectory.mass)
    rear = deposit.rear_of_base(start, trajectory.radius, geometry.slope_deg)
    slab_cm, slab_rear = geometry.slab(volume)
    return {"x_cm": float(cm[0]), "z_cm": float(cm[2]), "rear_x": rear[0], "rear_z": rear[1],
            "bulk_volume": float(trajectory.mass.sum() / density), "apparent_density": float(density),
            "bodies_outside_box": int(geometry.outside_box(start).sum()),
            "slab_x_cm": float(slab_cm[0]), "slab_z_cm": float(slab_cm[2]), "slab_rear_x": float(slab_rear[0]), "slab_rear_z": float(slab_rear[2])}


def measure(trajectory: Trajectory, brick: BodyShape, first_frame: int = 0, gravity: float = 9.81, slope_deg: float = 45.0) -> dict[str, Any]:
    """Deposit metrics on the last frame and the front curve from `first_frame` (the trap opening) on.

    gravity: m/s², the downward (−z) component of the case's gravity, for the released energy;
    slope_deg: the slope, for the rear of the initial mass (φ_app)."""
    metrics = deposit.deposit_metrics(trajectory.position[first_frame], trajectory.position[-1], trajectory.mass, trajectory.radius,
                                      slope_deg=slope_deg)
    # The front is the leading brick among those that end in the deposit: the rule of R (deposit.py),
    # less the brick's bounding radius, so a group that runs ahead and leaves never holds it.
    time = trajectory.time[first_frame:] - trajectory.time[first_frame]
    members = deposit.deposit_members(trajectory.position[-1], trajectory.radius)
    position, velocity = front.front_curve(time, trajectory.position[first_frame:, :, 0], trajectory.mass, window=2 * brick.length,
                                           min_fraction=0.0, members=members)
    on_flat = position >= 0.0
    return {
        "deposit": metrics.as_dict(),
        "front": {
            "time": time.tolist(),
            "position": position.tolist(),
            "velocity": velocity.tolist(),
            "max_velocity": float(np.nanmax(velocity)),
            "max_velocity_on_flat": float(np.nanmax(velocity[on_flat])) if on_flat.any() else float("nan"),
            "final_position": float(position[-1]),
            "flat_phases": front.flat_phases(position, velocity),
        },
        "kinetic_to_released_energy": released_ratio(trajectory, first_frame, gravity),
    }


def released_ratio(trajectory: Trajectory, first_frame: int, gravity: float = 9.81) -> float:
    """Kinetic energy at the end over the potential energy released since `first_frame`: ~0 when stopped.

    gravity: m/s², the downward (−z) component of the case's gravity."""
    released = gravity * float(np.nansum(trajectory.mass * (trajectory.position[first_frame, :, 2] - trajectory.position[-1, :, 2])))
    return float(kinetic_energy(trajectory)[-1] / released) if released > 0 else float("nan")
