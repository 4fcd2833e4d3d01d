"""One run's plan: every engine-neutral number a run needs, computed once from a validated case.

`make_plan` derives the step schedule, the body table, the pair constants, the wall triangles, the
domain, the wall removals and the stop-at-rest checks, and runs the pre-flight checks on those same
numbers, so a run computes each of them once. The plan is frozen and handed to a stateless engine
adapter (`write_input(plan, directory)`, `execute(plan, directory, …)`, `read_output(plan,
directory)`): the deck is rendered from the plan, how the engine runs (MPI processes, executable)
stays with the adapter, and where it runs is the directory passed in, the split ASE's
`calculators/genericfileio.py` makes between template, profile and directory.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

import numpy as np

from orchestrator import geometry, physics, preflight
from orchestrator.capabilities import capabilities
from orchestrator.case import Case, CaseError, Domain, renamed
from orchestrator.estimate import OutputEstimate, estimate
from orchestrator.shapes import BodyShape


@dataclass(frozen=True)
class Resume:
    """Where a continued run starts: its segment number, the checkpoint's step and file (a name in
    the run directory), and the step of the newest frame the cut-off run had written."""

    segment: int
    step: int
    file: str
    reached_step: int | None = field(default=None, compare=False)


@dataclass(frozen=True)
class RestChecks:
    """When and how an engine stops a run at rest (TimeSettings.stop_at_rest), in steps: a check every
    `every` steps from step `first` (`after`: the case's own start, before a later wall removal), the
    speed threshold (m/s), the moving mass M (kg, glued spheres left out) and the stray fraction
    (None: the RMS criterion)."""

    every: int
    after: int
    first: int
    speed: float
    mass: float
    stray_fraction: float | None

    def as_dict(self) -> dict[str, float | None]:
        return {"every": self.every, "after": self.after, "first": self.first, "speed": self.speed, "mass": self.mass,
                "stray_fraction": self.stray_fraction}


@dataclass(frozen=True)
class RunPlan:
    """A validated case and what follows from it, for one run (see the module docstring).

    bodies: one BodyInfo per body in results.h5 order. pairs: the constants of every listed pair,
    with the dashpot an engine without the compiled law uses in its place. wall_triangles: (t, 3, 3)
    per wall, in case order (m). removals: wall name → removal step. rest: None without
    stop_at_rest. output: what the run will write and hold in memory. shapes: one per clump, in case
    order, its shape at its material's density (what engines realise; bodies of one shape and
    material share one object). resume: the checkpoint a continued run starts from (None: from t = 0).
    """

    case: Case
    case_dir: Path
    schedule: physics.Schedule
    bodies: tuple[physics.BodyInfo, ...]
    pairs: tuple[physics.PairConstants, ...]
    wall_triangles: tuple[np.ndarray, ...]
    domain: Domain
    removals: Mapping[str, int]
    rest: RestChecks | None
    output: OutputEstimate
    shapes: tuple[BodyShape, ...]
    resume: Resume | None = None

    @property
    def segment(self) -> int:
        """The segment this plan runs: 0 for a first attempt, k for the k-th continuation."""
        return self.resume.segment if self.resume else 0

    def resumed(self, resume: Resume | None) -> "RunPlan":
        """The same plan continuing from `resume` (nothing is computed again)."""
        return replace(self, resume=resume)

    def masses(self) -> np.ndarray:
        """(bodies,) kg: exact body masses (dumps print fewer digits than the engines compute with)."""
        return np.array([b.mass for b in self.bodies])

    def materials(self) -> np.ndarray:
        """(bodies,) the material of each body, in body order."""
        return np.array([b.material for b in self.bodies])

    def inertia(self) -> np.ndarray:
        """(bodies, 3) kg m²: principal moments about each body's axes."""
        return np.array([b.inertia for b in self.bodies])

    def radii(self) -> np.ndarray:
        """(bodies,) m: each body's bounding radius."""
        return np.array([b.radius for b in self.bodies])


def make_plan(case: Case, case_dir: Path) -> RunPlan:
    """The plan of `case` (files it names are relative to `case_dir`), after the pre-flight checks.

    Raises CaseError (one line naming the field) for what the checks find (orchestrator.preflight).
    """
    schedule = physics.schedule(case)
    shapes = physics.clump_shapes(case)
    table = tuple(physics.bodies(case, shapes))
    triangles = tuple(geometry.wall_triangles(wall, case_dir) for wall in case.walls)
    try:
        output = estimate(case, schedule, table)
        preflight.check_all(case, case_dir, schedule, table, triangles, output)
    except CaseError as error:
        # a study's stage names its own fields (release.duration, not time.duration)
        if not case.field_names:
            raise
        raise CaseError(renamed(str(error), case.field_names)) from None
    can = capabilities(case.engine)
    # An engine without the compiled law runs a dashpot in its place; an implicit one has no stiffness to damp.
    pairs = tuple(physics.pair_constants(case, dashpot_for_bilinear=not can.compiled_law, damping=not can.implicit))
    removals = physics.removal_steps(case, schedule)
    return RunPlan(
        case=case,
        case_dir=case_dir,
        schedule=schedule,
        bodies=table,
        pairs=pairs,
        wall_triangles=triangles,
        domain=case.domain or geometry.automatic_domain(case, list(triangles), schedule.end_time, table),
        removals=MappingProxyType(removals),
        rest=rest_checks(case, schedule, removals, table),
        output=output,
        shapes=shapes,
    )


def rest_checks(case: Case, schedule: physics.Schedule, removals: Mapping[str, int],
                table: tuple[physics.BodyInfo, ...]) -> RestChecks | None:
    """What an engine needs to stop at rest (whole output intervals), or None: run the whole duration."""
    checks = physics.rest_check_steps(case, schedule)
    if checks is None:
        return None
    every, after = checks
    rest = case.time.stop_at_rest
    glued = [s.fixed for s in case.bodies.spheres] + [c.fixed for c in case.bodies.clumps]
    moving = float(sum(body.mass for body, fixed in zip(table, glued) if not fixed))
    # The first check: at `after`, or at the last wall removal if later (a release's trap opening).
    return RestChecks(every=every, after=after, first=max([after, *removals.values()]), speed=rest.speed, mass=moving,
                      stray_fraction=rest.stray_fraction)
