"""Superquadric bodies on LIGGGHTS: data-file rows, the per-body settings, and their dump columns.

Each superquadric brick is one atom of `atom_style superquadric` (the source-built LIGGGHTS, see
plugin.ensure_superquadric_liggghts). The data file gives its half-axes, blockiness and a density;
`set atom` then gives it the true brick's mass and principal moments (LIGGGHTS would otherwise take
those of the superquadric's own volume), its orientation, and its spin (after the orientation and
inertia, since LIGGGHTS turns the spin into an angular momentum with both).
"""

from __future__ import annotations

from orchestrator.case import Case
from orchestrator.shapes.superquadric import BrickSuperquadric

# Dump columns of a superquadric run: quat1..4 are the orientation (w, x, y, z).
SUPERQUADRIC_COLUMNS = ("id", "type", "mass", "radius", "x", "y", "z", "vx", "vy", "vz", "omegax", "omegay", "omegaz",
                        "quat1", "quat2", "quat3", "quat4")


def is_superquadric_case(case: Case) -> bool:
    return any(case.shape(c.shape).kind == "superquadric" for c in case.bodies.clumps)


def bodies(case: Case) -> list[BrickSuperquadric]:
    return [case.shape(c.shape).body(case.material(c.material).density) for c in case.bodies.clumps]  # type: ignore[misc]


def atom_rows(case: Case, types: dict[str, int]) -> list[str]:
    """Atoms rows `id type density a b c n1 n2 x y z`, one per body in case order (atom id = body index + 1)."""
    rows = []
    for i, (c, body) in enumerate(zip(case.bodies.clumps, bodies(case)), start=1):
        a, b, h = (float(v) for v in body.half_axes)
        n1, n2 = body.blockiness
        x, y, z = c.position
        rows.append(f"{i} {types[c.material]} {body.engine_density!r} {a!r} {b!r} {h!r} {float(n1)!r} {float(n2)!r} {x!r} {y!r} {z!r}")
    return rows


def velocity_rows(case: Case) -> list[str]:
    """Velocities rows `id vx vy vz 0 0 0` (the spin is set with `set`, after the orientation)."""
    return [f"{i} {' '.join(repr(float(v)) for v in c.velocity)} 0.0 0.0 0.0" for i, c in enumerate(case.bodies.clumps, start=1)]


def set_commands(case: Case) -> list[str]:
    """One `set atom` per body: true mass and principal moments, orientation (w, x, y, z), spin."""
    commands = []
    for i, (c, body) in enumerate(zip(case.bodies.clumps, bodies(case)), start=1):
        ix, iy, iz = (float(v) for v in body.principal_inertia)
        w, x, y, z = (float(v) for v in c.orientation)
        spin = " ".join(f"omega{axis} {float(v)!r}" for axis, v in zip("xyz", c.angular_velocity))
        commands.append(f"set atom {i} mass {body.mass!r} inertiax {ix!r} inertiay {iy!r} inertiaz {iz!r} "
                        f"quat_direct {w!r} {x!r} {y!r} {z!r} {spin}")
    return commands

