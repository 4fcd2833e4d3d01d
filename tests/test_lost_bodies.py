"""Bodies lost from a run, counted one way on every engine (post.lost): three spheres shot out of
the domain were reported as 3 spheres at LIGGGHTS' last step, 1 body on YADE and 2 on cocd."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from orchestrator.case import parse_case
from orchestrator.engines import EngineError
from orchestrator.post.deposit import deposit_metrics
from orchestrator.post.lost import NoBodyLeft, lost_bodies
from orchestrator.results import Trajectory, read_results, write_results
from orchestrator.results import RESULTS
from orchestrator.runner import run_case

from conftest import assert_one_line_error, run_cli

HALF_WIDTH, INTERVAL = 0.05, 0.005
SPEEDS = (1.0, 2.0, 3.0)  # m/s along x from the centre: they leave at 0.05, 0.025 and 0.0167 s


def three_leaving(engine: str) -> dict:
    ball = {"material": "glass", "radius": 0.004}
    return {"name": "leave", "engine": engine, "time": {"step": 1.0e-5, "duration": 0.08, "output_interval": INTERVAL},
            "gravity": [0.0, 0.0, 0.0], "materials": [{"name": "glass", "density": 2500.0}],
            "contacts": [{"materials": ["glass", "glass"], "en2": 0.5, "mu": 0.5, "kn": 1.0e5, "kt_over_kn": 0.4}],
            "bodies": {"spheres": [{**ball, "position": [0.0, y, 0.0], "velocity": [speed, 0.0, 0.0]}
                                   for y, speed in zip((-0.02, 0.0, 0.02), SPEEDS)]},
            "domain": {"lower": [-HALF_WIDTH] * 3, "upper": [HALF_WIDTH] * 3}}


@pytest.mark.engine
@pytest.mark.parametrize("engine", ["liggghts", "yade", "cocd"])
def test_three_spheres_leaving_are_counted_alike_with_their_times(engine: str, tmp_path: Path) -> None:
    with pytest.raises(EngineError) as caught:
        run_case(parse_case(three_leaving(engine)), tmp_path, tmp_path / "run")
    message = caught.value.summary
    assert caught.value.tail and caught.value.deck is not None, "an engine failure keeps its deck and log tail"
    assert message.startswith("3 bodies left the simulation domain (bodies 2 at t = "), message
    left = {int(body): float(t) for body, t in re.findall(r"(\d) at t = ([0-9.e-]+) s", message)}
    assert sorted(left) == [0, 1, 2], message
    for body, speed in enumerate(SPEEDS):  # the first frame found outside: within one output interval after the crossing
        crossing = HALF_WIDTH / speed
        assert crossing <= left[body] + 1e-9 <= crossing + INTERVAL + 1e-6, (body, left[body], crossing)


@pytest.mark.engine
@pytest.mark.parametrize("engine", ["liggghts", "yade", "cocd"])
def test_with_lost_bodies_drop_the_run_completes_without_them(engine: str, tmp_path: Path) -> None:
    """`lost_bodies: drop` (bricks falling off a board's edge): the run completes, its record lists the
    three bodies with the times the error gives, their states are NaN from those frames on every engine,
    and a fourth sphere at rest is untouched."""
    data = three_leaving(engine)
    data["bodies"]["spheres"].append({"material": "glass", "radius": 0.004, "position": [-0.03, 0.03, 0.0]})
    record = run_case(parse_case({**data, "lost_bodies": "drop"}), tmp_path, tmp_path / "run")
    assert record["status"] == "completed"
    left = {entry["body"]: entry["time_s"] for entry in record["lost_bodies"]}
    assert sorted(left) == [0, 1, 2], record["lost_bodies"]
    assert any(w.startswith("3 bodies left the simulation domain") and "dropped from then on" in w for w in record["warnings"])
    result = read_results(tmp_path / "run" / RESULTS)
    for body, speed in enumerate(SPEEDS):
        crossing = HALF_WIDTH / speed
        assert crossing <= left[body] + 1e-9 <= crossing + INTERVAL + 1e-6, (body, left[body], crossing)
        gone = result.time >= left[body] - 1e-12
        assert np.isnan(result.position[gone, body]).all() and np.isnan(result.velocity[gone, body]).all()
        assert np.isfinite(result.position[~gone, body]).all()
    assert np.allclose(result.position[:, 3], [-0.03, 0.03, 0.0], atol=1e-12), "the sphere at rest stays"


def trajectory(position: np.ndarray) -> Trajectory:
    frames, bodies = position.shape[:2]
    return Trajectory(time=np.arange(frames) * 0.1, ids=np.arange(bodies), material=np.array(["m"] * bodies), mass=np.ones(bodies),
                      radius=np.full(bodies, 0.01), inertia=np.full((bodies, 3), 1e-5), position=position,
                      velocity=np.zeros_like(position), angular_velocity=np.zeros_like(position),
                      orientation=np.full((frames, bodies, 4), np.nan))


def test_one_lost_body_is_singular_and_nan_and_outside_count_alike() -> None:
    position = np.zeros((4, 3, 3))
    position[2:, 0] = np.nan  # dropped by the engine at frame 2
    position[1:, 2, 0] = 5.0  # carried on outside the domain from frame 1
    lost = lost_bodies(trajectory(position), (-1.0, -1.0, -1.0), (1.0, 1.0, 1.0))
    assert list(lost.bodies) == [2, 0] and np.allclose(lost.times, [0.1, 0.2])
    assert lost.message().startswith("2 bodies left the simulation domain (bodies 2 at t = 0.1 s, 0 at t = 0.2 s)")
    alone = lost_bodies(trajectory(position[:, :1]))
    assert alone.message().startswith("1 body left the simulation domain (body 0 at t = 0.2 s)")


def test_a_deposit_where_every_body_was_lost_says_so() -> None:
    final = np.full((3, 3), np.nan)
    with pytest.raises(NoBodyLeft, match="deposit: all 3 bodies were lost by the last frame"):
        deposit_metrics(np.zeros((3, 3)), final, np.ones(3), np.full(3, 0.01))


def test_post_on_a_result_that_lost_every_body_is_an_engine_failure(tmp_path: Path) -> None:
    """Exit 3, not 5: the file is intact (not damaged) and the case was valid (not 2); the run's outcome
    is that the engine kept no body, which `demorch run` reports as an engine failure too."""
    position = np.zeros((3, 2, 3))
    position[1:] = np.nan
    write_results(tmp_path / "results.h5", trajectory(position))
    assert_one_line_error(*run_cli(["post", str(tmp_path)]), expected_code=3, field="all 2 bodies were lost by the last frame")
    assert_one_line_error(*run_cli(["post", str(tmp_path), "--json"]), expected_code=3, field="no metric can be measured")


@pytest.mark.engine
def test_a_clump_leaving_is_one_body_on_liggghts(tmp_path: Path) -> None:
    """LIGGGHTS drops a clump's spheres one by one as they cross the box: the clump is lost from the
    first frame that misses one (it was reported as so many spheres, at the last step)."""
    data = three_leaving("liggghts")
    data["shapes"] = [{"name": "brick", "length": 0.031, "width": 0.015, "thickness": 0.008}]
    data["bodies"] = {"clumps": [{"shape": "brick", "material": "glass", "position": [0.0, 0.0, 0.0], "velocity": [2.0, 0.0, 0.0]}]}
    with pytest.raises(EngineError) as caught:
        run_case(parse_case(data), tmp_path, tmp_path / "run")
    left = float(re.search(r"^1 body left the simulation domain \(body 0 at t = ([0-9.e-]+) s\)", caught.value.summary).group(1))
    first_sphere_out = (HALF_WIDTH - 0.031 / 2 + 0.004) / 2.0  # the leading spheres' centres reach the box a little before the clump's
    assert first_sphere_out - 1e-9 <= left <= HALF_WIDTH / 2.0 + INTERVAL, (left, caught.value.summary)
