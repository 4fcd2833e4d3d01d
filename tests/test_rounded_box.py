"""The rounded-box brick on LIGGGHTS (pair_style roundedbox, custom_contact/): the study's brick as
the study models it, several contact points per touching face.

Brick on brick (orchestrator/studies/brick_pair.py; reference.toml [brick_pair.richefeu_code]): the
study's code starts sliding at atan 0.86 = 40.6955° in every placement. Acceptance of the brick
issue: each of the five placements moves at most 1 mm in 0.4 s at 40.2° and at least 5 mm at 41.2°
(the study's code: 0.03–0.13 mm at 40.5°, 6.7–28 mm at 41°); at 47° the upper brick slides at
g (sin θ − μ cos θ) = 1.4208 m/s² within 1 % (fitted over 0.01–0.05 s, before it tips off the lower
brick's edge). The flat drop (constants A): rebound ratio within 0.5 % of the study's code's.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from orchestrator.case import parse_case
from orchestrator.engines import RunOptions
from orchestrator.results import RELEASE_DIR, read_results
from orchestrator.runner import run_case
from orchestrator.studies import brick_drop, brick_pair

from conftest import requires_liggghts

pytestmark = [pytest.mark.engine, requires_liggghts]
ROUNDED_BOX = brick_drop.study_brick(kind="rounded_box")


@pytest.mark.parametrize("placement", brick_pair.PLACEMENTS)
def test_a_rounded_box_holds_half_a_degree_below_the_friction_angle_and_slides_half_a_degree_above(placement: str, tmp_path: Path) -> None:
    below = brick_pair.run_pair("liggghts", ROUNDED_BOX, placement, 40.2, tmp_path / "below")
    above = brick_pair.run_pair("liggghts", ROUNDED_BOX, placement, 41.2, tmp_path / "above")
    assert below["glued_moved"] == 0.0 and above["glued_moved"] == 0.0
    assert abs(below["slide"]) <= 1e-3
    assert abs(above["slide"]) >= 5e-3


@pytest.mark.parametrize("placement", brick_pair.PLACEMENTS)
def test_a_rounded_box_slides_as_the_study_brick_at_every_angle(placement: str, tmp_path: Path) -> None:
    """The slide after 0.4 s against the tilt, beside the study's code's (reference.toml
    [brick_pair.richefeu_code] slide_mm): from 40.7° on (sliding) within 10 %; below (the tangential
    springs' elastic creep, tens of microns) within 15 µm. Measured 2026-12-04: at 40.7° 1.23–1.40 mm
    (the study's code: 1.28–1.45), at 41° 6.66–26.4 mm (6.69–27.8), at 42° 48.5–172.8 mm (48.9–173.6):
    2 % to 6 % short of the study's, its dt being 1e-6 s against 5.56 µs here."""
    reference = brick_pair.reference()
    row = reference["slide_mm"][reference["placements"].index(placement)]
    for angle, expected in zip(reference["angles_deg"], row):
        if angle == 40.0:  # the 40.2° check above covers it
            continue
        slide = 1e3 * brick_pair.run_pair("liggghts", ROUNDED_BOX, placement, angle, tmp_path / f"{angle}")["slide"]
        if angle >= 40.7:
            assert slide == pytest.approx(expected, rel=0.10), (angle, slide, expected)
        else:
            assert slide == pytest.approx(expected, abs=0.015), (angle, slide, expected)


def test_a_rounded_box_slides_at_coulombs_acceleration(tmp_path: Path) -> None:
    """47°: within 1 % of g (sin θ − μ cos θ) (the study's code: within 1e-4 m/s²)."""
    metrics = brick_pair.run_pair("liggghts", ROUNDED_BOX, "aligned", 47.0, tmp_path)
    assert metrics["acceleration"] == pytest.approx(brick_pair.expected_acceleration(47.0), rel=0.01)


@pytest.mark.parametrize("constants", ["A", "B"])
def test_the_rounded_box_flat_drop_rebounds_as_the_study_brick(constants: str, tmp_path: Path) -> None:
    """Four corners of k_n each land as the study's brick's: both rebound ratios within 0.5 %.
    Measured 2026-12-04: A 0.72717 / 0.72689 (0.72720 / 0.72688), B 0.35744 / 0.35187 (0.35750 / 0.35172)."""
    metrics = brick_drop.run_drop("liggghts", ROUNDED_BOX, constants, False, tmp_path)
    expected = brick_drop.reference()["flat"][f"rebound_ratio_{constants}"]
    assert metrics["rebound_ratios"] == pytest.approx(expected, rel=0.005)


def test_the_tilted_rounded_box_drops_land_where_the_study_brick_lands(tmp_path: Path) -> None:
    """Corner, then edge, then face impacts, each a different number of contact points. Set A: the
    centre's apex within 1 mm and the second landing within 2 ms (the study's code is not step-robust
    after 0.27 s), the travel at 0.27 s within 1 mm. Set B: at rest within 5 ms of the study's brick,
    lying flat, its corners within 1 mm (mean) of the study brick's resting corners.
    Measured 2026-12-04: apex 27.13 mm (27.48), landing 0.2701 s (0.2719);
    B at rest 0.254 s (0.2553), corners 0.33 mm off (the rounded clump: 0.30; the superquadric: 22.5)."""
    tilted = brick_drop.reference()["tilted"]
    a = brick_drop.run_drop("liggghts", ROUNDED_BOX, "A", True, tmp_path / "A")
    assert a["centre_apex"] == pytest.approx(tilted["A_centre_apex"][0], abs=1e-3)
    assert a["second_landing"] == pytest.approx(tilted["A_second_landing"], abs=2e-3)
    assert a["travel_at_027"] == pytest.approx(tilted["A_horizontal_travel_at_027"], abs=1e-3)
    b, drop = brick_drop.measure_drop("liggghts", ROUNDED_BOX, "B", True, tmp_path / "B")
    assert b["rest_time"] == pytest.approx(tilted["B_rest_time"], abs=5e-3)
    assert b["lying_flat"]
    rest = drop.rest_frame()
    half = 0.5 * np.array([ROUNDED_BOX["length"], ROUNDED_BOX["width"], ROUNDED_BOX["thickness"]])
    assert drop.corner_error(rest, half, np.array(tilted["B_rest_centre"]), tilted["B_rest_yaw_deg"]) <= 1e-3


def test_rounded_boxes_rest_on_a_wall_and_on_each_other_over_two_processes(tmp_path: Path) -> None:
    """A stack of three bricks crossed at 90° dropped on a mesh plate, split over two MPI processes
    along x (the stack straddles the split): each comes to rest on the one below, its centre 8 mm
    above it (less the overlaps, microns), and nothing is lost."""
    quarter_turn = [0.7071067811865476, 0.0, 0.0, 0.7071067811865476]
    bricks = [{"shape": "brick", "material": "brick", "position": [0.002, 0.0, 0.0045 + 0.0085 * k],
               **({"orientation": quarter_turn} if k % 2 else {})} for k in range(3)]
    law = {"law": "bilinear", "en2": 0.13, "mu": 0.86, "kn": 1e5, "kt_over_kn": 0.27}
    case = parse_case({
        "name": "rounded_stack", "engine": "liggghts", "time": {"duration": 0.3, "output_interval": 0.01},
        "materials": [{"name": "brick", "density": 1700.0}, {"name": "plate", "density": 1700.0}],
        "contacts": [{"materials": ["brick", "brick"], **law}, {"materials": ["brick", "plate"], **law}],
        "shapes": [ROUNDED_BOX], "bodies": {"clumps": bricks},
        "walls": [{"type": "rectangle", "name": "plate", "material": "plate", "origin": [-0.1, -0.1, 0.0],
                   "edge1": [0.2, 0.0, 0.0], "edge2": [0.0, 0.2, 0.0]}],
        "domain": {"lower": [-0.1, -0.1, -0.05], "upper": [0.1, 0.1, 0.1]}})
    run_case(case, tmp_path, tmp_path / RELEASE_DIR, options=RunOptions(mpi_processes=2, processor_grid="2 1 1"))
    trajectory = read_results(tmp_path / RELEASE_DIR / "results.h5")
    final = trajectory.position[-1]
    assert final[:, 2] == pytest.approx([0.004, 0.012, 0.020], abs=2e-5)
    assert np.linalg.norm(trajectory.velocity[-1], axis=1).max() < 1e-3
