"""Single-brick drops on a plate: the impacts the 2012 study identified its contact law on, against
the same drops run with the study's own code (reference.toml, [brick_drop.richefeu_code]).

Two drops, each with two sets of constants (A: brick/support of Table 1; B: brick/brick of Table 1
put on the brick/plate pair):
- flat: the brick's centre released at rest at z = 0.050 m, its 31 × 15 face down. Measured: the
  rebound ratios v_out / v_in of the first two impacts and the apex of the brick's lowest point
  after the first;
- tilted: released at rest at z = 0.100 m, turned by Ry(10°)·Rx(20°). Measured: the apex of the
  centre in the main rebound and its time, the second landing, the horizontal travel at 0.27 s
  (set A; the study's code is not step-robust after that), the time at rest, the travel,
  whether the brick lies flat and how far its corners rest from the study brick's (set B).

Events come from the pose alone: a body touches the plate while the lowest point of its spheres is
below the plate (their overlap), so every representation of the brick is measured alike. Frames
every 1e-4 s; a rebound's speeds are those of the free flights on either side of the contact,
extrapolated to its ends (gravity only), so the frame interval does not bias the ratio.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from orchestrator.shapes import BodyShape
from orchestrator.shapes.rigid import quaternion_matrices
from orchestrator.case import Case, parse_case
from orchestrator.results import RELEASE_DIR, RESULTS, Trajectory, read_results
from orchestrator.runner import run_case
from orchestrator.studies.avalanche.spec import BrickSpec
from orchestrator.studies.reference import load_reference

G = 9.81
FRAME = 1.0e-4  # s between frames
TILTED = (0.981060262190, 0.172987393925, 0.085831651177, -0.015134435901)  # Ry(10°)·Rx(20°), (w, x, y, z)
REST_SPEED = 5.0e-3  # m/s: at rest once the centre and every corner move slower than this, for good
FLAT_TILT_DEG = 5.0
MAIN_FLIGHT = 0.02  # s: the main rebound is the first flight at least this long (the impact's own bounces last < 5 ms)  # lying flat: the short axis within this of the vertical


def reference() -> dict[str, Any]:
    """[brick_drop.richefeu_code] of reference.toml: constants, the brick's volume and inertia, results."""
    return load_reference()["brick_drop"]["richefeu_code"]


def study_brick(layout: tuple[int, int, int] | None = None, rounding: float | None = None, name: str = "brick",
                kind: str = "clump", blockiness: tuple[float, float] | None = None) -> dict[str, Any]:
    """A shape entry for the study's brick (31 × 15 × 8 mm) as the brick studies build it by default
    (BrickSpec: its layout and rounding unless given), with the mass and inertia of the study's
    rounded brick (density 1700 kg/m³ × V, and I/m of the reference) whatever its representation
    (`kind`: any kind of orchestrator/shapes; `blockiness` for a superquadric). The entry is not
    validated here: the case made of it is."""
    ref = reference()
    given = {"layout": layout, "rounding": rounding, "blockiness": blockiness}
    # not validated here: the case made of the entry is (a test may build a brick out of range on purpose)
    brick = BrickSpec.model_construct(kind=kind, **{key: value for key, value in given.items() if value is not None})
    mass = brick.density * ref["volume"]
    return brick.entry(name, mass=mass, inertia=[mass * k for k in ref["inertia_over_mass"]])


def drop_case(engine: str, shape: dict[str, Any], constants: str, tilted: bool, duration: float | None = None) -> Case:
    """The drop of `shape` with constants "A" or "B" on a 0.4 × 0.4 m plate (top at z = 0)."""
    law = {"law": "bilinear", **reference()[f"set_{constants}"]}
    start = {"position": [0.0, 0.0, 0.100], "orientation": list(TILTED)} if tilted else {"position": [0.0, 0.0, 0.050]}
    return parse_case({
        "name": f"drop_{'tilted' if tilted else 'flat'}_{constants}", "engine": engine,
        "time": {"duration": duration or (0.60 if tilted else 0.36), "output_interval": FRAME},
        "materials": [{"name": "brick", "density": 1700.0}, {"name": "plate", "density": 1700.0}],
        "contacts": [{"materials": ["brick", "brick"], **law}, {"materials": ["brick", "plate"], **law}],
        "shapes": [shape],
        "bodies": {"clumps": [{"shape": shape["name"], "material": "brick", **start}]},
        "walls": [{"type": "rectangle", "name": "plate", "material": "plate", "origin": [-0.2, -0.2, 0.0],
                   "edge1": [0.4, 0.0, 0.0], "edge2": [0.0, 0.4, 0.0]}],
        "domain": {"lower": [-0.3, -0.3, -0.05], "upper": [0.3, 0.3, 0.3]},
    })


@dataclass(frozen=True)
class Drop:
    """The pose of one dropped brick over time. time (F,) s; centre (F, 3) m; velocity (F, 3) m/s;
    spin (F, 3) rad/s; rotation (F, 3, 3); lowest (F,) m: lowest point of the body's spheres;
    reach m: the body's bounding radius (how fast its farthest point moves for a given spin)."""

    time: np.ndarray
    centre: np.ndarray
    velocity: np.ndarray
    spin: np.ndarray
    rotation: np.ndarray
    lowest: np.ndarray
    reach: float

    @classmethod
    def from_trajectory(cls, trajectory: Trajectory, body: BodyShape) -> "Drop":
        rotation = quaternion_matrices(trajectory.orientation[:, 0])
        lowest = trajectory.position[:, 0, 2] + body.lowest_points(rotation)
        return cls(trajectory.time, trajectory.position[:, 0], trajectory.velocity[:, 0], trajectory.angular_velocity[:, 0], rotation, lowest,
                   body.bounding_radius)

    def contacts(self) -> list[tuple[int, int]]:
        """(first, last) frame of each contact episode with the plate (lowest point below its top)."""
        touching = np.concatenate([[False], self.lowest < 0.0, [False]])
        edges = np.flatnonzero(np.diff(touching.astype(int)))
        return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2])]

    def flight_speed(self, frame: int, at: float) -> float:
        """Vertical speed of the centre at time `at` on the free flight through `frame` (gravity only)."""
        return float(self.velocity[frame, 2] - G * (at - self.time[frame]))

    def rebound_ratios(self, count: int = 2) -> list[float]:
        """v_out / v_in of the first `count` impacts (vertical centre speeds at the contact's ends)."""
        ratios = []
        for first, last in self.contacts()[:count]:
            if first == 0 or last + 1 >= len(self.time):
                break
            v_in = self.flight_speed(first - 1, self._crossing(first - 1))
            v_out = self.flight_speed(last + 1, self._crossing(last))
            ratios.append(-v_out / v_in)
        return ratios

    def _crossing(self, frame: int) -> float:
        """Time the lowest point crosses the plate between `frame` and the next (linear)."""
        a, b = self.lowest[frame], self.lowest[frame + 1]
        return float(self.time[frame] + (self.time[frame + 1] - self.time[frame]) * a / (a - b))

    def rest_frame(self) -> int | None:
        """First frame from which the brick stays at rest (centre and every corner slower than REST_SPEED)."""
        fastest = np.linalg.norm(self.velocity, axis=1) + np.linalg.norm(self.spin, axis=1) * self.reach
        moving = np.flatnonzero(fastest >= REST_SPEED)
        if not len(moving):
            return 0
        return int(moving[-1]) + 1 if moving[-1] + 1 < len(self.time) else None

    def corner_error(self, frame: int, half_extents: np.ndarray, centre: np.ndarray, yaw_deg: float) -> float:
        """m; mean distance from each corner of the brick's box (half_extents (3,) m) at `frame` to the
        nearest corner of the same box lying flat at `centre` (3,) m turned by `yaw_deg` about z: how far
        the resting brick is from a reference pose (a box's corners are the same set under its half-turns)."""
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
        yaw = math.radians(yaw_deg)
        turn = np.array([[math.cos(yaw), -math.sin(yaw), 0.0], [math.sin(yaw), math.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
        here = self.centre[frame] + (signs * half_extents) @ self.rotation[frame].T
        there = np.asarray(centre) + (signs * half_extents) @ turn.T
        return float(np.linalg.norm(here[:, None] - there[None], axis=2).min(axis=1).mean())

    def lying_flat(self, frame: int) -> bool:
        return bool(abs(self.rotation[frame, 2, 2]) >= math.cos(math.radians(FLAT_TILT_DEG)))

    def travel(self, frame: int) -> float:
        return float(np.linalg.norm(self.centre[frame, :2] - self.centre[0, :2]))


def flat_metrics(drop: Drop) -> dict[str, Any]:
    ratios = drop.rebound_ratios(2)
    episodes = drop.contacts()
    apex = float(drop.lowest[episodes[0][1]:episodes[1][0]].max()) if len(episodes) > 1 else math.nan
    return {"rebound_ratios": ratios, "apex_lowest_point": apex}


def tilted_metrics(drop: Drop) -> dict[str, Any]:
    """First contact; the main rebound (the first flight of MAIN_FLIGHT or longer): the centre's apex
    and its time, and the landing that ends it; the horizontal travel at 0.27 s; rest time, travel, pose."""
    episodes = drop.contacts()
    metrics: dict[str, Any] = {"first_contact": float(drop.time[episodes[0][0]]) if episodes else math.nan}
    flights = [(episodes[k][1] + 1, episodes[k + 1][0]) for k in range(len(episodes) - 1)]
    main = [f for f in flights if drop.time[f[1]] - drop.time[f[0]] >= MAIN_FLIGHT]
    if main:
        start, end = main[0]
        top = start + int(np.argmax(drop.centre[start:end, 2]))
        metrics.update(centre_apex=float(drop.centre[top, 2]), apex_time=float(drop.time[top]), second_landing=float(drop.time[end]))
    at = int(np.searchsorted(drop.time, 0.27))
    metrics["travel_at_027"] = drop.travel(min(at, len(drop.time) - 1))
    rest = drop.rest_frame()
    metrics.update(rest_time=math.nan if rest is None else float(drop.time[rest]))
    if rest is not None:
        metrics.update(rest_travel=drop.travel(rest), lying_flat=drop.lying_flat(rest))
    return metrics


def measure_drop(engine: str, shape: dict[str, Any], constants: str, tilted: bool, directory: Path) -> tuple[dict[str, Any], Drop]:
    """Run one drop in `directory`: its metrics (flat_metrics or tilted_metrics) and its Drop."""
    case = drop_case(engine, shape, constants, tilted)
    run_case(case, directory, directory / RELEASE_DIR)
    brick = case.shape(shape["name"])
    drop = Drop.from_trajectory(read_results(directory / RELEASE_DIR / RESULTS), brick.body(case.material("brick").density))
    if not tilted:
        return flat_metrics(drop), drop
    metrics = tilted_metrics(drop)
    rest = drop.rest_frame()
    if constants == "B" and rest is not None:  # the study's brick at rest: its centre and yaw (reference.toml)
        at_rest = reference()["tilted"]
        half = 0.5 * np.array([brick.length, brick.width, brick.thickness])
        metrics["rest_corner_error"] = drop.corner_error(rest, half, np.array(at_rest["B_rest_centre"]), at_rest["B_rest_yaw_deg"])
    return metrics, drop


def first_rebound_ratio(trajectory: Trajectory, body: BodyShape) -> float:
    """v_out / v_in of the first impact of a drop's results (drop_case) of a brick of shape `body`
    (its lowest point tells the contacts); NaN when there was none."""
    ratios = Drop.from_trajectory(trajectory, body).rebound_ratios(1)
    return ratios[0] if ratios else math.nan


def run_drop(engine: str, shape: dict[str, Any], constants: str, tilted: bool, directory: Path) -> dict[str, Any]:
    """Run one drop in `directory` and return its metrics (flat_metrics or tilted_metrics)."""
    return measure_drop(engine, shape, constants, tilted, directory)[0]
