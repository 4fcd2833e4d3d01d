"""`time.stop_at_rest`: a run ends once its bodies are at rest instead of simulating a fixed duration.

The criterion (case.RestStop): the RMS speed sqrt(Σ m v² / M) of the moving bodies below `speed`
(or, with `stray_fraction` f, the bodies faster than `speed` weighing at most f M), checked every
`check_interval` from `after` on. Each engine evaluates it itself (LIGGGHTS in the
deck, YADE in its recorder, cocd in its loop); these tests check, from the recorded frames, that the
run stopped at the first check that met it and not before, and that the last frame is that state.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from orchestrator.case import Case, CaseError, parse_case
from orchestrator.results import Trajectory, read_results
from orchestrator.results import RESULTS
from orchestrator.runner import run_case

from conftest import engine_params, pile_case

THRESHOLD = 0.01  # m/s
CHECK = 0.1  # s, five output intervals of the pile case


def with_rest_stop(case: Case, **rest: float) -> Case:
    data = case.model_dump(mode="json")
    data["time"]["stop_at_rest"] = rest
    return parse_case(data)


def rms_speed(trajectory: Trajectory, moving: np.ndarray) -> np.ndarray:
    """Per frame, sqrt(Σ m v² / Σ m) over the moving bodies, from the recorded velocities."""
    mass = trajectory.mass[moving]
    squared = np.sum(trajectory.velocity[:, moving] ** 2, axis=2)
    return np.sqrt(squared @ mass / mass.sum())


@pytest.mark.parametrize("engine", engine_params())
def test_a_settling_pile_stops_at_the_first_check_below_the_threshold(engine: str, tmp_path: Path) -> None:
    case = with_rest_stop(pile_case(engine, count=20, duration=3.0), speed=THRESHOLD, after=0.1, check_interval=CHECK)
    run_case(case, tmp_path, tmp_path / "run")
    trajectory = read_results(tmp_path / "run" / RESULTS)
    stopped = trajectory.attrs["stopped_at_rest"]
    assert stopped < 2.0, "20 bricks dropped by a few centimetres settle well within 2 s"
    assert trajectory.time[-1] == pytest.approx(stopped, abs=1e-9), "the last frame is the state found at rest"
    speeds = rms_speed(trajectory, np.ones(trajectory.n_bodies, bool))
    assert speeds[-1] < THRESHOLD
    assert trajectory.attrs["rest_speed"] == pytest.approx(speeds[-1], rel=1e-6), "the engine's figure is the recorded state's"
    # Checks fall on every 5th frame (0.1 s of 0.02 s frames) from frame 5 (0.1 s) on: the stop is one
    # of them, and every check before it saw a moving pile.
    last = trajectory.n_frames - 1
    assert last % 5 == 0 and last >= 5
    earlier_checks = list(range(5, last, 5))
    assert earlier_checks, "the pile was still moving at the first check"
    assert np.all(speeds[earlier_checks] >= THRESHOLD)


def resting_spheres_case(engine: str) -> Case:
    """Nine spheres lying on a floor (a hair above it): at rest from the start."""
    spheres = [{"material": "glass", "radius": 0.005, "position": [0.012 * i, 0.0, 0.005]} for i in range(9)]
    return parse_case(
        {
            "name": "resting",
            "engine": engine,
            "time": {"duration": 1.0, "output_interval": 0.01, "stop_at_rest": {"speed": 0.001, "after": 0.25, "check_interval": 0.05}},
            "materials": [{"name": "glass", "density": 2500.0}, {"name": "board", "density": 2500.0}],
            "contacts": [
                {"materials": ["glass", "glass"], "en2": 0.25, "mu": 0.5, "kn": 1e4, "kt_over_kn": 0.4},
                {"materials": ["glass", "board"], "en2": 0.25, "mu": 0.5, "kn": 1e4, "kt_over_kn": 0.4},
            ],
            "bodies": {"spheres": spheres},
            "walls": [{"type": "rectangle", "name": "floor", "material": "board", "origin": [-0.1, -0.1, 0.0], "edge1": [0.3, 0, 0], "edge2": [0, 0.2, 0]}],
        }
    )


@pytest.mark.parametrize("engine", engine_params())
def test_no_stop_before_after(engine: str, tmp_path: Path) -> None:
    """A pile at rest from t = 0 runs until `after` (rounded to whole output intervals), not less."""
    run_case(resting_spheres_case(engine), tmp_path, tmp_path / "run")
    trajectory = read_results(tmp_path / "run" / RESULTS)
    assert trajectory.attrs["stopped_at_rest"] == pytest.approx(0.25, abs=1e-3)  # steps round the 0.01 s interval
    assert trajectory.n_frames == 26


@pytest.mark.engine
def test_without_the_setting_the_whole_duration_runs(tmp_path: Path) -> None:
    case = resting_spheres_case("cocd")
    data = case.model_dump(mode="json")
    data["time"].update(stop_at_rest=None, duration=0.05, step=1e-3)
    run_case(parse_case(data), tmp_path, tmp_path / "run")
    trajectory = read_results(tmp_path / "run" / RESULTS)
    assert "stopped_at_rest" not in trajectory.attrs
    assert trajectory.time[-1] == pytest.approx(0.05)


@pytest.mark.engine
def test_cocd_stops_at_rest_too(tmp_path: Path) -> None:
    data = resting_spheres_case("cocd").model_dump(mode="json")
    data["time"]["step"] = 1e-3
    run_case(parse_case(data), tmp_path, tmp_path / "run")
    trajectory = read_results(tmp_path / "run" / RESULTS)
    assert trajectory.attrs["stopped_at_rest"] == pytest.approx(0.25, abs=1e-3)


def stray_ball_case(engine: str, stray_fraction: float | None) -> Case:
    """The resting spheres, plus a small ball launched at 0.5 m/s along the floor beside them.

    It slides, then rolls at 5/7 of that forever (these laws have no rolling resistance). It weighs
    2.3 % of the moving mass (radius 3 mm against nine of 5 mm): the RMS speed stays near
    sqrt(0.023) × 0.36 = 0.054 m/s, far above the 0.001 m/s threshold.
    """
    data = resting_spheres_case(engine).model_dump(mode="json")
    data["bodies"]["spheres"].append({"material": "glass", "radius": 0.003, "position": [-0.05, 0.05, 0.003], "velocity": [0.5, 0.0, 0.0]})
    data["time"].update(duration=0.5)
    data["time"]["stop_at_rest"]["stray_fraction"] = stray_fraction
    if engine == "cocd":
        data["time"]["step"] = 1e-3
    return parse_case(data)


@pytest.mark.parametrize("engine", [*engine_params(), pytest.param("cocd", marks=pytest.mark.engine)])
def test_a_stray_body_holds_the_rms_criterion_but_not_the_stray_fraction(engine: str, tmp_path: Path) -> None:
    """With stray_fraction 5 %, the rolling ball (2.3 %) is left out and the run stops at `after`;
    without it, the ball's RMS share keeps the run going for the whole duration."""
    run_case(stray_ball_case(engine, 0.05), tmp_path, tmp_path / "tolerant")
    stopped = read_results(tmp_path / "tolerant" / RESULTS)
    assert stopped.attrs["stopped_at_rest"] == pytest.approx(0.25, abs=1e-3)
    ball = stopped.n_bodies - 1
    assert np.linalg.norm(stopped.velocity[-1, ball]) > 0.3, "the ball still rolls at the stop"
    assert stopped.attrs["rest_speed"] > 0.02, "the stop reports the RMS speed, the ball's share included"
    run_case(stray_ball_case(engine, None), tmp_path, tmp_path / "strict")
    ran = read_results(tmp_path / "strict" / RESULTS)
    assert "stopped_at_rest" not in ran.attrs
    assert ran.time[-1] == pytest.approx(0.5, abs=1e-3)


@pytest.mark.parametrize("engine", [*engine_params(), pytest.param("cocd", marks=pytest.mark.engine)])
def test_glued_spheres_are_not_in_the_moving_mass(engine: str, tmp_path: Path) -> None:
    """A glued sphere of radius 1 cm (8 × a 5 mm sphere) next to the rolling ball, with stray_fraction
    1.5 %: the ball weighs 2.3 % of the moving mass, so the run must not stop. Counting the glued
    sphere in the moving mass would make it 1.25 % and stop the run at `after`."""
    data = stray_ball_case(engine, 0.015).model_dump(mode="json")
    data["bodies"]["spheres"].append({"material": "glass", "radius": 0.01, "position": [0.15, -0.05, 0.01], "fixed": True})
    run_case(parse_case(data), tmp_path, tmp_path / "run")
    ran = read_results(tmp_path / "run" / RESULTS)
    assert "stopped_at_rest" not in ran.attrs
    assert ran.time[-1] == pytest.approx(0.5, abs=1e-3)


@pytest.mark.parametrize(
    ("field", "value", "allowed"),
    [
        ("speed", 0.0, "greater than 0"),
        ("speed", 11.0, "less than or equal to 10"),
        ("after", -1.0, "greater than or equal to 0"),
        ("check_interval", 0.0, "greater than 0"),
        ("stray_fraction", 0.5, "less than or equal to 0.1"),
        ("stray_fraction", -0.01, "greater than or equal to 0"),
    ],
)
def test_bad_settings_name_the_field(field: str, value: float, allowed: str) -> None:
    data = resting_spheres_case("liggghts").model_dump(mode="json")
    data["time"]["stop_at_rest"][field] = value
    with pytest.raises(CaseError) as error:
        parse_case(data)
    assert f"time.stop_at_rest.{field}" in str(error.value)
    assert allowed in str(error.value)
