"""The paper's modified bricks: a bevelled brick laid on its bevelled face rests tilted by the bevel.

Real engines on one brick: this checks the per-sphere radii, the true centre of mass and the full
inertia tensor of a bevelled clump in each engine, and that the recorded body state is the brick's
(its centre of mass and frame), not the engine's sphere-union centroid.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from orchestrator.shapes.clump import BrickClump
from orchestrator.shapes.rigid import quaternion_matrix
from orchestrator.case import parse_case
from orchestrator.results import read_results
from orchestrator.results import RESULTS
from orchestrator.runner import run_case

from conftest import engine_params

BEVEL = 2.0
BRICK = BrickClump(0.031, 0.015, 0.008, 1700.0, (4, 2, 1), bevel_deg=BEVEL)
UPSIDE_DOWN = (0.0, 1.0, 0.0, 0.0)  # half a turn about x: the bevelled +z face down


def bevelled_drop(engine: str) -> dict:
    """One bevelled brick, upside down and level, 2 mm above a floor: it lands and rocks onto its bevelled face."""
    lowest = float((BRICK.vertices.reshape(-1, 3) - BRICK.centroid_offset)[:, 2].max())  # body +z reach → world −z
    return {
        "name": "bevel",
        "engine": engine,
        "time": {"duration": 0.6, "output_interval": 0.05},
        "materials": [{"name": "brick", "density": 1700.0}, {"name": "board", "density": 1400.0}],
        "contacts": [
            {"materials": ["brick", "brick"], "law": "bilinear", "en2": 0.13, "mu": 0.86, "kn": 1e5, "kt_over_kn": 0.27},
            {"materials": ["brick", "board"], "law": "bilinear", "en2": 0.53, "mu": 0.46, "kn": 1e5, "kt_over_kn": 0.42},
        ],
        "shapes": [{"name": "brick", "length": 0.031, "width": 0.015, "thickness": 0.008, "layout": [4, 2, 1], "bevel_deg": BEVEL}],
        "bodies": {"clumps": [{"shape": "brick", "material": "brick", "position": [0.0, 0.0, lowest + 0.002], "orientation": list(UPSIDE_DOWN)}]},
        "walls": [{"type": "rectangle", "name": "floor", "material": "board", "origin": [-0.1, -0.1, 0.0], "edge1": [0.2, 0, 0], "edge2": [0, 0.2, 0]}],
    }


@pytest.mark.parametrize("engine", engine_params())
def test_bevelled_brick_rests_on_its_bevelled_face_tilted_by_the_bevel(engine: str, tmp_path: Path) -> None:
    case = parse_case(bevelled_drop(engine))
    run_case(case, tmp_path, tmp_path / "run")
    trajectory = read_results(tmp_path / "run" / RESULTS)
    assert trajectory.mass[0] == pytest.approx(BRICK.mass)
    assert np.linalg.norm(trajectory.velocity[-1, 0]) < 1e-3  # at rest
    rotation = quaternion_matrix(trajectory.orientation[-1, 0])
    # The bevelled face lies on the floor, so the brick's z axis is 2° off the downward vertical.
    # ± 0.1°: the spheres touch the bevelled plane exactly; the rest overlap (≈ 1e-7 m) tilts nothing.
    tilt = math.degrees(math.acos(-rotation[2, 2]))
    assert tilt == pytest.approx(BEVEL, abs=0.1)
    # The centre of mass sits at its distance from the bevelled face: (c/2 − t x0 − z0) cos β with
    # (x0, y0, z0) its offset from the box centre (4.007 mm). ± 10 µm: the sphere union's centroid,
    # which both engines integrate about, is 0.3 mm away, and uncorrected it would read 30 µm off.
    t = math.tan(math.radians(BEVEL))
    x0, _, z0 = BRICK.centroid_offset
    expected = (BRICK.thickness / 2 - t * x0 - z0) * math.cos(math.radians(BEVEL))
    assert trajectory.position[-1, 0, 2] == pytest.approx(expected, abs=1e-5)
    if engine == "yade":  # YADE places clumps exactly: the first frame is the requested centre of mass
        np.testing.assert_allclose(trajectory.position[0, 0], case.bodies.clumps[0].position, atol=1e-9)
