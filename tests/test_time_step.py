"""The automatic time step is fine enough: halving it changes a brick's drop-test rebound by < 1 %.

A brick tilted about two axes hits the board on a corner, spins and rebounds: several sphere
contacts open and close within one impact, the case most sensitive to the step. The rebound is
measured as the apex of the centre of mass after the first impact, and the spin there (in flight,
the spin no longer changes).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from orchestrator import physics
from orchestrator.case import Case, parse_case
from orchestrator.results import read_results
from orchestrator.results import RESULTS
from orchestrator.runner import run_case

from conftest import engine_params


def tilted_drop(engine: str, step: float | str = "auto") -> Case:
    tilt_y, tilt_x = math.radians(20.0), math.radians(10.0)
    qy = (math.cos(tilt_y / 2), 0.0, math.sin(tilt_y / 2), 0.0)
    qx = (math.cos(tilt_x / 2), math.sin(tilt_x / 2), 0.0, 0.0)
    w1, x1, y1, z1 = qy
    w2, x2, y2, z2 = qx
    orientation = (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                   w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)
    contact = {"law": "bilinear", "en2": 0.53, "mu": 0.46, "kn": 1e5, "kt_over_kn": 0.42}
    return parse_case(
        {
            "name": "drop",
            "engine": engine,
            "time": {"step": step, "duration": 0.2, "output_interval": 0.0005},
            "materials": [{"name": "brick", "density": 1700.0}, {"name": "board", "density": 1400.0}],
            "contacts": [{"materials": ["brick", "brick"], **contact}, {"materials": ["brick", "board"], **contact}],
            "shapes": [{"name": "brick", "length": 0.031, "width": 0.015, "thickness": 0.008, "layout": [4, 2, 1]}],
            "bodies": {"clumps": [{"shape": "brick", "material": "brick", "position": [0.0, 0.0, 0.05], "orientation": list(orientation)}]},
            "walls": [{"type": "rectangle", "name": "floor", "material": "board", "origin": [-0.2, -0.2, 0.0], "edge1": [0.4, 0.0, 0.0], "edge2": [0.0, 0.4, 0.0]}],
        }
    )


def rebound(case: Case, directory: Path) -> tuple[float, float]:
    """(apex height of the centre after the first impact, spin magnitude at that apex)."""
    run_case(case, directory, directory / "run")
    trajectory = read_results(directory / "run" / RESULTS)
    vz = trajectory.velocity[:, 0, 2]
    impact = int(np.argmax(vz > 0.0))  # first frame moving up: the first impact is over
    assert impact > 0, "the brick never rebounded"
    falling_again = impact + int(np.argmax(vz[impact:] < 0.0))
    top = impact + int(np.argmax(trajectory.position[impact:falling_again + 1, 0, 2]))
    apex = float(trajectory.position[top, 0, 2])
    spin = float(np.linalg.norm(trajectory.angular_velocity[top, 0]))  # in flight: constant
    print(f"apex {apex:.6f} m at {trajectory.time[top]:.4f} s, spin {spin:.4f} rad/s")
    return apex, spin


@pytest.mark.parametrize("engine", engine_params())
def test_halving_the_automatic_step_changes_the_rebound_by_less_than_one_percent(engine: str, tmp_path: Path) -> None:
    case = tilted_drop(engine)
    chosen = physics.schedule(case).dt
    apex, spin = rebound(case, tmp_path / "auto")
    apex_half, spin_half = rebound(tilted_drop(engine, step=chosen / 2.0), tmp_path / "half")
    assert apex > 0.004 + 1e-3  # it really bounced (resting height of a flat brick: 4 mm)
    assert apex_half == pytest.approx(apex, rel=0.01)
    assert spin_half == pytest.approx(spin, rel=0.01)
