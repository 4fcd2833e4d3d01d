"""The case description: one validated YAML file that either engine can run.

Everything is SI. Every field has an allowed range so that a typo is caught here, with the
field's path in the message, before any engine process starts.
"""

from __future__ import annotations

import math
from enum import Enum
from pathlib import Path
from typing import Annotated, Literal, Union

import yaml
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, field_validator, model_validator

# Names end up in LIGGGHTS decks (group/fix ids) and YADE scripts; a strict pattern keeps them
# inert there and makes quotes, spaces and newlines a validation error rather than an injection.
NAME_PATTERN = r"^[A-Za-z][A-Za-z0-9_]{0,39}$"
Name = Annotated[str, Field(pattern=NAME_PATTERN)]



def _reject_bool(value: object) -> object:
    """YAML turns `yes`/`no`/`true` into booleans; a boolean is never a valid number here."""
    if isinstance(value, bool):
        raise ValueError("must be a number, not a boolean")
    return value


FiniteFloat = Annotated[float, BeforeValidator(_reject_bool), Field(allow_inf_nan=False)]
Vec3 = tuple[FiniteFloat, FiniteFloat, FiniteFloat]


def Real(**bounds: float) -> object:
    """A finite float with bounds, e.g. Real(gt=0, le=1) (pydantic Field keywords)."""
    return Annotated[float, BeforeValidator(_reject_bool), Field(allow_inf_nan=False, **bounds)]


class CaseError(ValueError):
    """A case file that cannot be run; the message names the field and the allowed range."""


class Strict(BaseModel):
    """Base for all case sections: unknown keys are errors, numbers written as "1e5" (a YAML string) are accepted."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class Engine(str, Enum):
    liggghts = "liggghts"
    yade = "yade"


class TimeSettings(Strict):
    """Time integration. `step: auto` derives Δt from the stiffest contact and the lightest body."""

    step: Union[Literal["auto"], Real(gt=0.0, le=1e-2)] = "auto"
    safety_factor: Real(gt=0.0, le=0.5) = 0.02
    duration: Real(gt=0.0, le=1e4)
    output_interval: Real(gt=0.0, le=1e4)


class Material(Strict):
    name: Name
    density: Real(gt=0.0, le=1e5)


class ContactLaw(str, Enum):
    """`linear`: spring-dashpot with restitution e_n (stock in both engines).
    `bilinear`: the Richefeu et al. (2012) loading/unloading law (custom plugin)."""

    linear = "linear"
    bilinear = "bilinear"


class ContactPair(Strict):
    """Contact parameters for one pair of materials (order does not matter)."""

    materials: tuple[Name, Name]
    law: ContactLaw = ContactLaw.linear
    en2: Real(gt=0.0, le=1.0)
    mu: Real(ge=0.0, le=10.0)
    kn: Real(gt=0.0, le=1e12)
    kt_over_kn: Real(ge=0.0, le=10.0)

    @property
    def key(self) -> frozenset[str]:
        return frozenset(self.materials)


class Sphere(Strict):
    material: Name
    radius: Real(gt=0.0, le=10.0)
    position: Vec3
    velocity: Vec3 = (0.0, 0.0, 0.0)
    angular_velocity: Vec3 = (0.0, 0.0, 0.0)
    # A sphere that cannot rotate slides like a block: the sliding-friction check needs it.
    fixed_rotation: bool = False


class Bodies(Strict):
    spheres: Annotated[list[Sphere], Field(min_length=1, max_length=2_000_000)]


class RectangleWall(Strict):
    """A flat rectangle: `origin` corner and two edge vectors. Both engines get the same two triangles."""

    type: Literal["rectangle"]
    name: Name
    material: Name
    origin: Vec3
    edge1: Vec3
    edge2: Vec3

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
    scale: Real(gt=0.0, le=1e6) = 1.0

    @field_validator("file")
    def _stl_suffix(cls, value: str) -> str:
        if not value.lower().endswith(".stl") or "\n" in value or "\x00" in value:
            raise ValueError("must be a path to an .stl file")
        return value


Wall = Annotated[Union[RectangleWall, MeshWall], Field(discriminator="type")]


class Domain(Strict):
    """Simulation box (LIGGGHTS needs one). Bodies leaving it are lost and reported."""

    lower: Vec3
    upper: Vec3

    @model_validator(mode="after")
    def _ordered(self) -> "Domain":
        if any(lo >= up for lo, up in zip(self.lower, self.upper)):
            raise ValueError("every component of lower must be below upper")
        return self


class Case(Strict):
    """One simulation, engine-neutral."""

    name: Name
    engine: Engine = Engine.liggghts
    seed: Annotated[int, Field(ge=1, le=2**31 - 1)] = 12345
    time: TimeSettings
    gravity: Vec3 = (0.0, 0.0, -9.81)
    materials: Annotated[list[Material], Field(min_length=1, max_length=32)]
    contacts: Annotated[list[ContactPair], Field(min_length=1)]
    bodies: Bodies
    walls: list[Wall] = []
    domain: Domain | None = None

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
        if self.time.output_interval > self.time.duration:
            raise ValueError("time.output_interval: must not exceed time.duration")
        return self

    def body_materials(self) -> list[str]:
        """Materials that bodies are made of, in the order of `materials`."""
        used = {s.material for s in self.bodies.spheres}
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

    def material(self, name: str) -> Material:
        return next(m for m in self.materials if m.name == name)

    def contact(self, a: str, b: str) -> ContactPair:
        key = frozenset((a, b))
        return next(p for p in self.contacts if p.key == key)


def _format_error(error: ValidationError) -> str:
    """One line per problem: `field.path: message (got value)`."""
    lines = []
    for item in error.errors():
        location = ".".join(str(part) for part in item["loc"]) or "case"
        message = item["msg"].removeprefix("Value error, ")
        shown = repr(item.get("input"))
        if len(shown) > 60:
            shown = shown[:57] + "..."
        lines.append(f"{location}: {message} (got {shown})")
    return "; ".join(lines)


def parse_case(data: object, source: str = "case") -> Case:
    """Validate a mapping (from YAML or code) into a Case, raising CaseError with a one-line message."""
    if not isinstance(data, dict):
        raise CaseError(f"{source}: the case must be a mapping of fields, got {type(data).__name__}")
    try:
        return Case.model_validate(data)
    except ValidationError as error:
        raise CaseError(f"{source}: {_format_error(error)}") from None


def load_case(path: str | Path) -> Case:
    """Read and validate a YAML case file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise CaseError(f"{path}: cannot read the case file ({error.strerror})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise CaseError(f"{path}: not valid YAML ({str(error).splitlines()[0]})") from None
    return parse_case(data, source=str(path))
