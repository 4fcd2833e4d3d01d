"""The field types every case section is built from: names, bounded reals with units, vectors."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field

# Names end up in LIGGGHTS decks (group/fix ids) and YADE scripts; a strict pattern keeps them
# inert there and makes quotes, spaces and newlines a validation error rather than an injection.
NAME_PATTERN = r"^[A-Za-z][A-Za-z0-9_]{0,39}$"

# m: the smallest length of any body (a sphere's radius, a brick's sides and rounding, a clump's
# spheres): a smaller body's mass and inertia underflow in the engines, and it falls through its support.
MIN_SIZE = 1e-6
Name = Annotated[str, Field(pattern=NAME_PATTERN)]


def _reject_bool(value: object) -> object:
    """YAML turns `yes`/`no`/`true` into booleans; a boolean is never a valid number here."""
    if isinstance(value, bool):
        raise ValueError("must be a number, not a boolean")
    return value


def Real(*, unit: str, **bounds: float) -> object:
    """A finite float with its unit and bounds, e.g. Real(unit="s", gt=0, le=1) (pydantic Field
    keywords); the unit ("1": dimensionless) goes into the JSON Schema and the field reference."""
    return Annotated[float, BeforeValidator(_reject_bool), Field(allow_inf_nan=False, json_schema_extra={"unit": unit}, **bounds)]


# Physical bounds of the vectors of a case, far beyond any granular flow but finite: a coordinate of
# 1e300 m or a speed of 1e8 m/s is a typo, and an engine would meet it as an overflow.
Coordinate = Real(unit="m", ge=-1e4, le=1e4)
Speed = Real(unit="m/s", ge=-1e3, le=1e3)
Spin = Real(unit="rad/s", ge=-1e5, le=1e5)
Acceleration = Real(unit="m/s²", ge=-1e3, le=1e3)
Position = tuple[Coordinate, Coordinate, Coordinate]
Velocity = tuple[Speed, Speed, Speed]
AngularVelocity = tuple[Spin, Spin, Spin]
QuaternionPart = Real(unit="1")


class Strict(BaseModel):
    """Base for all case sections: unknown keys are errors, numbers written as "1e5" (a YAML string) are accepted."""

    model_config = ConfigDict(extra="forbid", frozen=True)
