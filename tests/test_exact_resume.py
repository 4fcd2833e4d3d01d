"""A run continued from a checkpoint is the uninterrupted run to the bit, with bodies in contact at the
checkpoint: spheres pressed on spheres, bricks resting on bricks; and after a chain of SIGKILLs."""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from orchestrator.case import Case, parse_case
from orchestrator.engines import RunOptions, checkpoint, get_adapter
from orchestrator.plan import Resume, make_plan
from orchestrator.results import read_results

from conftest import pile_case, requires_liggghts, requires_yade

REPO = Path(__file__).resolve().parent.parent
ENGINES = [pytest.param("liggghts", marks=[pytest.mark.engine, requires_liggghts]),
           pytest.param("yade", marks=[pytest.mark.engine, requires_yade])]


def pressed_spheres(engine: str, law: str, duration: float = 0.3) -> Case:
    """27 spheres stacked 3 × 3 × 3 in a box that fits them, the top layer thrown down: every sphere
    rests on another at every checkpoint."""
    spheres = [{"material": "glass", "radius": 0.005, "position": [0.01 * i, 0.01 * j, 0.005 + 0.01 * k],
                "velocity": [0.0, 0.0, -0.05 if k == 2 else 0.0]}
               for i in (-1, 0, 1) for j in (-1, 0, 1) for k in range(3)]
    pair = {"law": law, "en2": 0.5, "mu": 0.3, "kt_over_kn": 0.5}
    side = 0.0151
    walls = [{"name": "floor", "type": "rectangle", "material": "steel", "origin": [-side, -side, 0.0], "edge1": [2 * side, 0, 0],
              "edge2": [0, 2 * side, 0]}]
    for name, origin, edge1 in (("west", [-side, -side, 0.0], [0, 2 * side, 0]), ("east", [side, -side, 0.0], [0, 2 * side, 0]),
                                ("south", [-side, -side, 0.0], [2 * side, 0, 0]), ("north", [-side, side, 0.0], [2 * side, 0, 0])):
        walls.append({"name": name, "type": "rectangle", "material": "steel", "origin": origin, "edge1": edge1, "edge2": [0, 0, 0.04]})
    return parse_case({
        "name": "pressed", "engine": engine, "time": {"duration": duration, "output_interval": 0.01},
        "materials": [{"name": "glass", "density": 2500.0}, {"name": "steel", "density": 7800.0}],
        "contacts": [{"materials": ["glass", "glass"], "kn": 1e4, **pair}, {"materials": ["glass", "steel"], "kn": 2e4, **pair}],
        "bodies": {"spheres": spheres}, "walls": walls,
        "domain": {"lower": [-0.03, -0.03, -0.01], "upper": [0.03, 0.03, 0.06]}})


def bricks_on_bricks(engine: str, kind: str = "clump") -> Case:
    """Twelve bricks dropped into a pile (bilinear law): brick–brick contacts at every late checkpoint."""
    return pile_case(engine, count=12, duration=0.4, kind=kind)


def _touching_pairs(trajectory: object, frame: int, case: Case) -> int:
    """Pairs of bodies closer than the sum of their bounding radii at a frame (spheres: touching)."""
    from scipy.spatial import cKDTree

    position = trajectory.position[frame]
    radius = trajectory.radius
    pairs = cKDTree(position).query_pairs(2 * float(radius.max()), output_type="ndarray")
    return int(np.sum(np.linalg.norm(position[pairs[:, 0]] - position[pairs[:, 1]], axis=1) < radius[pairs].sum(axis=1)))


ROUNDED_BOXES = pytest.param("liggghts", "rounded boxes", marks=[pytest.mark.engine, requires_liggghts], id="liggghts-rounded boxes")


@pytest.mark.parametrize(("engine", "body"), [pytest.param(*engine.values, body, marks=engine.marks, id=f"{engine.values[0]}-{body}")
                                             for engine in ENGINES for body in ("spheres, linear", "spheres, bilinear", "bricks")]
                         + [ROUNDED_BOXES])
def test_a_run_continued_from_a_checkpoint_with_bodies_in_contact_is_exact(engine: str, body: str, tmp_path: Path) -> None:
    """Rounded boxes: their sub-contacts' histories (fix roundedbox/history) go into the checkpoint."""
    if body == "bricks":
        case = bricks_on_bricks(engine)
    elif body == "rounded boxes":
        case = bricks_on_bricks(engine, "rounded_box")
    else:
        case = pressed_spheres(engine, body.split(", ")[1])
    adapter = get_adapter(engine, RunOptions(checkpoint_interval=0.1))
    plan = make_plan(case, tmp_path)
    adapter.write_input(plan, tmp_path)
    adapter.execute(plan, tmp_path)
    whole = adapter.read_output(plan, tmp_path)
    found = adapter.usable_checkpoints(plan, tmp_path)
    assert len(found) == 2
    for segment, (step, path) in enumerate(found, start=1):
        if body.startswith("spheres"):  # spheres touch spheres at the checkpoint (clumps: their bounding spheres overlap in the pile)
            frame = int(np.argmin(np.abs(whole.time - step * plan.schedule.dt)))
            assert _touching_pairs(whole, frame, case) >= 5
        resumed = plan.resumed(Resume(segment, step, path.name))
        adapter.write_input(resumed, tmp_path)
        adapter.execute(resumed, tmp_path)
        continued = adapter.read_output(resumed, tmp_path)
        assert np.array_equal(continued.position, whole.position, equal_nan=True), np.nanmax(np.abs(continued.position - whole.position))
        assert np.array_equal(continued.velocity, whole.velocity, equal_nan=True)
        assert np.array_equal(continued.angular_velocity, whole.angular_velocity, equal_nan=True)


def _demorch(arguments: list[str], cwd: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "orchestrator.cli", "--checkpoint-interval", "0.05", *arguments], cwd=cwd,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True,
                            env={**os.environ, "PYTHONPATH": str(REPO)})


def _newest_sealed(directory: Path, ext: str) -> int:
    found = checkpoint.usable(directory, ext) if directory.exists() else []
    return found[-1][0] if found else -1


def _kill_after_progress(process: subprocess.Popen, directory: Path, ext: str, after: int, chooser: random.Random) -> bool:
    """SIGKILL the orchestrator and its engine (one process group) a random instant after a checkpoint
    newer than `after` was sealed; False when the run ended first."""
    deadline = time.monotonic() + 300
    while _newest_sealed(directory, ext) <= after and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(chooser.uniform(0.0, 0.1))
    if process.poll() is not None:
        return False
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    return True


@pytest.mark.parametrize("engine", ENGINES)
def test_a_chain_of_ten_random_sigkills_ends_as_the_uninterrupted_run(engine: str, tmp_path: Path) -> None:
    """The pressed spheres (bilinear law) for 1.5 s, checkpoints every 0.05 s, killed with SIGKILL
    (orchestrator and engine) ten times, each a random instant after the run made a new checkpoint,
    then run to the end: results.h5 equals the uninterrupted run's to the bit."""
    case = pressed_spheres(engine, "bilinear", duration=1.5)
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(json.loads(case.model_dump_json())))
    whole = _demorch(["run", "case.yaml", "-o", "whole"], tmp_path)
    assert whole.wait(timeout=600) == 0, whole.stdout.read()[-2000:]
    ext, chooser, kills = get_adapter(engine).checkpoint_ext, random.Random(2026), 0
    while kills < 10:
        process = _demorch(["run", "case.yaml", "-o", "cut"], tmp_path)
        if not _kill_after_progress(process, tmp_path / "cut", ext, _newest_sealed(tmp_path / "cut", ext), chooser):
            break
        kills += 1
    final = _demorch(["run", "case.yaml", "-o", "cut"], tmp_path)
    output = final.communicate(timeout=600)[0]
    assert final.returncode == 0 or "already holds a completed run" in output, output[-2000:]
    assert kills == 10
    first, cut = read_results(tmp_path / "whole" / "results.h5"), read_results(tmp_path / "cut" / "results.h5")
    assert np.array_equal(first.time, cut.time)
    assert np.array_equal(first.position, cut.position) and np.array_equal(first.velocity, cut.velocity)
    record = json.loads((tmp_path / "cut" / "run.json").read_text())
    assert record["status"] == "completed" and len(record["segments"]) == 11  # every kill continued from a checkpoint
    assert not list((tmp_path / "cut").glob("checkpoint.*"))  # a completed run keeps no checkpoint
