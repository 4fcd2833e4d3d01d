"""One-atom bodies on LIGGGHTS (superquadrics, rounded boxes): data-file rows, the per-body settings,
and their dump columns.

Each such brick is one atom of `atom_style superquadric` (the source-built LIGGGHTS, see
plugin.ensure_superquadric_liggghts). A rounded box is that atom too: its `shape` is the box's outer
half extents, and `pair_style roundedbox` / `fix wall/roundedbox` (custom_contact/) make its
contacts, taking the inner box as `shape` less the rounding; its blockiness only sizes LIGGGHTS'
own bounding radius (ROUNDED_BOX_BLOCKINESS). The data file gives its half-axes, blockiness and a density;
`set atom` then gives it the true brick's mass and principal moments (LIGGGHTS would otherwise take
those of the superquadric's own volume), its orientation, and its spin (after the orientation and
inertia, since LIGGGHTS turns the spin into an angular momentum with both).
"""

from __future__ import annotations

from orchestrator.case import Case
from orchestrator.plan import RunPlan
from orchestrator.shapes import BodyShape

# Dump columns of a superquadric run: quat1..4 are the orientation (w, x, y, z).
SUPERQUADRIC_COLUMNS = ("id", "type", "mass", "radius", "x", "y", "z", "vx", "vy", "vz", "omegax", "omegay", "omegaz",
                        "quat1", "quat2", "quat3", "quat4")


# Kinds whose body is one atom of `atom_style superquadric`.
ONE_ATOM_KINDS = ("superquadric", "rounded_box")
# A rounded box's blockiness in the data file: LIGGGHTS sizes the atom's radius (the dump's) from it;
# at 12 that radius is within 2 % of the box's corner.
ROUNDED_BOX_BLOCKINESS = (12.0, 12.0)


def one_atom_bodies(plan: RunPlan) -> bool:
    """Whether the plan's bodies are one atom each (superquadrics or rounded boxes)."""
    return any(body.kind in ONE_ATOM_KINDS for body in plan.shapes)


def rounding(plan: RunPlan) -> float | None:
    """The rounding radius (m) of a run of rounded boxes (pair_style roundedbox takes one: the case
    check `capabilities.one_rounding_kinds` holds them to it), else None."""
    return next((float(body.rounding) for body in plan.shapes if body.kind == "rounded_box"), None)  # type: ignore[attr-defined]


def _data_shape(body: BodyShape) -> tuple[tuple[float, float, float], tuple[float, float], float]:
    """(half-axes m, blockiness, density kg/m³) of a body's data-file row: LIGGGHTS' own mass of these
    is overwritten by `set atom … mass` (set_commands)."""
    a, b, c = (float(v) for v in body.half_axes)  # type: ignore[attr-defined]
    if body.kind == "rounded_box":
        return (a, b, c), ROUNDED_BOX_BLOCKINESS, body.mass / (8.0 * a * b * c)
    n1, n2 = body.blockiness  # type: ignore[attr-defined]
    return (a, b, c), (float(n1), float(n2)), body.engine_density  # type: ignore[attr-defined]


def atom_rows(plan: RunPlan, types: dict[str, int]) -> list[str]:
    """Atoms rows `id type density a b c n1 n2 x y z`, one per body in case order (atom id = body index + 1)."""
    rows = []
    for i, (c, body) in enumerate(zip(plan.case.bodies.clumps, plan.shapes), start=1):
        (a, b, h), (n1, n2), density = _data_shape(body)
        x, y, z = c.position
        rows.append(f"{i} {types[c.material]} {density!r} {a!r} {b!r} {h!r} {n1!r} {n2!r} {x!r} {y!r} {z!r}")
    return rows


def velocity_rows(case: Case) -> list[str]:
    """Velocities rows `id vx vy vz 0 0 0` (the spin is set with `set`, after the orientation)."""
    return [f"{i} {' '.join(repr(float(v)) for v in c.velocity)} 0.0 0.0 0.0" for i, c in enumerate(case.bodies.clumps, start=1)]


def set_commands(plan: RunPlan) -> list[str]:
    """One `set atom` per body: true mass and principal moments, orientation (w, x, y, z), spin."""
    commands = []
    for i, (c, body) in enumerate(zip(plan.case.bodies.clumps, plan.shapes), start=1):
        ix, iy, iz = (float(v) for v in body.principal_inertia)
        w, x, y, z = (float(v) for v in c.orientation)
        spin = " ".join(f"omega{axis} {float(v)!r}" for axis, v in zip("xyz", c.angular_velocity))
        commands.append(f"set atom {i} mass {body.mass!r} inertiax {ix!r} inertiay {iy!r} inertiaz {iz!r} "
                        f"quat_direct {w!r} {x!r} {y!r} {z!r} {spin}")
    return commands

