"""Per-material constants for YADE's ViscElMat from the case's per-pair constants.

YADE gives every body one material and combines two materials' stiffness and damping in series,
1/k = 1/k_a + 1/k_b, treating a zero as absent (k = k_b when k_a = 0). So for each quantity we
solve for per-material values that reproduce every touching pair: a body material gets twice its
self-pair value, a wall material what is left for each body/wall pair. A combination the series
rule cannot express is a case error, reported before YADE starts.

The stand-in's dashpot is sized for one contact. A clump landing flat touches with face_contacts
spheres at once, and N dashpots in parallel damp like one with √N times the damping ratio (a 4 × 2 × 1
brick landing flat on 8: v_out/v_in 0.414 for 0.727). stand_in_scale divides every dashpot by √N
when all bodies are clumps with the same N: a flat landing then has the law's restitution, a
landing on fewer spheres (a corner) is under-damped (docs/parity.md gives the measured values).

A glued (fixed) sphere gives its partner the whole contact: the dashpot must be sized for the
partner's mass, not for the reduced mass of two moving bodies (which under-damps: e² 0.632 for
0.53 on a sphere landing on a glued one). Glued spheres therefore get a clone of their material
(GLUED) whose damping makes each moving/glued pair come out at the partner's mass.
"""

from __future__ import annotations

import math

from orchestrator.plan import RunPlan
from orchestrator.case import Case, CaseError, ContactLaw
from orchestrator.physics import MIN_LINEAR_EN2, PairConstants, clipped_restitution, linear_damping, reference_masses

RELATIVE_TOLERANCE = 1e-9
GLUED = "{}~glued"  # the YADE material of a body material's glued spheres (no case name has a '~')


def series(a: float, b: float) -> float:
    """YADE's contactParameterCalculation: series combination where 0 means 'absent'."""
    inverse = (1.0 / a if a else 0.0) + (1.0 / b if b else 0.0)
    return 1.0 / inverse if inverse else 0.0


def _close(a: float, b: float) -> bool:
    return abs(a - b) <= RELATIVE_TOLERANCE * max(abs(a), abs(b), 1e-300)


def split_in_series(case: Case, pairs: list[PairConstants], quantity: str) -> dict[str, float]:
    """Per-material values of `quantity` (kn, kt or cn) whose series combinations give the pair values."""
    value = {frozenset(p.materials): float(getattr(p, quantity)) for p in pairs}
    bodies = case.body_materials()
    walls = sorted({w.material for w in case.walls} - set(bodies))
    per_material = {name: 2.0 * value[frozenset((name,))] for name in bodies}
    for name in walls:
        for body in bodies:
            target = value.get(frozenset((body, name)))
            if target is None:
                continue
            if not target:
                candidate = 0.0
            elif not per_material[body]:
                candidate = target
            else:
                remainder = 1.0 / target - 1.0 / per_material[body]
                candidate = 0.0 if abs(remainder) * target <= RELATIVE_TOLERANCE else (1.0 / remainder if remainder > 0 else -1.0)
            if candidate < 0:
                raise CaseError(_too_large(body, name, quantity, target, per_material[body], pairs))
            per_material.setdefault(name, candidate)
    for pair, target in value.items():
        names = sorted(pair) * (2 if len(pair) == 1 else 1)
        if any(n not in per_material for n in names):
            continue  # wall/wall: never touch
        got = series(per_material[names[0]], per_material[names[1]])
        if not _close(got, target):
            raise CaseError(
                f"contacts ({'/'.join(names)}).{_field(quantity)}: YADE combines per-material values in series; "
                f"with the other pairs this pair would get {got!r}, not {target!r}. Make the pair values consistent "
                f"(k_ab = k_a k_b / (k_a + k_b) with k_a = 2 k_aa) or run this case on LIGGGHTS"
            )
    return per_material


def _too_large(body: str, wall: str, quantity: str, target: float, limit: float, pairs: list[PairConstants]) -> str:
    """The error for a body/wall value above what the series rule allows, in the field the user wrote."""
    head = f"contacts ({body}/{wall}).{_field(quantity)}: YADE combines per-material values in series"
    if quantity != "cn":
        ratio = "" if quantity == "kn" else " (k_t = kt_over_kn · k_n)"
        return f"{head}, so a body/wall value may not exceed twice the body's self-pair value{ratio}; allowed range: (0, {limit:.6g}] (got {target:.6g})"
    pair = next(p for p in pairs if frozenset(p.materials) == frozenset((body, wall)))
    lowest = restitution_for_damping(limit, pair.kn, pair.reference_mass)
    return (f"{head}, so a body/wall contact may not dissipate more than twice the body's own pair; "
            f"allowed range: [{lowest:.4g}, 1] (got {pair.en2:.4g})")


def restitution_for_damping(cn: float, kn: float, mass: float) -> float:
    """e_n² of a clipped spring-dashpot (k_n, c_n) for reduced mass m: physics.linear_damping inverted."""
    q = cn / (2.0 * math.sqrt(kn * mass))  # = r / sqrt(1 + r²), r = β / ω_d
    if q >= 1.0:
        return MIN_LINEAR_EN2
    return clipped_restitution(q / math.sqrt(1.0 - q * q)) ** 2


def _field(quantity: str) -> str:
    return {"kn": "kn", "kt": "kt_over_kn", "cn": "en2"}[quantity]


def yade_materials(case: Case, pairs: list[PairConstants]) -> list[dict[str, object]]:
    """ViscElMat arguments per material, in case order (YADE material id = index). Friction is not a
    material property here: it reaches YADE once, per pair, through the script's MatchMaker."""
    stiffness = split_in_series(case, pairs, "kn")
    shear = split_in_series(case, pairs, "kt")
    damping = split_in_series(case, pairs, "cn")
    result = []
    for material in case.materials:
        result.append(
            {
                "name": material.name,
                "density": material.density,
                "kn": stiffness.get(material.name, 0.0),
                "ks": shear.get(material.name, 0.0),
                "cn": damping.get(material.name, 0.0),
            }
        )
    return result


def glued_clones(case: Case, pairs: list[PairConstants], rows: list[dict[str, object]]) -> list[dict[str, object]]:
    """ViscElMat arguments of the GLUED clone of each material that has glued spheres: the material's
    own stiffness, and the damping that gives every damped pair with a moving body of material X
    the dashpot of X's mass alone (series rule: 1/c = 1/c_X + 1/c_clone)."""
    by_name = {row["name"]: row for row in rows}
    masses = reference_masses(case)
    glued = sorted({s.material for s in case.bodies.spheres if s.fixed})
    moving = {s.material for s in case.bodies.spheres if not s.fixed} | {c.material for c in case.bodies.clumps}
    clones = []
    for name in glued:
        candidates = []
        for pair in pairs:
            others = [m for m in pair.materials if m != name] or [name]
            if name not in pair.materials or others[0] not in moving or not pair.cn:
                continue
            partner = others[0]
            target = linear_damping(pair.kn, pair.en2, masses[partner])
            remainder = 1.0 / target - 1.0 / float(by_name[partner]["cn"])
            if remainder <= 0.0:
                raise CaseError(f"contacts ({partner}/{name}).en2: YADE cannot damp a body landing on a glued sphere enough "
                                "with the series rule; run this case on LIGGGHTS")
            candidates.append(1.0 / remainder)
        if candidates and not all(_close(c, candidates[0]) for c in candidates):
            raise CaseError(f"materials ({name}): its glued spheres meet bodies of several masses, which YADE's per-material "
                            "damping cannot all reproduce; run this case on LIGGGHTS")
        clones.append({**by_name[name], "name": GLUED.format(name), "cn": candidates[0] if candidates else by_name[name]["cn"]})
    return clones


def glued_friction(friction: list[tuple[str, str, float]], clones: list[str]) -> list[tuple[str, str, float]]:
    """The (material, material, μ) pairs a glued clone adds: it meets what its material meets, with
    the same friction, except another glued sphere (glued spheres never interact)."""
    added = []
    for clone in clones:
        name = clone.split("~")[0]
        for a, b, mu in friction:
            if a == name:
                added.append((clone, b, mu))
            if b == name:
                added.append((a, clone, mu))
    return added


def stand_in_scale(plan: RunPlan) -> tuple[float, str | None]:
    """(factor on every dashpot of the bilinear stand-in, warning or None): 1/√N when every body is a
    clump whose flat landing touches with N spheres; 1 with a warning when clumps of different N, or
    clumps and spheres, share the case (one factor cannot serve them all)."""
    case = plan.case
    if case.law is not ContactLaw.bilinear or not case.bodies.clumps:
        return 1.0, None
    counts = {body.face_contacts for body in plan.shapes}
    if len(counts) == 1 and not case.bodies.spheres:
        return 1.0 / math.sqrt(counts.pop()), None
    return 1.0, ("YADE's dashpot stand-in of the bilinear law is not calibrated for these clumps (several face-contact counts, "
                 f"{sorted(counts)}, or spheres beside them): bodies landing on several spheres at once are over-damped")
