"""The bodies of a case: spheres, brick shapes (of any kind, orchestrator/shapes) and the bodies made of them."""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field, field_validator, model_validator

from orchestrator.fields import MIN_SIZE, AngularVelocity, Name, Position, QuaternionPart, Real, Strict, Velocity
from orchestrator.shapes import KINDS, BodyShape, make_shape
from orchestrator.shapes import kind as shape_kind
from orchestrator.shapes.clump import BrickClump


class Sphere(Strict):
    material: Name
    radius: Real(unit="m", ge=MIN_SIZE, le=10.0)
    position: Position
    velocity: Velocity = (0.0, 0.0, 0.0)
    angular_velocity: AngularVelocity = (0.0, 0.0, 0.0)
    # A sphere that cannot rotate slides like a block: the sliding-friction check needs it.
    fixed_rotation: bool = False
    # Glued: the sphere never moves (it still touches others). The rough bed of a collapse channel.
    fixed: bool = False


ShapeKind = Literal[tuple(KINDS)]  # type: ignore[valid-type]


class Brick(Strict):
    """The one schema of a brick: its sides, kind and the kind's parameters, checked together.
    A case's shape entry (`BrickShape`) and a study's brick (studies/avalanche/spec.py `BrickSpec`)
    are this schema with their own extra fields."""

    kind: ShapeKind | None = "clump"
    length: Real(unit="m", ge=MIN_SIZE, le=10.0)
    width: Real(unit="m", ge=MIN_SIZE, le=10.0)
    thickness: Real(unit="m", ge=MIN_SIZE, le=10.0)
    layout: tuple[Annotated[int, Field(ge=1, le=64)], Annotated[int, Field(ge=1, le=64)], Annotated[int, Field(ge=1, le=64)]] = (4, 2, 1)
    bevel_deg: Real(unit="°", ge=0.0, le=10.0) = 0.0
    # Edges and corners rounded at this radius (m; 0, or from MIN_SIZE): eight corner spheres join the layout (shapes/clump.py).
    # The 2012 study's brick: 0.001 (its drops are reproduced: tests/test_brick_drop.py).
    rounding: Real(unit="m", ge=0.0, le=1.0) = 0.0
    # Superquadric only: the exponents (n1 across the thickness, n2 in the length-width plane); 2 is
    # an ellipsoid, larger is blockier (flatter faces, sharper edges, a costlier contact search).
    blockiness: tuple[Real(unit="1", ge=2.0, le=40.0), Real(unit="1", ge=2.0, le=40.0)] = (6.0, 6.0)

    @model_validator(mode="after")
    def _a_brick_of_its_kind(self) -> "Brick":
        limit = min(self.length, self.width, self.thickness) / 2.0
        if self.rounding and self.bevel_deg:
            raise ValueError(f"rounding: needs bevel_deg 0 (a brick bevelled by {self.bevel_deg!r}° has no rounded edges); "
                             f"allowed: 0 (got {self.rounding!r})")
        if self.rounding and not MIN_SIZE <= self.rounding < limit:
            # 0 is offered only to a kind that takes it (a rounded box is its rounding)
            zero = "" if self.kind and shape_kind(self.kind).check(self.model_copy(update={"rounding": 0.0})) else "0, or "
            raise ValueError(f"rounding: allowed: {zero}[{MIN_SIZE:g}, {limit:g}) m (below half the smallest side) (got {self.rounding!r})")
        problem = shape_kind(self.kind).check(self) if self.kind else None  # None: a study's brick, the engine's preferred kind
        if problem:
            raise ValueError(problem)
        return self

    def entry(self, name: str = "brick", **extra: object) -> dict[str, object]:
        """This brick as a case's shape entry (JSON-ready; `extra`: mass, inertia), a clump when `kind` is unset."""
        fields = self.model_dump(mode="json", include=set(Brick.model_fields))
        return {**fields, "name": name, "kind": self.kind or "clump", **extra}


class BrickShape(Brick):
    """The one schema of a brick (box) of length × width × thickness, realised as `kind`
    (orchestrator/shapes): `clump`, a clump of layout[0] × layout[1] × layout[2] spheres (see
    shapes/clump.py), or `superquadric`, one body with flat faces and rounded edges of the given
    blockiness (see shapes/superquadric.py), or `rounded_box`, the box swept by a sphere of radius
    `rounding`, with several contact points per touching face (see shapes/rounded_box.py). Every
    kind has the true brick's mass and inertia (given below, or the rounded box's at the density).

    `bevel_deg` > 0 turns three faces by that angle (the paper's modified bricks; clumps only).
    """

    name: Name
    kind: ShapeKind = "clump"
    # The body's mass (kg) and principal moments of inertia (kg m², about the length, width and
    # thickness axes) when given; default: those of the (rounded) box at the material's density.
    mass: Real(unit="kg", gt=0.0, le=1e4) | None = None
    inertia: tuple[Real(unit="kg m²", gt=0.0, le=1e4), Real(unit="kg m²", gt=0.0, le=1e4), Real(unit="kg m²", gt=0.0, le=1e4)] | None = None

    @model_validator(mode="after")
    def _physical_inertia(self) -> "BrickShape":
        if self.inertia is not None:
            a, b, c = sorted(self.inertia)
            if c > a + b:
                raise ValueError(f"inertia: no solid has these principal moments (the largest, {c!r}, exceeds the sum of the other two)")
            if self.mass is not None:  # a body within the brick's box: I ≤ m R², R its half diagonal (5 % for a bevel's tilt)
                most = 1.05 * self.mass * (self.length ** 2 + self.width ** 2 + self.thickness ** 2) / 4.0
                if c > most:
                    raise ValueError(f"inertia: {c!r} kg m² is more than a body of mass {self.mass!r} kg inside a {self.length:g} × {self.width:g} × "
                                     f"{self.thickness:g} m brick can have (m R², R its half diagonal); allowed: each moment at most {most:.4g} kg m²")
        return self

    def body(self, density: float) -> BodyShape:
        """The body shape (mass, inertia, extent, surface…) at the material's density (kg/m³)."""
        return make_shape(self, density)

    def clump(self, density: float) -> BrickClump:
        """The body as a clump of spheres; ValueError for another kind (engine code that needs spheres)."""
        body = self.body(density)
        if not isinstance(body, BrickClump):
            raise ValueError(f"shapes.{self.name}: a {self.kind} brick has no spheres")
        return body


class Clump(Strict):
    """A rigid body of one of the case's shapes (a clump of spheres or a superquadric), with the
    shape's true mass and inertia."""

    shape: Name
    material: Name
    position: Position
    orientation: tuple[QuaternionPart, QuaternionPart, QuaternionPart, QuaternionPart] = (1.0, 0.0, 0.0, 0.0)  # (w, x, y, z)
    velocity: Velocity = (0.0, 0.0, 0.0)
    angular_velocity: AngularVelocity = (0.0, 0.0, 0.0)
    # Glued: the body never moves (it still touches others), e.g. the lower brick of a sliding test.
    fixed: bool = False

    @field_validator("orientation")
    def _unit_quaternion(cls, value: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
        """Normalised, but kept to the bit when already unit (to 1e-12): renormalising moves last bits, so a
        case read back from case.json would hash to another run id and a finished run never be reused."""
        norm = math.hypot(*value)  # no overflow: (1e200, 0, 0, 0) is the identity, not zeros
        if norm < 1e-9:
            raise ValueError("must be a non-zero quaternion (w, x, y, z)")
        return value if abs(norm - 1.0) <= 1e-12 else tuple(v / norm for v in value)  # type: ignore[return-value]


class Bodies(Strict):
    """Spheres (ids first, in order) then clumps (in order): body i in results.h5 is the i-th here."""

    spheres: Annotated[list[Sphere], Field(max_length=2_000_000)] = []
    clumps: Annotated[list[Clump], Field(max_length=200_000)] = []

    @model_validator(mode="after")
    def _not_empty(self) -> "Bodies":
        if not self.spheres and not self.clumps:
            raise ValueError("give at least one body (spheres or clumps)")
        return self
