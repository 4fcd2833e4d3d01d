"""Engine parity: the same micro-case on every engine that supports it, against its analytic value.

Each micro-case is a tiny real run (well under a second of engine time) whose answer is known
without a simulation:
- restitution e² = (v_out / v_in)² of a body arriving at 0.5 m/s without gravity, for the bilinear
  law of Richefeu et al. (2012), whose e² is e_n² = k_n-/k_n+ at any speed and for any number of
  simultaneous contacts: a sphere on a fixed sphere, on a rectangle wall (centre, 0.2 mm inside an
  edge, on the diagonal where its two triangles meet), on an STL mesh (inside a triangle, on an
  edge shared by two, on a vertex shared by four); a brick clump landing flat on 4 and 8 of its
  spheres at once; the study's rounded brick landing on one corner (the normal speed of that point).
  Tolerance ±3 % (the law has no damping; its only error is the discrete overlap,
  about 100 steps per contact: measured within 0.3 % on LIGGGHTS);
- angular momentum about the centre of mass over 0.1 s of free flight with spin, for a sphere and a
  tilted brick clump: relative change within 0.1 %;
- Coulomb friction on a 1 m incline, a rotation-locked sphere (a block): at tan α = μ + 0.05 its
  acceleration is g (sin α − μ cos α) within 2 %; at tan α = μ − 0.02 it travels less than 1e-5 m
  in 0.3 s (elastic creep of the tangential spring: about 2e-7 m);
- a body leaving the simulation domain ends the run with the same message on every engine;
- brick on brick (the engine's preferred brick on a glued one, gravity tilted): at 40.2°, half a
  degree below the friction angle atan 0.86, the upper brick slides at most 1 mm in 0.4 s in each of
  the five placements of the 2012 study's own runs; at 47° it slides at g (sin θ − 0.86 cos θ)
  within 2 % (reference.toml [brick_pair.richefeu_code]);
- the same brick-on-brick cases for the rounded box (the study's brick as its code models it) on
  every engine that takes that kind, and its flat drop A: first rebound ratio within 0.5 % of the
  study's code's (reference.toml [brick_drop.richefeu_code.flat]).

KNOWN_GAPS holds the cases an engine is known to miss, with the value measured; the parity tests
expect them to fail (strictly: a fix shows as an unexpected pass) and `demorch parity` marks them.
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from orchestrator.bodies import BrickShape
from orchestrator.shapes.rigid import quaternion_matrices, quaternion_matrix
from orchestrator.case import Case, parse_case
from orchestrator.engines import EngineError
from orchestrator.capabilities import ENGINE_NAMES, ENGINES, engines_with
from orchestrator.results import RELEASE_DIR, RESULTS, Trajectory, read_results
from orchestrator.runner import run_case
from orchestrator.studies import brick_drop, brick_pair
from orchestrator.studies.avalanche.spec import BrickSpec

EN2, SPEED, RADIUS, MU = 0.53, 0.5, 0.005, 0.46
TILTED = (0.981060262190, 0.172987393925, 0.085831651177, -0.015134435901)  # Ry(10°)·Rx(20°), (w, x, y, z)
BRICK = BrickSpec(rounding=0.0).entry("brick")  # the study's brick, sharp (a box's mass and inertia at the material's density)
FLOOR = {"type": "rectangle", "name": "floor", "material": "board", "origin": [-0.1, -0.1, 0.0], "edge1": [0.2, 0.0, 0.0], "edge2": [0.0, 0.2, 0.0]}
# A square of four triangles around its centre: edges shared by two, the centre by all four.
FAN = [[[0.0, 0.0, 0.0], [-0.1, -0.1, 0.0], [0.1, -0.1, 0.0]], [[0.0, 0.0, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0]],
       [[0.0, 0.0, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]], [[0.0, 0.0, 0.0], [-0.1, 0.1, 0.0], [-0.1, -0.1, 0.0]]]


@dataclass(frozen=True)
class MicroCase:
    """One row of the matrix. build(engine, directory) → the case (files it needs are written in
    directory); measure(trajectory) → the value compared with `expected`, within `tolerance`
    (relative when `relative`, else absolute, in the unit of `quantity`). `ends_with`: the case
    must end the run with an engine error saying this (measured 1 when it does, 0 when not)."""

    name: str
    quantity: str
    expected: float
    tolerance: float
    relative: bool
    engines: tuple[str, ...]
    build: Callable[[str, Path], Case]
    measure: Callable[[Trajectory], float]
    ends_with: str | None = None

    def passes(self, measured: float) -> bool:
        bound = self.tolerance * (abs(self.expected) if self.relative else 1.0)
        return bool(np.isfinite(measured)) and abs(measured - self.expected) <= bound


@dataclass(frozen=True)
class Outcome:
    case: str
    engine: str
    measured: float
    passed: bool
    known_gap: str | None


# (case, engine): why the engine misses it and the value measured (from the engine registry).
KNOWN_GAPS: dict[tuple[str, str], str] = {(case, name): why for name, entry in ENGINES.items() for case, why in entry.parity_gaps}


def _drop(engine: str, bodies: dict, walls: list[dict], shapes: list[dict] | None = None) -> Case:
    law = {"law": "bilinear", "en2": EN2, "mu": 0.0, "kn": 1.0e5, "kt_over_kn": 0.4}
    return parse_case({
        "name": "parity", "engine": engine, "gravity": [0.0, 0.0, 0.0],
        "time": {"duration": 0.012, "output_interval": 0.001, "safety_factor": 0.01},
        "materials": [{"name": "ball", "density": 2500.0}, {"name": "board", "density": 2500.0}],
        "contacts": [{"materials": ["ball", "ball"], **law}, {"materials": ["ball", "board"], **law}],
        "shapes": shapes or [], "bodies": bodies, "walls": walls,
    })


def _ball(x: float, y: float, z: float = RADIUS + 1e-4) -> dict:
    return {"material": "ball", "radius": RADIUS, "position": [x, y, z], "velocity": [0.0, 0.0, -SPEED]}


def _on_rectangle(x: float, y: float) -> Callable[[str, Path], Case]:
    return lambda engine, directory: _drop(engine, {"spheres": [_ball(x, y)]}, [FLOOR])


def _on_fixed_sphere(engine: str, directory: Path) -> Case:
    anvil = {"material": "ball", "radius": RADIUS, "position": [0.0, 0.0, 0.0], "fixed": True}
    return _drop(engine, {"spheres": [_ball(0.0, 0.0, 2 * RADIUS + 1e-4), anvil]}, [])


def write_stl(path: Path, triangles: list[list[list[float]]]) -> None:
    lines = ["solid parity"]
    for a, b, c in triangles:
        lines += ["facet normal 0 0 1", " outer loop", *[f"  vertex {p[0]} {p[1]} {p[2]}" for p in (a, b, c)], " endloop", "endfacet"]
    path.write_text("\n".join(lines + ["endsolid parity"]) + "\n")


def _on_mesh(x: float, y: float) -> Callable[[str, Path], Case]:
    def build(engine: str, directory: Path) -> Case:
        write_stl(directory / "fan.stl", FAN)
        return _drop(engine, {"spheres": [_ball(x, y)]}, [{"type": "mesh", "name": "floor", "material": "board", "file": "fan.stl"}])
    return build


def _clump_flat(layout: list[int]) -> Callable[[str, Path], Case]:
    clump = {"shape": "brick", "material": "ball", "position": [0.0, 0.0, 0.0041], "velocity": [0.0, 0.0, -SPEED]}
    return lambda engine, directory: _drop(engine, {"clumps": [clump]}, [FLOOR], [{**BRICK, "layout": layout}])


ROUNDED = BrickSpec().entry("brick")  # the default brick of the brick studies (4 × 2 × 1 and 1 mm corner spheres)


def _corner_sphere() -> tuple[np.ndarray, float, float]:
    """(body-frame centre, radius, height of the clump's centre) of the rounded brick's lowest sphere
    when it is turned by TILTED with that sphere 0.1 mm above the floor."""
    clump = BrickShape(**ROUNDED).clump(2500.0)
    heights = (clump.centres @ quaternion_matrix(TILTED).T)[:, 2] - clump.radii
    lowest = int(np.argmin(heights))
    return clump.centres[lowest], float(clump.radii[lowest]), 1e-4 - float(heights[lowest])


def _clump_on_corner(engine: str, directory: Path) -> Case:
    clump = {"shape": "brick", "material": "ball", "position": [0.0, 0.0, _corner_sphere()[2]], "orientation": list(TILTED),
             "velocity": [0.0, 0.0, -SPEED]}
    case = _drop(engine, {"clumps": [clump]}, [FLOOR], [ROUNDED])
    return case.model_copy(update={"time": case.time.model_copy(update={"duration": 0.003, "output_interval": 1e-4})})


def corner_restitution(trajectory: Trajectory) -> float:
    """e² at the corner that lands: (normal speed of that point as it leaves / as it arrives)², the
    point's velocity being v + ω × R c, interpolated to the frame interval where its sphere leaves
    the floor (once free, the point's speed changes as the body turns). A single contact: the law's
    e_n² whatever the lever (mu = 0); the body turns a little during the contact (about 1 %)."""
    centre, radius, _ = _corner_sphere()
    rotations = quaternion_matrices(trajectory.orientation[:, 0])
    arms = rotations @ centre
    heights = trajectory.position[:, 0, 2] + arms[:, 2] - radius
    speeds = (trajectory.velocity[:, 0] + np.cross(trajectory.angular_velocity[:, 0], arms))[:, 2]
    touched = np.flatnonzero(heights < 0.0)
    after = touched[-1] + 1 if len(touched) else len(heights)
    if after >= len(heights):
        return math.nan
    w = heights[after] / (heights[after] - heights[after - 1])  # weight of the frame before, at height 0
    return float(((w * speeds[after - 1] + (1.0 - w) * speeds[after]) / speeds[0]) ** 2)


def restitution(trajectory: Trajectory) -> float:
    """e² of the first body: (last vertical speed / first)²; NaN if it has not left the wall."""
    velocity = trajectory.velocity[:, 0, 2]
    return float((velocity[-1] / velocity[0]) ** 2) if velocity[-1] > 0.0 else math.nan


def flight(engine: str, body: str, shape: dict | None = None) -> Case:
    """One body (a brick clump of `shape`, 4 × 2 × 1 by default, or a sphere) thrown with spin, 0.1 s of free fall."""
    state = {"position": [0.01, -0.02, 0.05], "velocity": [1.0, -2.0, 0.5], "angular_velocity": [20.0, 3.0, 1.0]}
    shape = shape or {**BRICK, "layout": [4, 2, 1]}
    bodies = ({"clumps": [{"shape": shape["name"], "material": "brick", "orientation": list(TILTED), **state}]} if body == "clump"
              else {"spheres": [{"material": "brick", "radius": 0.004, **state}]})
    return parse_case({
        "name": "flight", "engine": engine,
        "time": {"step": 1.0e-5, "duration": 0.1, "output_interval": 0.01},
        "materials": [{"name": "brick", "density": 1700.0}],
        "contacts": [{"materials": ["brick", "brick"], "law": "linear", "en2": 0.5, "mu": 0.5, "kn": 1.0e5, "kt_over_kn": 0.4}],
        "shapes": [shape] if body == "clump" else [],
        "bodies": bodies,
        "domain": {"lower": [-1.0, -1.0, -1.0], "upper": [1.0, 1.0, 1.0]},
    })


def angular_momentum(trajectory: Trajectory, frame: int, body: int = 0) -> np.ndarray:
    """(3,) L = R I Rᵀ ω about the centre of mass, kg m²/s (I: principal moments about the body axes)."""
    inertia = np.diag(trajectory.inertia[body])
    if not trajectory.attrs.get("orientation_tracked") or np.isnan(trajectory.orientation[frame, body]).any():
        return inertia @ trajectory.angular_velocity[frame, body]  # a sphere: isotropic
    rotation = quaternion_matrix(trajectory.orientation[frame, body])
    return rotation @ inertia @ rotation.T @ trajectory.angular_velocity[frame, body]


def spin_drift(trajectory: Trajectory) -> float:
    start, end = angular_momentum(trajectory, 0), angular_momentum(trajectory, -1)
    return float(np.linalg.norm(end - start) / np.linalg.norm(start))


def slope_vectors(angle_deg: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Unit vectors down the slope and normal to it, for a slope descending towards +x."""
    a = math.radians(angle_deg)
    return (math.cos(a), 0.0, -math.sin(a)), (math.sin(a), 0.0, math.cos(a))


def sliding_case(engine: str, angle_deg: float = 30.0, mu: float = 0.2, duration: float = 0.25, law: str = "linear") -> Case:
    """A sphere that cannot rotate, resting on an inclined rectangle: it slides like a block."""
    down, normal = slope_vectors(angle_deg)
    start = [0.05 * d + RADIUS * n for d, n in zip(down, normal)]
    contact = {"law": law, "en2": 0.5, "mu": mu, "kn": 1e5, "kt_over_kn": 0.4}
    return parse_case({
        "name": "slide", "engine": engine,
        "time": {"duration": duration, "output_interval": 0.01},
        "materials": [{"name": "ball", "density": 2500.0}, {"name": "board", "density": 1000.0}],
        "contacts": [{"materials": ["ball", "ball"], **contact}, {"materials": ["ball", "board"], **contact}],
        "bodies": {"spheres": [{"material": "ball", "radius": RADIUS, "position": start, "fixed_rotation": True}]},
        "walls": [{"type": "rectangle", "name": "slope", "material": "board", "origin": [0.0, -0.1, 0.0],
                   "edge1": list(down), "edge2": [0.0, 0.2, 0.0]}],
    })


def downslope_acceleration(trajectory: Trajectory, angle_deg: float, start: float = 0.05) -> float:
    """m/s²: the slope of the downslope speed of body 0 against time, fitted from `start` on."""
    down, _ = slope_vectors(angle_deg)
    window = trajectory.time >= start
    return float(np.polyfit(trajectory.time[window], trajectory.velocity[window, 0, :] @ np.asarray(down), 1)[0])


SLIP, STICK = math.degrees(math.atan(MU + 0.05)), math.degrees(math.atan(MU - 0.02))


def _slip_ratio(trajectory: Trajectory) -> float:
    coulomb = 9.81 * (math.sin(math.radians(SLIP)) - MU * math.cos(math.radians(SLIP)))
    return downslope_acceleration(trajectory, SLIP) / coulomb


def _stick_travel(trajectory: Trajectory) -> float:
    down, _ = slope_vectors(STICK)
    return float((trajectory.position[-1, 0] - trajectory.position[0, 0]) @ np.asarray(down))


def leaving_case(engine: str, directory: Path | None = None) -> Case:
    """A sphere thrown at 1 m/s from the centre of a 0.1 m domain, without gravity: it leaves at 0.05 s."""
    return parse_case({
        "name": "leave", "engine": engine, "gravity": [0.0, 0.0, 0.0],
        "time": {"step": 1.0e-5, "duration": 0.2, "output_interval": 0.01},
        "materials": [{"name": "glass", "density": 2500.0}],
        "contacts": [{"materials": ["glass", "glass"], "en2": 0.5, "mu": 0.5, "kn": 1.0e5, "kt_over_kn": 0.4}],
        "bodies": {"spheres": [{"material": "glass", "radius": RADIUS, "position": [0.0, 0.0, 0.0], "velocity": [1.0, 0.0, 0.0]}]},
        "domain": {"lower": [-0.05, -0.05, -0.05], "upper": [0.05, 0.05, 0.05]},
    })


LEAVING = "left the simulation domain"
EXPLICIT, CLUMPS, MESHES = engines_with(implicit=False), engines_with(clumps=True, implicit=False), engines_with(meshes=True, implicit=False)
MATRIX: tuple[MicroCase, ...] = (
    MicroCase("sphere on a fixed sphere", "e²", EN2, 0.03, True, EXPLICIT, _on_fixed_sphere, restitution),
    MicroCase("sphere on a rectangle, centre", "e²", EN2, 0.03, True, EXPLICIT, _on_rectangle(0.03, -0.02), restitution),
    MicroCase("sphere on a rectangle, 0.2 mm inside an edge", "e²", EN2, 0.03, True, EXPLICIT, _on_rectangle(0.0998, 0.01), restitution),
    MicroCase("sphere on a rectangle, diagonal", "e²", EN2, 0.03, True, EXPLICIT, _on_rectangle(0.02, 0.02), restitution),
    MicroCase("sphere on a mesh, inside a triangle", "e²", EN2, 0.03, True, MESHES, _on_mesh(0.05, -0.01), restitution),
    MicroCase("sphere on a mesh, shared edge", "e²", EN2, 0.03, True, MESHES, _on_mesh(0.03, 0.03), restitution),
    MicroCase("sphere on a mesh, shared vertex", "e²", EN2, 0.03, True, MESHES, _on_mesh(0.0, 0.0), restitution),
    MicroCase("clump flat on 4 spheres", "e²", EN2, 0.03, True, CLUMPS, _clump_flat([2, 2, 1]), restitution),
    MicroCase("clump flat on 8 spheres", "e²", EN2, 0.03, True, CLUMPS, _clump_flat([4, 2, 1]), restitution),
    MicroCase("rounded brick landing on a corner", "e² at the corner", EN2, 0.03, True, CLUMPS, _clump_on_corner, corner_restitution),
    MicroCase("sphere spinning in free flight", "|ΔL| / |L|", 0.0, 1e-3, False, ENGINE_NAMES,
              lambda engine, directory: flight(engine, "sphere"), spin_drift),
    MicroCase("clump spinning in free flight", "|ΔL| / |L|", 0.0, 1e-3, False, engines_with(clumps=True),
              lambda engine, directory: flight(engine, "clump"), spin_drift),
    MicroCase("block sliding, tan α = μ + 0.05", "a / g (sin α − μ cos α)", 1.0, 0.02, True, EXPLICIT,
              lambda engine, directory: sliding_case(engine, SLIP, MU, duration=0.3), _slip_ratio),
    MicroCase("block sticking, tan α = μ − 0.02", "travel (m)", 0.0, 1e-5, False, EXPLICIT,
              lambda engine, directory: sliding_case(engine, STICK, MU, duration=0.3), _stick_travel),
    MicroCase("sphere leaving the domain", f"run ends '{LEAVING}' (1: yes)", 1.0, 0.0, False, ENGINE_NAMES,
              leaving_case, lambda trajectory: 0.0, ends_with=LEAVING),
)
# Brick on brick (studies/brick_pair.py): the engine's preferred brick resting on a glued one,
# gravity tilted. The 2012 study's own code holds at 40.2° (slides from 40.70° in every placement)
# and then slides at g (sin θ − 0.86 cos θ) (reference.toml [brick_pair.richefeu_code]).
BRICK_PAIRS = tuple(
    MicroCase(f"brick on brick, {placement}, 40.2°", "slide in 0.4 s (m)", 0.0, 1e-3, False, CLUMPS,
              lambda engine, directory, p=placement: brick_pair.pair_case(engine, preferred_brick(engine), p, 40.2),
              lambda trajectory, p=placement: brick_pair.slide(trajectory, p))
    for placement in brick_pair.PLACEMENTS
) + (
    MicroCase("brick on brick, aligned, 47°", "a / g (sin θ − 0.86 cos θ)", 1.0, 0.02, True, CLUMPS,
              lambda engine, directory: brick_pair.pair_case(engine, preferred_brick(engine), "aligned", 47.0),
              lambda trajectory: brick_pair.sliding_acceleration(trajectory) / brick_pair.expected_acceleration(47.0)),
)
# The rounded box (the study's brick as its code models it) wherever an engine takes that kind: brick
# on brick as above where it is not already the engine's preferred brick (there the rows above are
# its), and the study's flat drop A (rebound ratio within 0.5 % of the study's code's,
# reference.toml [brick_drop.richefeu_code.flat]).
ROUNDED_BOXES = tuple(name for name in ENGINE_NAMES if "rounded_box" in ENGINES[name].capabilities.shape_kinds)
ROUNDED_BOXES_BESIDE = tuple(name for name in ROUNDED_BOXES if ENGINES[name].capabilities.preferred_brick != "rounded_box")
ROUNDED_BOX = brick_drop.study_brick(kind="rounded_box")
ROUNDED_BOX_CASES = tuple(
    MicroCase(f"rounded box on rounded box, {placement}, 40.2°", "slide in 0.4 s (m)", 0.0, 1e-3, False, ROUNDED_BOXES_BESIDE,
              lambda engine, directory, p=placement: brick_pair.pair_case(engine, ROUNDED_BOX, p, 40.2),
              lambda trajectory, p=placement: brick_pair.slide(trajectory, p))
    for placement in brick_pair.PLACEMENTS
) + (
    MicroCase("rounded box on rounded box, aligned, 47°", "a / g (sin θ − 0.86 cos θ)", 1.0, 0.02, True, ROUNDED_BOXES_BESIDE,
              lambda engine, directory: brick_pair.pair_case(engine, ROUNDED_BOX, "aligned", 47.0),
              lambda trajectory: brick_pair.sliding_acceleration(trajectory) / brick_pair.expected_acceleration(47.0)),
    MicroCase("rounded box, flat drop A, first rebound", "v_out / v_in ÷ the study's code's", 1.0, 0.005, True, ROUNDED_BOXES,
              lambda engine, directory: brick_drop.drop_case(engine, ROUNDED_BOX, "A", False),
              lambda trajectory: (brick_drop.first_rebound_ratio(trajectory, BrickShape(**ROUNDED_BOX).body(1700.0))
                                  / brick_drop.reference()["flat"]["rebound_ratio_A"][0])),
)
MATRIX = MATRIX + BRICK_PAIRS + tuple(case for case in ROUNDED_BOX_CASES if case.engines)
CASES = {case.name: case for case in MATRIX}


def preferred_brick(engine: str) -> dict:
    """The study's brick as the engine's preferred kind (capabilities.preferred_brick)."""
    return brick_drop.study_brick(kind=ENGINES[engine].capabilities.preferred_brick)


def run_micro(case: MicroCase, engine: str, directory: Path) -> float:
    """Run one micro-case on `engine` in `directory` and return the measured value. An engine failure
    raises EngineError, unless it is the one the case expects (`ends_with`)."""
    directory.mkdir(parents=True, exist_ok=True)
    try:
        run_case(case.build(engine, directory), directory, directory / RELEASE_DIR)
    except EngineError as error:
        if case.ends_with and case.ends_with in error.summary:
            return 1.0
        raise
    return case.measure(read_results(directory / RELEASE_DIR / RESULTS))


def run_matrix(engines: tuple[str, ...], directory: Path, on_outcome: Callable[[Outcome], None] | None = None) -> list[Outcome]:
    """Every micro-case on every engine of `engines` that supports it, in `directory`."""
    outcomes = []
    for index, case in enumerate(MATRIX):
        for engine in (e for e in engines if e in case.engines):
            measured = run_micro(case, engine, directory / f"{index:02d}-{engine}")
            outcome = Outcome(case.name, engine, measured, case.passes(measured), KNOWN_GAPS.get((case.name, engine)))
            outcomes.append(outcome)
            if on_outcome:
                on_outcome(outcome)
    return outcomes


def markdown(outcomes: list[Outcome], engines: tuple[str, ...], versions: dict[str, str]) -> str:
    """The matrix as a Markdown table (one column per engine), dated, with the known gaps explained."""
    found = {(o.case, o.engine): o for o in outcomes}
    lines = ["# Engine parity", "",
             "The same micro-case on every engine that supports it, against its analytic value (the cases, their "
             "tolerances and why: `orchestrator/parity.py`). ✓ within the tolerance, ✗ a miss, — not supported by the engine.", "",
             f"Measured {dt.date.today().isoformat()} with `demorch parity` on "
             + ", ".join(f"{e} {versions.get(e, '')}".strip() for e in engines) + ".", "",
             "| case | quantity | expected | " + " | ".join(engines) + " |", "|---|---|---|" + "---|" * len(engines)]
    for case in MATRIX:
        cells = []
        for engine in engines:
            outcome = found.get((case.name, engine))
            cells.append("—" if outcome is None else f"{outcome.measured:.4g} {'✓' if outcome.passed else '✗'}")
        bound = (f"{case.expected:g} ± {100 * case.tolerance:g} %" if case.relative
                 else f"{case.expected:g} ± {case.tolerance:g}" if case.tolerance else f"{case.expected:g}")
        quantity = case.quantity.replace("|", "\\|")  # a literal bar inside a Markdown cell
        lines.append(f"| {case.name} | {quantity} | {bound} | " + " | ".join(cells) + " |")
    gaps = [o for o in outcomes if not o.passed]
    if gaps:
        lines += ["", "Misses (✗):", ""] + [f"- {o.case} on {o.engine}: {o.known_gap or 'not a known gap: report it'}" for o in gaps]
    return "\n".join(lines) + "\n"
