"""Shared builders for small, fast cases and a guard that no engine starts where none may."""

from __future__ import annotations

import math
import shutil
import subprocess
from typing import Any

import pytest

from orchestrator.case import Case, parse_case

requires_liggghts = pytest.mark.skipif(shutil.which("liggghts") is None, reason="LIGGGHTS not installed (run scripts/setup.sh)")
requires_yade = pytest.mark.skipif(shutil.which("yade") is None, reason="YADE not installed (run scripts/setup.sh)")


def engine_params() -> list[Any]:
    """Parametrise a test over both engines, each marked and skipped when absent."""
    return [
        pytest.param("liggghts", marks=[pytest.mark.engine, requires_liggghts]),
        pytest.param("yade", marks=[pytest.mark.engine, requires_yade]),
    ]


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


def slope_vectors(angle_deg: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Unit vectors down the slope and normal to it, for a slope descending towards +x."""
    a = math.radians(angle_deg)
    return (math.cos(a), 0.0, -math.sin(a)), (math.sin(a), 0.0, math.cos(a))


def sliding_case(engine: str, angle_deg: float = 30.0, mu: float = 0.2, duration: float = 0.25, law: str = "linear") -> Case:
    """A sphere that cannot rotate, resting on an inclined rectangle: it slides like a block."""
    down, normal = slope_vectors(angle_deg)
    radius = 0.005
    start = tuple(0.05 * d + radius * n for d, n in zip(down, normal))
    contact = {"law": law, "en2": 0.5, "mu": mu, "kn": 1e5, "kt_over_kn": 0.4}
    return parse_case(
        {
            "name": "slide",
            "engine": engine,
            "time": {"duration": duration, "output_interval": 0.01},
            "materials": [{"name": "ball", "density": 2500.0}, {"name": "board", "density": 1000.0}],
            "contacts": [{"materials": ["ball", "ball"], **contact}, {"materials": ["ball", "board"], **contact}],
            "bodies": {"spheres": [{"material": "ball", "radius": radius, "position": start, "fixed_rotation": True}]},
            "walls": [
                {
                    "type": "rectangle",
                    "name": "slope",
                    "material": "board",
                    "origin": (0.0, -0.1, 0.0),
                    "edge1": tuple(1.0 * d for d in down),
                    "edge2": (0.0, 0.2, 0.0),
                }
            ],
        }
    )


@pytest.fixture
def no_engine_process(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if anything tries to start a process."""

    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError(f"an engine process was started: {args[0] if args else kwargs}")

    monkeypatch.setattr(subprocess, "Popen", refuse)
