"""The case description: one validated YAML file that either engine can run.

Everything is SI. Every field has an allowed range so that a typo is caught here, with the
field's path in the message, before any engine process starts.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from enum import Enum
from pathlib import Path
from typing import Annotated, Literal, Union

from pydantic import Field, PrivateAttr, field_validator, model_validator

from orchestrator.bodies import Bodies, BrickShape, Clump, Sphere  # noqa: F401  (re-exported: the case's sections)
from orchestrator.capabilities import DEFAULT_ENGINE, ENGINE_NAMES, Engine, capabilities
from orchestrator.engine_sections import EngineSections
from orchestrator.fields import (Acceleration, AngularVelocity, Coordinate, Name, Position, QuaternionPart, Real,  # noqa: F401  (re-exported)
                                 Speed, Spin, Strict, Velocity)
from orchestrator.validation import CaseError, parse_model, read_yaml  # noqa: F401  (CaseError re-exported)


class RestStop(Strict):
    """End the run early once the bodies are at rest, instead of simulating a fixed, generous duration.

    At rest: the root-mean-square speed of the moving bodies, sqrt(Σ m v² / Σ m) (translation; glued
    spheres excluded), is below `speed`. It is checked every `check_interval` (rounded to whole output
    intervals) from `after` on, so a pile that starts at rest (a release) is not stopped at t = 0.

    With `stray_fraction` f, at rest means instead: the bodies faster than `speed` weigh at most f of
    the moving mass. A few bricks that left the deposit and still roll across the board then do not
    hold a whole avalanche for another half second (measured: docs/benchmarks.md). The speed counted
    is each body's centre speed (YADE, cocd) or, with LIGGGHTS, each clump sphere's (centre plus spin).
    """

    speed: Real(unit="m/s", gt=0.0, le=10.0) = 0.005
    after: Real(unit="s", ge=0.0, le=1e4) = 0.0
    check_interval: Real(unit="s", gt=0.0, le=1e4) = 0.1
    stray_fraction: Real(unit="1", ge=0.0, le=0.1) | None = None


class TimeSettings(Strict):
    """Time integration. `step: auto` derives Δt from the stiffest contact and the lightest body."""

    step: Union[Literal["auto"], float] = Field("auto", json_schema_extra={"unit": "s"})
    # Δt = safety_factor × the shortest contact duration. Default (None): 0.02 (50 steps per
    # contact) for the bilinear law on LIGGGHTS, which has no damping term to integrate; 0.01
    # (100 steps) otherwise, for the explicit dashpots (see physics.default_safety_factor). At most
    # 0.1: there every brick kind's drop rebounds within 0.5 % of 50 steps and lands at rest; at 0.2
    # a flat brick's rebound is 43 % too high and a superquadric lying on the plate does not come to
    # rest; at 0.5 a brick leaves its landing faster than it came (docs/engines.md, time step, 2026-12-06).
    safety_factor: Real(unit="1", gt=0.0, le=0.1) | None = None
    duration: Real(unit="s", gt=0.0, le=1e4)
    output_interval: Real(unit="s", gt=0.0, le=1e4)
    # None: run the whole duration. Otherwise the duration is an upper bound (see RestStop).
    stop_at_rest: RestStop | None = None

    @field_validator("step", mode="before")
    def _step_auto_or_range(cls, value: object) -> object:
        if value == "auto":
            return value
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 < value <= 1e-2:
            raise ValueError("must be 'auto' or a number of seconds; allowed range: (0, 0.01]")
        return float(value)


class Material(Strict):
    name: Name
    density: Real(unit="kg/m³", ge=1.0, le=1e5)


class ContactLaw(str, Enum):
    """`linear`: spring-dashpot with restitution e_n (stock in both engines).
    `bilinear`: the Richefeu et al. (2012) loading/unloading law (custom plugin)."""

    linear = "linear"
    bilinear = "bilinear"


class ContactPair(Strict):
    """Contact parameters for one pair of materials (order does not matter)."""

    materials: tuple[Name, Name]
    law: ContactLaw = ContactLaw.linear
    en2: Real(unit="1", gt=0.0, le=1.0)
    mu: Real(unit="1", ge=0.0, le=10.0)
    kn: Real(unit="N/m", gt=0.0, le=1e12)
    kt_over_kn: Real(unit="1", ge=0.0, le=10.0)

    @property
    def key(self) -> frozenset[str]:
        return frozenset(self.materials)


class RectangleWall(Strict):
    """A flat rectangle: `origin` corner and two edge vectors. Both engines get the same two triangles."""

    type: Literal["rectangle"]
    name: Name
    material: Name
    origin: Position
    edge1: Position
    edge2: Position
    remove_at: Real(unit="s", gt=0.0, le=1e4) | None = None  # s: the wall disappears then (a trap opening)

    @model_validator(mode="after")
    def _not_degenerate(self) -> "RectangleWall":
        ax, ay, az = self.edge1
        bx, by, bz = self.edge2
        cross = (ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx)
        if math.sqrt(sum(c * c for c in cross)) <= 1e-12:
            raise ValueError("edge1 and edge2 must be non-zero and not parallel")
        return self


class MeshWall(Strict):
    """An ASCII or binary STL mesh; the path is relative to the case file."""

    type: Literal["mesh"]
    name: Name
    material: Name
    file: Annotated[str, Field(min_length=1, max_length=4096)]
    scale: Real(unit="1", gt=0.0, le=1e6) = 1.0
    remove_at: Real(unit="s", gt=0.0, le=1e4) | None = None  # s: the wall disappears then (a trap opening)

    @field_validator("file")
    def _stl_suffix(cls, value: str) -> str:
        if not value.lower().endswith(".stl") or "\n" in value or "\x00" in value:
            raise ValueError("must be a path to an .stl file")
        return value


Wall = Annotated[Union[RectangleWall, MeshWall], Field(discriminator="type")]


class Domain(Strict):
    """Simulation box (LIGGGHTS needs one). Bodies leaving it are lost and reported."""

    lower: Position
    upper: Position

    @model_validator(mode="after")
    def _ordered(self) -> "Domain":
        if any(lo >= up for lo, up in zip(self.lower, self.upper)):
            raise ValueError("every component of lower must be below upper")
        return self


class Case(EngineSections, Strict):
    """One simulation, engine-neutral (the sections one engine reads come from EngineSections)."""

    name: Name
    engine: Engine = Engine(DEFAULT_ENGINE)
    seed: Annotated[int, Field(ge=1, le=2**31 - 1)] = 12345
    time: TimeSettings
    gravity: tuple[Acceleration, Acceleration, Acceleration] = (0.0, 0.0, -9.81)
    materials: Annotated[list[Material], Field(min_length=1, max_length=32)]
    contacts: Annotated[list[ContactPair], Field(min_length=1)]
    shapes: list[BrickShape] = []
    bodies: Bodies
    walls: list[Wall] = []
    domain: Domain | None = None
    # What a body leaving `domain` does to the run. "error" (default): the run fails, naming the bodies
    # and when they left (a domain too small, a body thrown out by a bad step). "drop": the run goes on
    # without them; each lost body's state is NaN from the first frame it is out, on every engine,
    # and the run record lists them (bricks falling off the edge of a board, say).
    lost_bodies: Literal["error", "drop"] = "error"
    # Write the engine's whole state at the end (LIGGGHTS: `state.restart`, contact history included),
    # so a later case can start from it: a settled packing feeding many releases, say.
    save_state: bool = False
    # LIGGGHTS only: start from a state file written with `save_state` (a path relative to the case
    # file). `bodies` must then list the bodies as they are in that state, in the same order; the
    # state's simulation box is kept. YADE needs no state file: it places clumps exactly.
    initial_state: Annotated[str, Field(min_length=1, max_length=4096)] | None = None
    # 2D: bodies move in the x-z plane only (no y motion, spin about y only). Spheres whose centres
    # lie in y = const stay there by symmetry; YADE also blocks those degrees of freedom, LIGGGHTS
    # zeroes the y force.
    planar: bool = False
    # Record every contact at each output frame into results.h5 (/contacts: bodies, point, normal and
    # tangential force, branch; per-body contact counts and force sums; coordination number). Opt-in:
    # a dense pile has several contacts per body, so this multiplies the output.
    record_contacts: bool = False

    # For a case made from another file (a study): the names that file gives the case's fields
    # (parse_case's `fields`), so that the pre-flight checks name what its user wrote. Not a field.
    _field_names: dict[str, str] = PrivateAttr(default_factory=dict)

    @property
    def field_names(self) -> Mapping[str, str]:
        """The names the file this case was made from gives its fields ({} for a case file)."""
        return self._field_names

    @model_validator(mode="after")
    def _cross_references(self) -> "Case":
        names = [m.name for m in self.materials]
        if len(set(names)) != len(names):
            raise ValueError("materials: names must be unique")
        known = set(names)
        for i, pair in enumerate(self.contacts):
            for name in pair.materials:
                if name not in known:
                    raise ValueError(f"contacts.{i}.materials: unknown material {name!r}; known: {sorted(known)}")
        pairs = [p.key for p in self.contacts]
        if len(set(pairs)) != len(pairs):
            raise ValueError("contacts: each pair of materials may appear once")
        laws = {p.law for p in self.contacts}
        if len(laws) > 1:
            raise ValueError("contacts.law: all pairs must use the same law in one case")
        for i, sphere in enumerate(self.bodies.spheres):
            if sphere.material not in known:
                raise ValueError(f"bodies.spheres.{i}.material: unknown material {sphere.material!r}; known: {sorted(known)}")
        shapes = {shape.name for shape in self.shapes}
        for i, clump in enumerate(self.bodies.clumps):
            if clump.material not in known:
                raise ValueError(f"bodies.clumps.{i}.material: unknown material {clump.material!r}; known: {sorted(known)}")
            if clump.shape not in shapes:
                raise ValueError(f"bodies.clumps.{i}.shape: unknown shape {clump.shape!r}; known: {sorted(shapes)}")
        for i, wall in enumerate(self.walls):
            if wall.material not in known:
                raise ValueError(f"walls.{i}.material: unknown material {wall.material!r}; known: {sorted(known)}")
        missing = self.touching_pairs() - set(pairs)
        if missing:
            shown = ", ".join(sorted("/".join(sorted(p)) if len(p) == 2 else f"{min(p)}/{min(p)}" for p in missing))
            raise ValueError(f"contacts: missing parameters for the material pairs that can touch: {shown}")
        wall_names = [w.name for w in self.walls]
        if len(set(wall_names)) != len(wall_names):
            raise ValueError("walls: names must be unique")
        for i, wall in enumerate(self.walls):
            if wall.remove_at is not None and wall.remove_at >= self.time.duration:
                raise ValueError(f"walls.{i}.remove_at: must be before the end of the run ({self.time.duration} s)")
        if self.time.output_interval > self.time.duration:
            raise ValueError("time.output_interval: must not exceed time.duration")
        return self

    @model_validator(mode="after")
    def _engine_can_run(self) -> "Case":
        """What the chosen engine cannot run is a case error, from its declared capabilities."""
        problem = engine_limits(self)
        if problem:
            raise ValueError(problem)
        return self

    def body_materials(self) -> list[str]:
        """Materials that bodies are made of, in the order of `materials`."""
        used = {s.material for s in self.bodies.spheres} | {c.material for c in self.bodies.clumps}
        return [m.name for m in self.materials if m.name in used]

    def touching_pairs(self) -> set[frozenset[str]]:
        """Pairs that can come into contact: body/body and body/wall (wall/wall never touch)."""
        body = self.body_materials()
        wall = {w.material for w in self.walls}
        pairs = {frozenset((a, b)) for a in body for b in body}
        pairs |= {frozenset((a, w)) for a in body for w in wall}
        return pairs

    @property
    def law(self) -> ContactLaw:
        return self.contacts[0].law

    def shape(self, name: str) -> BrickShape:
        return next(s for s in self.shapes if s.name == name)

    def material(self, name: str) -> Material:
        return next(m for m in self.materials if m.name == name)

    def contact(self, a: str, b: str) -> ContactPair:
        key = frozenset((a, b))
        return next(p for p in self.contacts if p.key == key)


def engine_limits(case: Case) -> str | None:
    """The first part of `case` that its engine cannot run, as `field: reason; engines that can: …`."""
    from orchestrator.capabilities import engines_with, refused_kinds

    can = capabilities(case.engine)
    engine = case.engine.value
    checks = [
        ("bodies.clumps", bool(case.bodies.clumps), "clumps", f"{engine} takes spheres only"),
        ("bodies", bool(case.bodies.clumps and case.bodies.spheres), "mixed_bodies",
         f"{engine} runs either spheres or clumps in one case, not both"),
        ("initial_state", case.initial_state is not None, "restart",
         f"{engine} cannot start from a state file; give the saved positions, orientations and velocities in `bodies`"),
        ("walls", any(isinstance(w, MeshWall) for w in case.walls), "meshes", f"{engine} takes rectangle walls only"),
        ("record_contacts", case.record_contacts, "contact_output", f"{engine} does not record contacts"),
    ]
    for field, used, capability, reason in checks:
        if used and not getattr(can, capability):
            return f"{field}: {reason}; engines that can: {', '.join(engines_with(**{capability: True}))}"
    section = case.section_limits(engine, case.planar)
    if section:
        return section
    used_kinds = {case.shape(c.shape).kind for c in case.bodies.clumps}
    for i, shape in enumerate(case.shapes):
        if shape.kind in used_kinds and shape.kind not in can.shape_kinds:
            able = [name for name in ENGINE_NAMES if shape.kind in capabilities(name).shape_kinds]
            return f"shapes.{i}.kind: {engine} takes {', '.join(can.shape_kinds)} bodies, not {shape.kind}; engines that can: {', '.join(able)}"
    if len(used_kinds) > 1 and not can.mixed_kinds:  # LIGGGHTS runs a case either as multisphere clumps or as superquadrics
        able = [name for name in ENGINE_NAMES if capabilities(name).mixed_kinds and used_kinds <= set(capabilities(name).shape_kinds)]
        return (f"shapes: {engine} takes bodies of one kind per case ({' or '.join(can.shape_kinds)}), not {' and '.join(sorted(used_kinds))} "
                f"together; give every shape one kind; engines that can mix kinds: {', '.join(able) or 'none'}")
    refused = refused_kinds(engine, case.law.value, case.record_contacts)
    unrecorded = sorted(kind for kind in used_kinds if refused.get(kind) == "record_contacts")
    if unrecorded:
        return f"record_contacts: {engine} does not record the contacts of {unrecorded[0]} bodies; allowed: false"
    bilinear_only = sorted(kind for kind in used_kinds if refused.get(kind) == "contacts.law")
    if bilinear_only:
        return (f"contacts.law: {bilinear_only[0]} bodies touch by the bilinear law of Richefeu et al. (2012) only on {engine}; "
                f"allowed: bilinear (got {case.law.value})")
    used_shapes = {c.shape for c in case.bodies.clumps}
    for kind in sorted(used_kinds & set(can.one_rounding_kinds)):
        first = None
        for i, shape in enumerate(case.shapes):
            if shape.kind == kind and shape.name in used_shapes:
                first = shape.rounding if first is None else first
                if shape.rounding != first:
                    return (f"shapes.{i}.rounding: {engine} takes one rounding for all {kind} bodies of a case; "
                            f"allowed: {first!r} (got {shape.rounding!r})")
    glued = {case.shape(c.shape).kind for c in case.bodies.clumps if c.fixed}
    for kind in sorted(glued - set(can.glued_kinds)):
        able = [name for name in ENGINE_NAMES if kind in capabilities(name).glued_kinds]
        return f"bodies.clumps.fixed: {engine} cannot glue a {kind} body; engines that can: {', '.join(able) or 'none'}"
    return None


def parse_case(data: object, source: str = "case", fields: Mapping[str, str] | None = None) -> Case:
    """Validate a mapping (from YAML or code) into a Case, raising CaseError with a one-line message.

    fields: for a case made from another file (a study), the names that file gives the case's fields,
    so that the message names what its user wrote: {"shapes.0": "brick"} turns `shapes.0.kind` into
    `brick.kind` (a field path is renamed whole, never inside a longer one)."""
    if not isinstance(data, dict):
        raise CaseError(f"{source}: the case must be a mapping of fields, got {type(data).__name__}")
    try:
        case = parse_model(Case, data, source)
    except CaseError as error:
        if not fields:
            raise
        raise CaseError(renamed(str(error), fields)) from None
    if fields:
        case._field_names = dict(fields)
    return case


def renamed(message: str, fields: Mapping[str, str]) -> str:
    """`message` with each case field path in `fields` renamed whole (parse_case's `fields`)."""
    for case_field, name in fields.items():
        message = re.sub(rf"(?<![\w.]){re.escape(case_field)}(?![\w])", name, message)
    return message


def load_case(path: str | Path) -> Case:
    """Read and validate a YAML case file."""
    return parse_case(read_yaml(path), source=str(path))

