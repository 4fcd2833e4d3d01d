"""Case and study sections that one engine reads and the others ignore.

They live in this leaf module (it imports nothing from the package) so that the case model names
no engine and loads no engine code: `Case` and the studies inherit these sections.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


COCD_SOLVERS = ("clarabel", "scs", "piqp", "mehrotra")
COCD_PLANAR_ONLY = ("piqp", "mehrotra")  # their constraints are linear: a 2D contact's cone is two rows


class CocdSettings(_Section):
    """The cocd engine's solver: Clarabel (interior point, the reference), SCS (first order), PIQP and
    mehrotra (2D only; mehrotra is cocd's own interior point, warm-started, docs/engines.md); `auto` is
    mehrotra in 2D and Clarabel in 3D. `tolerance` bounds the solver's relative primal and dual
    residuals and duality gap, from 1e-10 (what every solver met in double precision on the recorded
    steps of a collapse: mehrotra's primal residual has a floor of 2e-12 there) to 1e-2; a step whose
    solver stops short of it ends the run with one line naming this field."""

    solver: Literal["auto", "clarabel", "scs", "piqp", "mehrotra"] = "auto"
    tolerance: Annotated[float, Field(ge=1e-10, le=1e-2, allow_inf_nan=False, json_schema_extra={"unit": "1"})] = 1e-8

    def resolved(self, planar: bool) -> str:
        """The solver that runs: `auto` is mehrotra in 2D (the fastest there, docs/benchmarks.md), Clarabel in 3D."""
        if self.solver == "auto":
            return "mehrotra" if planar else "clarabel"
        return self.solver


class EngineSections(_Section):
    """Sections of a case read by one engine only."""

    cocd: CocdSettings = CocdSettings()  # engine: cocd only

    def engine_sections(self) -> dict[str, object]:
        """The engine-only sections as data, to carry from a study into the cases it makes."""
        return {name: getattr(self, name).model_dump() for name in EngineSections.model_fields}

    def section_limits(self, engine: str, planar: bool) -> str | None:
        """What the engine's own section asks that this case cannot give, as `field: reason; allowed: …`."""
        if engine == "cocd" and not planar and self.cocd.solver in COCD_PLANAR_ONLY:
            allowed = [name for name in ("auto", *COCD_SOLVERS) if name not in COCD_PLANAR_ONLY]
            return f"cocd.solver: {self.cocd.solver} solves 2D cases only (planar: true); allowed in 3D: {', '.join(allowed)}"
        return None


class StudyEngineSections(EngineSections):
    """A study's engine-only sections: those of its cases, and the step of an implicit engine."""

    # cocd has no contact stiffness, so no contact duration to take a fraction of: its step is this.
    cocd_step: Annotated[float, Field(gt=0.0, le=0.01, allow_inf_nan=False, json_schema_extra={"unit": "s"})] = 1e-3

    def implicit_step(self) -> float:
        """Δt (s) for an engine with the `implicit` capability."""
        return self.cocd_step
