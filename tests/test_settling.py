"""No end-of-flow oscillation: 50 clumped bricks rained onto a floor come to rest with no global damping."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from orchestrator.bricks import BrickClump
from orchestrator.case import Case, parse_case
from orchestrator.metrics import kinetic_energy
from orchestrator.packing import loose_grid
from orchestrator.results import read_results
from orchestrator.runner import RESULTS, run_case

from conftest import engine_params

BRICK = {"length": 0.031, "width": 0.015, "thickness": 0.008, "layout": [4, 2, 1]}


def pile_case(engine: str, count: int = 50, duration: float = 1.0) -> Case:
    brick = BrickClump(BRICK["length"], BRICK["width"], BRICK["thickness"], 1700.0, tuple(BRICK["layout"]))
    positions, orientations = loose_grid(brick, count, (-0.08, -0.08, 0.001), (5, 5), seed=7)
    return parse_case(
        {
            "name": "pile",
            "engine": engine,
            "time": {"duration": duration, "output_interval": 0.02},
            "materials": [{"name": "brick", "density": 1700.0}, {"name": "board", "density": 1400.0}],
            "contacts": [
                {"materials": ["brick", "brick"], "law": "bilinear", "en2": 0.13, "mu": 0.86, "kn": 1e5, "kt_over_kn": 0.27},
                {"materials": ["brick", "board"], "law": "bilinear", "en2": 0.53, "mu": 0.46, "kn": 1e5, "kt_over_kn": 0.42},
            ],
            "shapes": [{"name": "brick", **BRICK}],
            "bodies": {
                "clumps": [
                    {"shape": "brick", "material": "brick", "position": p.tolist(), "orientation": q.tolist()}
                    for p, q in zip(positions, orientations)
                ]
            },
            "walls": [{"type": "rectangle", "name": "floor", "material": "board", "origin": [-0.3, -0.3, 0], "edge1": [0.6, 0, 0], "edge2": [0, 0.6, 0]}],
        }
    )


@pytest.mark.parametrize("engine", engine_params())
def test_fifty_bricks_settle_without_damping(engine: str, tmp_path: Path) -> None:
    run_case(pile_case(engine), tmp_path, tmp_path / "run")
    trajectory = read_results(tmp_path / "run" / RESULTS)
    drop = 9.81 * np.sum(trajectory.mass * (trajectory.position[0, :, 2] - trajectory.position[-1, :, 2]))
    assert drop > 0.05  # the bricks did fall (~0.085 J) ...
    assert np.all(trajectory.position[-1, :, 2] < 0.05)  # ... into a pile a few bricks high
    # Issue 3: kinetic energy below 1e-6 of the potential-energy drop within 1 s.
    assert kinetic_energy(trajectory)[-1] < 1e-6 * drop
