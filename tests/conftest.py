"""Shared builders for small, fast cases, and the guards of the test tiers.

Tiers: `pytest -m "not engine"` is the fast tier (no engine, no compiler); every test that starts
an engine, the cocd runner or the plugin compiler carries `@pytest.mark.engine`, which the guard
below enforces; `-m slow` selects the long studies left out of the default run.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
import time
import tracemalloc
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from orchestrator.shapes.clump import BrickClump
from orchestrator.shapes.rounded_box import brick_rounded_box
from orchestrator.case import Case, parse_case
from orchestrator.cli.main import main
from orchestrator.studies.avalanche.packing import loose_grid
from orchestrator.studies.avalanche.study import AvalancheStudy

# Hypothesis keeps its files out of the checkout (no test writes there).
os.environ.setdefault("HYPOTHESIS_STORAGE_DIRECTORY", tempfile.mkdtemp(prefix="demorch-hypothesis-"))

requires_liggghts = pytest.mark.skipif(shutil.which("liggghts") is None, reason="LIGGGHTS not installed (run scripts/setup.sh)")
requires_yade = pytest.mark.skipif(shutil.which("yade") is None, reason="YADE not installed (run scripts/setup.sh)")


def engine_params(slow: tuple[str, ...] = ()) -> list[Any]:
    """Parametrise a test over both engines, each marked and skipped when absent; the engines in
    `slow` run only with -m slow (the default run's budget: 20 minutes on 2 cores)."""
    requires = {"liggghts": requires_liggghts, "yade": requires_yade}
    return [pytest.param(name, marks=[pytest.mark.engine, mark] + ([pytest.mark.slow] if name in slow else []))
            for name, mark in requires.items()]


def free_fall_case(engine: str) -> Case:
    return parse_case(
        {
            "name": "free_fall",
            "engine": engine,
            "time": {"step": 1e-5, "duration": 0.1, "output_interval": 0.01},
            "materials": [{"name": "glass", "density": 2500.0}],
            "contacts": [{"materials": ["glass", "glass"], "en2": 0.5, "mu": 0.5, "kn": 1e5, "kt_over_kn": 0.4}],
            "bodies": {"spheres": [{"material": "glass", "radius": 0.005, "position": [0.0, 0.0, 1.0]}]},
        }
    )


BRICK = {"length": 0.031, "width": 0.015, "thickness": 0.008, "layout": [4, 2, 1]}


def pile_case(engine: str, count: int = 50, duration: float = 1.0, kind: str = "clump") -> Case:
    """`count` bricks (`kind`: the plain 4 × 2 × 1 clump, or the study's brick as a rounded box) rained
    from a loose grid onto a floor, Table 1's constants."""
    brick = (BrickClump(BRICK["length"], BRICK["width"], BRICK["thickness"], 1700.0, tuple(BRICK["layout"])) if kind == "clump"
             else brick_rounded_box(BRICK["length"], BRICK["width"], BRICK["thickness"], 1700.0, 0.001))
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
            "shapes": [{"name": "brick", **BRICK, **({"kind": kind, "rounding": 0.001} if kind != "clump" else {})}],
            "bodies": {
                "clumps": [
                    {"shape": "brick", "material": "brick", "position": p.tolist(), "orientation": q.tolist()}
                    for p, q in zip(positions, orientations)
                ]
            },
            "walls": [{"type": "rectangle", "name": "floor", "material": "board", "origin": [-0.3, -0.3, 0], "edge1": [0.6, 0, 0], "edge2": [0, 0.6, 0]}],
        }
    )


def tiny_study(engine: str) -> AvalancheStudy:
    """≈30 bricks in a 12 × 10 cm box launched from 25 cm: a real avalanche in well under a minute.

    The boards are 0.8 m wide: deposits of this study spread to |y| ≈ 0.24 m, and a brick that
    slides off a board edge leaves the simulation (a failed run).

    k_n = 2e4 N/m (the 2012 study found E2G flat between 1e4 and 1e6) makes the step 2.2 × longer.
    The packing's contacts are given explicitly, so releases with other contacts share its packing,
    and it packs once (`density_search.max_trials: 1`): the search has its own test.
    """
    contacts = {
        "brick_brick": {"en2": 0.13, "mu": 0.86, "kn": 2e4, "kt_over_kn": 0.27},
        "brick_board": {"en2": 0.53, "mu": 0.46, "kn": 2e4, "kt_over_kn": 0.42},
    }
    return AvalancheStudy.model_validate(
        {
            "name": "tiny",
            "engine": engine,
            "geometry": {"launch_height": 0.25, "board_length": 0.8, "board_width": 0.8, "box_depth": 0.12, "box_width": 0.1, "box_height": 0.08},
            "packing": {"volume": 1.9e-4, "settle_time": 0.4, "contacts": contacts, "density_search": {"max_trials": 1}},
            "contacts": contacts,
            "release": {"duration": 1.6, "output_interval": 0.02},
        }
    )


def column_study(name: str, column: tuple[float, float], channel_length: float, settle_time: float, duration: float,
                 **fields: Any) -> dict[str, Any]:
    """A 2D collapse study file on a flat channel: a column (length, height) in m, the channel
    `channel_length` long, rained for `settle_time` and released for `duration` (s), frames every
    0.01 s; `fields` add or replace top-level sections."""
    return {"name": name, "dimension": 2, "column": {"length": column[0], "height": column[1]},
            "channel": {"slope_deg": 0.0, "length": channel_length}, "preparation": {"settle_time": settle_time},
            "release": {"duration": duration, "output_interval": 0.01}, **fields}


@pytest.fixture
def no_engine_process(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if anything tries to start a process."""

    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError(f"an engine process was started: {args[0] if args else kwargs}")

    monkeypatch.setattr(subprocess, "Popen", refuse)


# Programs that only an engine-marked test may start: the engines, MPI, the plugin build, the cocd runner.
ENGINE_PROGRAMS = {"liggghts", "yade", "yade-double", "mpirun", "stdbuf", "bash", "g++", "c++"}
VERSION_QUERIES = {"-h", "--version"}


@pytest.fixture(autouse=True)
def engines_only_in_marked_tests(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> None:
    """A test without `@pytest.mark.engine` that starts an engine or a compiler fails, naming it."""
    if request.node.get_closest_marker("engine") is not None:
        return
    real = subprocess.Popen

    def guarded(args: Any, *rest: Any, **options: Any) -> Any:
        words = [str(w) for w in (args if isinstance(args, (list, tuple)) else str(args).split())]
        version_query = len(words) == 2 and words[1] in VERSION_QUERIES  # the run identity asks an engine its version: no simulation
        if words and not version_query and (Path(words[0]).name in ENGINE_PROGRAMS or "orchestrator.engines.cocd" in words):
            raise AssertionError(f"this test starts {Path(words[0]).name} without @pytest.mark.engine: {' '.join(words)[:200]}")
        return real(args, *rest, **options)

    monkeypatch.setattr(subprocess, "Popen", guarded)


# Hostile input through the CLI: shared by the hostile-input tests.
def case_data(**changes: Any) -> dict[str, Any]:
    data = json.loads(free_fall_case("liggghts").model_dump_json())
    for path, value in changes.items():
        node = data
        *parents, last = path.split("__")
        for part in parents:
            node = node[int(part)] if part.isdigit() else node[part]
        node[int(last) if last.isdigit() else last] = value
    return data


def run_cli(arguments: list[str]) -> tuple[int, str, float, int]:
    """(exit code, output, seconds, peak bytes of Python allocations)."""
    tracemalloc.start()
    started = time.perf_counter()
    result = CliRunner().invoke(main, arguments)
    seconds = time.perf_counter() - started
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return result.exit_code, result.output, seconds, peak


def assert_one_line_error(code: int, output: str, seconds: float, peak: int, expected_code: int, field: str) -> None:
    assert code == expected_code, output
    lines = [line for line in output.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), output
    assert field in lines[0], output
    assert "Traceback" not in output
    assert seconds < 5.0 and peak < 500 * 2**20, (seconds, peak)
