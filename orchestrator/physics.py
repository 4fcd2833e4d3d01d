"""Engine-neutral derived quantities: body masses, per-pair contact constants, the time step.

Both engines receive the same numbers from here, so a case behaves the same whichever runs it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scipy.optimize import brentq

from orchestrator.shapes import BodyShape
from orchestrator.case import Case, CaseError, ContactLaw, Sphere
from orchestrator.capabilities import capabilities


def sphere_mass(sphere: Sphere, density: float) -> float:
    return density * 4.0 / 3.0 * math.pi * sphere.radius**3


@dataclass(frozen=True)
class BodyInfo:
    """What the orchestrator needs of one body, whatever its kind, in results.h5 order."""

    material: str
    mass: float
    radius: float  # bounding radius
    position: tuple[float, float, float]
    velocity: tuple[float, float, float]
    # How many sphere contacts one flat face can make at once (1 for a sphere): the effective
    # stiffness of a face-to-face contact is that many times k_n, which shortens the contact.
    face_contacts: int
    inertia: tuple[float, float, float]  # principal moments about the body axes


def clump_shapes(case: Case) -> tuple[BodyShape, ...]:
    """Each clump's body shape at its material's density, in case order (one object per shape and material)."""
    built: dict[tuple[str, str], BodyShape] = {}
    for c in case.bodies.clumps:
        if (c.shape, c.material) not in built:
            built[(c.shape, c.material)] = case.shape(c.shape).body(case.material(c.material).density)
    return tuple(built[(c.shape, c.material)] for c in case.bodies.clumps)


def bodies(case: Case, shapes: tuple[BodyShape, ...] | None = None) -> list[BodyInfo]:
    """Spheres first, then clumps, as the engines number them (`shapes`: clump_shapes(case), when made already)."""
    table = [
        BodyInfo(s.material, mass, s.radius, s.position, s.velocity, 1, (0.4 * mass * s.radius**2,) * 3)
        for s in case.bodies.spheres
        for mass in [sphere_mass(s, case.material(s.material).density)]
    ]
    for c, body in zip(case.bodies.clumps, clump_shapes(case) if shapes is None else shapes):
        inertia = tuple(float(i) for i in body.principal_inertia)
        table.append(BodyInfo(c.material, body.mass, body.bounding_radius, c.position, c.velocity, body.face_contacts, inertia))
    return table


def reference_masses(case: Case) -> dict[str, float]:
    """Mean body mass per body material: the mass the linear law's damping is tuned for."""
    totals: dict[str, list[float]] = {}
    for body in bodies(case):
        totals.setdefault(body.material, []).append(body.mass)
    return {name: sum(masses) / len(masses) for name, masses in totals.items()}


def smallest_masses(case: Case) -> dict[str, float]:
    """Lightest body per body material, its mass divided by its face-contact count.

    m / n with stiffness k gives the same duration as m with stiffness n k: the shortest contact.
    """
    smallest: dict[str, float] = {}
    for body in bodies(case):
        smallest[body.material] = min(body.mass / body.face_contacts, smallest.get(body.material, math.inf))
    return smallest


def effective_mass(mass_a: float | None, mass_b: float | None) -> float:
    """Reduced mass of a pair; None stands for a wall (infinite mass)."""
    if mass_a is None and mass_b is None:
        raise ValueError("a wall/wall pair has no effective mass")
    if mass_a is None:
        return float(mass_b)  # type: ignore[arg-type]
    if mass_b is None:
        return mass_a
    return mass_a * mass_b / (mass_a + mass_b)


def clipped_restitution(ratio: float) -> float:
    """Restitution of a spring-dashpot whose force is clipped at zero (never attractive).

    With r = β/ω_d (damping rate over damped frequency) the force k x + c x' reaches zero at
    ω_d t* = π - 2 atan r, and from then on the bodies separate at the speed they had:
    e = exp(-r (π - 2 atan r)). Both engines clip (LIGGGHTS `limitForce on`, YADE always), so
    the plain e = exp(-π r) of the unclipped oscillator would miss e² by up to 50 % at e² = 0.13.
    """
    return math.exp(-ratio * (math.pi - 2.0 * math.atan(ratio)))


MIN_LINEAR_EN2 = math.exp(-4.0) * 1.0001  # e → e^-2 as r → ∞: below this no damping is enough


def linear_damping(kn: float, en2: float, mass: float) -> float:
    """Viscous coefficient c_n giving restitution sqrt(en2) for reduced mass m, with force clipping.

    Solves clipped_restitution(r) = e for r, then c = 2 β m = 2 r sqrt(k m) / sqrt(1 + r²).
    """
    if en2 >= 1.0:
        return 0.0
    if en2 < MIN_LINEAR_EN2:
        raise CaseError(f"contacts.en2: the linear law cannot dissipate that much; allowed range: [{MIN_LINEAR_EN2:.4f}, 1]")
    target = 0.5 * math.log(en2)
    ratio = brentq(lambda r: math.log(clipped_restitution(r)) - target, 0.0, 1e6, xtol=1e-14, rtol=1e-14)
    return 2.0 * ratio * math.sqrt(kn * mass) / math.sqrt(1.0 + ratio**2)


@dataclass(frozen=True)
class PairConstants:
    """What an engine needs for one material pair, in SI units."""

    materials: tuple[str, str]
    law: ContactLaw
    kn: float
    kt: float
    en2: float
    mu: float
    cn: float  # normal viscous coefficient (linear law only; 0 for bilinear)
    reference_mass: float


def pair_constants(case: Case, dashpot_for_bilinear: bool = False, damping: bool = True) -> list[PairConstants]:
    """Constants for every pair listed in the case (wall/wall pairs get no damping: they never touch).

    `dashpot_for_bilinear`: an engine without the bilinear law (YADE) emulates it with the linear
    spring-dashpot of the same loading stiffness, damped to the same restitution. `damping` False:
    no viscous coefficient at all (cn = 0), for an engine without stiffness (contact dynamics).
    """
    masses = reference_masses(case)
    constants = []
    for pair in case.contacts:
        a, b = pair.materials
        mass_a, mass_b = masses.get(a), masses.get(b)
        if mass_a is None and mass_b is None:
            reference = 0.0
        else:
            reference = effective_mass(mass_a, mass_b)
        damped = damping and (pair.law is ContactLaw.linear or dashpot_for_bilinear)
        cn = linear_damping(pair.kn, pair.en2, reference) if damped and reference > 0 else 0.0
        constants.append(
            PairConstants(
                materials=(a, b),
                law=pair.law,
                kn=pair.kn,
                kt=pair.kt_over_kn * pair.kn,
                en2=pair.en2,
                mu=pair.mu,
                cn=cn,
                reference_mass=reference,
            )
        )
    return constants


def contact_duration(kn: float, mass: float) -> float:
    """Undamped contact duration π sqrt(m/k): an upper bound on the stiffest phase of either law."""
    return math.pi * math.sqrt(mass / kn)


def time_step(case: Case) -> float:
    """The case's Δt: given, or safety_factor × the shortest contact duration over touching pairs.

    The shortest duration uses the lightest body of each material and the loading stiffness k_n
    (for the bilinear law the unloading branch is softer, hence slower); a clump's mass is divided
    by the spheres on its largest face. The safety factor is the case's, else the default below.
    """
    if case.time.step != "auto":
        return float(case.time.step)
    can = capabilities(case.engine)
    if can.implicit:  # no stiffness, no contact duration: the engine's own step
        return float(can.default_step)
    factor = case.time.safety_factor if case.time.safety_factor is not None else default_safety_factor(case)
    return factor * shortest_contact_duration(case)


def shortest_contact_duration(case: Case) -> float:
    """s; the shortest undamped contact duration over the pairs that can touch (see time_step)."""
    smallest = smallest_masses(case)
    durations = []
    for pair in case.contacts:
        if pair.key not in case.touching_pairs():
            continue
        a, b = pair.materials
        mass = effective_mass(smallest.get(a), smallest.get(b))
        durations.append(contact_duration(pair.kn, mass))
    return min(durations)


def default_safety_factor(case: Case) -> float:
    """0.02 (50 steps per contact) for the compiled bilinear law (LIGGGHTS), else 0.01 (100 steps).

    Measured (2026-11-23): the compiled bilinear law has no damping term, so its error is only the
    discrete overlap. At 50 steps a 50-brick pile settles to 1.7e-7 of its energy drop in 1 s (limit
    1e-6) and a tilted brick's rebound is within 0.2 % of 200 steps. The explicit dashpots (the
    linear law; YADE's stand-in for the bilinear law) lose restitution at 50 steps (e² 0.124–0.128
    for 0.13) and the YADE rebound moved 1.5 %: they keep 100. Larger steps were measured and kept out:
    the rebound hardly moves (apex 0.19 %, spin 0.39 % from 50 to 25 steps), but the pile does not
    come to rest. Its kinetic energy at 1 s is 4.4e-6 of the drop at 25 steps. At 33 steps it is
    6e-9 (50 bricks) and 5.9e-8 (100 bricks), against 1.7e-7 and 1.3e-9 at 50 steps. At 29 steps
    (100 bricks) it is 1.3e-6. Residual motion grows steeply with the step, too close to the limit
    to trade for 1.5 × speed.
    """
    return 0.02 if capabilities(case.engine).compiled_law and case.law is ContactLaw.bilinear else 0.01


@dataclass(frozen=True)
class Schedule:
    """Integer step counts the engines run with; the duration is rounded up to whole output intervals (see schedule)."""

    dt: float
    output_every: int
    frames: int
    total_steps: int

    @property
    def end_time(self) -> float:
        return self.total_steps * self.dt


def removal_steps(case: Case, plan: "Schedule") -> dict[str, int]:
    """Wall name → step at which it is removed, rounded to a whole output interval (frames stay aligned)."""
    return {
        wall.name: max(1, round(wall.remove_at / (plan.output_every * plan.dt))) * plan.output_every
        for wall in case.walls
        if wall.remove_at is not None
    }


def rest_check_steps(case: Case, plan: Schedule) -> tuple[int, int] | None:
    """(steps between rest checks, step of the first check), whole output intervals counted like the
    frames (requested interval), so each check is a recorded frame and a stop leaves the state found
    at rest as the last frame. The first check is at `after`, or at the start of the last stage (the
    last wall removal) if that is later. None without stop_at_rest."""
    rest = case.time.stop_at_rest
    if rest is None:
        return None
    every = max(1, round(rest.check_interval / case.time.output_interval)) * plan.output_every
    after = max(1, math.ceil(rest.after / case.time.output_interval - 1e-9)) * plan.output_every
    return every, after


def schedule(case: Case) -> Schedule:
    """Steps per output interval (the interval rounded to whole steps, at least one) and the number of
    intervals: the duration over the interval actually run, rounded to the nearest whole number.

    So the run ends within half an output interval of the duration whatever the rounding: rounding up
    instead would add a whole interval whenever rounding made it a hair shorter (a 0.1 s run with
    0.02 s output ran 0.12 s), and counting the requested interval would run 0.41 s for 0.35 s when
    the step is longer than the interval (1.18e-5 s steps for 1e-5 s output).
    """
    dt = time_step(case)
    output_every = max(1, round(case.time.output_interval / dt))
    frames = max(1, round(case.time.duration / (output_every * dt)))
    return Schedule(dt=dt, output_every=output_every, frames=frames, total_steps=frames * output_every)

