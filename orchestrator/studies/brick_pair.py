"""Two bricks, one resting flat on the other (glued), gravity tilted until the upper one slides.

The 2012 study's brick/brick constants of Table 1 (μ = 0.86, k_n 1e5 N/m, e_n² 0.13, k_t/k_n 0.27):
the study's own code starts sliding at atan 0.86 = 40.6955° in every placement and then slides at
g (sin θ − μ cos θ) (reference.toml [brick_pair.richefeu_code]). Placements: `aligned` (sliding
along the length), `aligned_y` (along the width), `offset_x` (upper brick 3.9 mm along x), `yaw_90deg`
and `yaw_30deg` (upper brick turned about z). The upper brick starts 1 µm above the lower one.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from orchestrator.case import Case, parse_case
from orchestrator.results import RELEASE_DIR, RESULTS, Trajectory, read_results
from orchestrator.runner import run_case
from orchestrator.studies.reference import load_reference

G = 9.81
PLACEMENTS = ("aligned", "aligned_y", "offset_x_3.9mm", "yaw_90deg", "yaw_30deg")
CONSTANTS = {"law": "bilinear", "en2": 0.13, "mu": 0.86, "kn": 1e5, "kt_over_kn": 0.27}
ACCELERATION_WINDOW = (0.01, 0.05)  # s: steady sliding at 47°, before the upper brick tips off the lower one's edge


def reference() -> dict[str, Any]:
    """[brick_pair.richefeu_code] of reference.toml: placements, onsets, contacts at rest, the slide
    after 0.4 s against the tilt (slide_mm, one row per placement) and the sliding accelerations."""
    return load_reference()["brick_pair"]["richefeu_code"]


def pair_case(engine: str, shape: dict[str, Any], placement: str, angle_deg: float, duration: float = 0.4) -> Case:
    """The case: gravity g (sin θ, 0, −cos θ), along y for `aligned_y`; frames every 2 ms."""
    if placement not in PLACEMENTS:
        raise ValueError(f"placement: unknown {placement!r}; allowed: {', '.join(PLACEMENTS)}")
    theta = math.radians(angle_deg)
    upper: dict[str, Any] = {"position": [0.0039 if placement == "offset_x_3.9mm" else 0.0, 0.0, 0.008 + 1e-6]}
    if placement.startswith("yaw_"):
        half = math.radians(float(placement[4:-3])) / 2.0
        upper["orientation"] = [math.cos(half), 0.0, 0.0, math.sin(half)]
    slope = G * math.sin(theta)
    gravity = [0.0, slope, -G * math.cos(theta)] if placement == "aligned_y" else [slope, 0.0, -G * math.cos(theta)]
    return parse_case({
        "name": f"brick_pair_{placement.replace('.', '_')}", "engine": engine,
        "time": {"duration": duration, "output_interval": 0.002}, "gravity": gravity,
        "materials": [{"name": "brick", "density": 1700.0}],
        "contacts": [{"materials": ["brick", "brick"], **CONSTANTS}],
        "shapes": [shape],
        "bodies": {"clumps": [{"shape": shape["name"], "material": "brick", "position": [0.0, 0.0, 0.0], "fixed": True},
                              {"shape": shape["name"], "material": "brick", **upper}]},
        "domain": {"lower": [-2.0, -2.0, -2.0], "upper": [2.0, 2.0, 0.2]},
    })


def run_pair(engine: str, shape: dict[str, Any], placement: str, angle_deg: float, directory: Path) -> dict[str, float]:
    """Run one tilt: slide (m) of the upper brick after the run along the slope, its sliding
    acceleration (m/s², sliding_acceleration) and how far the glued one moved (m)."""
    case = pair_case(engine, shape, placement, angle_deg)
    run_case(case, directory, directory / RELEASE_DIR)
    trajectory = read_results(directory / RELEASE_DIR / RESULTS)
    return {"slide": slide(trajectory, placement), "acceleration": sliding_acceleration(trajectory, placement),
            "glued_moved": float(np.abs(trajectory.position[:, 0] - trajectory.position[0, 0]).max())}


def _along(trajectory: Trajectory, placement: str) -> np.ndarray:
    """(F,) m: the upper brick's travel along the slope."""
    axis = 1 if placement == "aligned_y" else 0
    return trajectory.position[:, 1, axis] - trajectory.position[0, 1, axis]


def slide(trajectory: Trajectory, placement: str) -> float:
    """m: the upper brick's travel along the slope at the end of the run."""
    return float(_along(trajectory, placement)[-1])


def sliding_acceleration(trajectory: Trajectory, placement: str = "aligned") -> float:
    """m/s²: twice the leading coefficient of a parabola fitted to the travel over ACCELERATION_WINDOW."""
    window = (trajectory.time >= ACCELERATION_WINDOW[0]) & (trajectory.time <= ACCELERATION_WINDOW[1])
    return float(2.0 * np.polyfit(trajectory.time[window], _along(trajectory, placement)[window], 2)[0])


def expected_acceleration(angle_deg: float, mu: float = CONSTANTS["mu"]) -> float:
    """g (sin θ − μ cos θ), m/s²."""
    theta = math.radians(angle_deg)
    return G * (math.sin(theta) - mu * math.cos(theta))
