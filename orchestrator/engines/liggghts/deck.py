"""The LIGGGHTS deck of a case: data file, wall meshes, template context (numbers from physics.py)."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np

from orchestrator import geometry
from orchestrator.case import Domain
from orchestrator.engines import common
from orchestrator.engines.checkpoint import segment_name
from orchestrator.engines.liggghts import superquadrics
from orchestrator.plan import RunPlan
from orchestrator.engines.templating import render

DECK_NAME = "in.liggghts"
CHECKPOINT_EXT = "restart"  # checkpoint.<step>.restart: LIGGGHTS restart files (atoms, clumps, contact history)
DATA_NAME = "data.spheres"
DUMP_NAME = "frames.bin"  # binary `dump custom` (LIGGGHTS writes binary when the name ends in .bin)
TEXT_DUMP_NAME = "frames.dump"  # runs made before the binary dump; still read
SPHERE_COLUMNS = ("id", "type", "mass", "radius", "x", "y", "z", "vx", "vy", "vz", "omegax", "omegay", "omegaz")
CLUMP_COLUMNS = ("id", "id_multisphere", *SPHERE_COLUMNS[1:])
CONTACT_PAIRS_NAME = "contacts_pairs.dump"  # `dump local` of pair/gran/local (record_contacts)
CONTACT_WALLS_NAME = "contacts_walls.dump"  # `dump local` of wall/gran/local (record_contacts)
STATE_NAME = "state.restart"  # written at the end when the case has `save_state`
INITIAL_STATE_NAME = "initial.restart"  # the `initial_state` a case starts from, linked into the run
INSTALL_HINT = "apt-get install -y liggghts libliggghts-dev openmpi-bin mpi-default-dev"

def id_ranges(ids: list[int]) -> str:
    """Compress sorted ids into LIGGGHTS group ranges: [1, 2, 3, 7] → '1:3 7'."""
    parts: list[str] = []
    start = previous = ids[0]
    for value in ids[1:] + [None]:  # type: ignore[list-item]
        if value is not None and value == previous + 1:
            previous = value
            continue
        parts.append(f"{start}:{previous}" if previous > start else str(start))
        if value is not None:
            start = previous = value
    return " ".join(parts)


# LIGGGHTS bins the whole box at half the neighbour cut-off and clears every bin at each rebuild.
# On the full-scale boards (a 6 x 5 x 3.5 m box for 4 mm spheres) that was 2.4e8 bins: 1.1 GB per
# process and 0.20 s per rebuild, 16 % of the release. Larger bins cap the count at this many
# (measured on that release: 0.035 s per rebuild at 18.6 mm bins, pair time unchanged within noise).
# The demo runs 2.7 x faster with it (1 min 13 s against 3 min 19 s). Bins never change a force:
# pours with capped and own bins agree to round-off until chaos amplifies it (test_avalanche.py,
# test_capped_bins_leave_a_brick_pour_unchanged_to_round_off). The demo's packing density, taken
# before the pile is at rest, scatters by 100 kg/m3 between such round-off twins either way
# (docs/benchmarks.md, "The neighbour bins").
MAX_BINS = 2e7
# Neighbour skin in skin lengths (shapes' `skin_length`): the largest sphere radius, a superquadric's
# bounding radius, a rounded box's half thickness. Chosen by measurement on spheres
# (benchmarks/flow_throughput.py, `settings` sweep, docs/benchmarks.md); a module constant so that
# the benchmark can vary it. A rounded box sized by its bounding radius had a skin of 17.7 mm for a
# 4 mm half thickness: twice the neighbour pairs (31 per brick in the full-scale release, 13–16 at
# 3–6 mm) and 5–6 % more time per step (2026-12-04). Superquadrics keep theirs: at 4 mm their
# full-scale packing ran 35 % slower (LIGGGHTS moves their contact history at every rebuild). A
# skin never changes a force.
SKIN_RADII = 1.0
# LIGGGHTS clears a pair's contact history (surfacesClose) only while the pair is closer than this
# factor × its radii sum without touching; at its default, 1, never. The bilinear law keeps its force
# and overlap in that history, so a pair that met again before the next neighbour-list rebuild
# started from its last contact's values (measured 2026-11-30: five colliding spheres ended 0.43 mm
# apart between LIGGGHTS' own rebuilds and a rebuild at every step; 0 at 1.1, and with the linear
# law). Pairs part by far less than 10 % of their radii in one step.
CONTACT_DISTANCE_FACTOR = 1.1
# m: insert/pack puts a clump's centre at random in a region; a sphere this small (with the region's
# volume_limit lowered, else LIGGGHTS refuses regions under about 1e-12 m³) places it within 1e-9 m.
PLACEMENT_RADIUS = 1e-9


def primes_above(start: int, count: int) -> list[int]:
    """LIGGGHTS random seeds must be primes above 10000."""
    found: list[int] = []
    candidate = start + 1
    while len(found) < count:
        if all(candidate % d for d in range(2, int(candidate**0.5) + 1)):
            found.append(candidate)
        candidate += 1
    return found


def _sphere_radii(plan: RunPlan) -> list[float]:
    """The radius of every particle LIGGGHTS meets: spheres, clump spheres, superquadrics' bounding spheres."""
    return [s.radius for s in plan.case.bodies.spheres] + [body.radius for body in plan.shapes]


def _skin_length(plan: RunPlan) -> float:
    """m, what the neighbour skin is a multiple of: the largest sphere radius or shape skin length."""
    return float(max([s.radius for s in plan.case.bodies.spheres] + [body.skin_length for body in plan.shapes]))


def bin_size(domain: Domain, cutoff: float, max_bins: float = MAX_BINS) -> float | None:
    """The neighbour bin size to ask LIGGGHTS for, or None for its own (half the cut-off).

    A large, mostly empty box (boards of metres, spheres of millimetres) gets bins just large enough
    to stay within max_bins: memory and the clearing at each rebuild fall with the bin count, while
    the distance checks per sphere grow with the bin volume (a dense pile pays for bins much larger
    than the cut-off).
    """
    volume = float(np.prod(np.asarray(domain.upper) - np.asarray(domain.lower)))
    capped = (volume / max_bins) ** (1.0 / 3.0)
    return capped if capped > 0.5 * cutoff else None


def _numbers(values: object) -> str:
    return " ".join(repr(float(v)) for v in values)  # type: ignore[union-attr]


def clump_context(plan: RunPlan, types: dict[str, int]) -> dict[str, object]:
    """Template data for clumps: multisphere templates per (shape, material, glued) and one insertion per clump."""
    case = plan.case
    if not case.bodies.clumps or superquadrics.one_atom_bodies(plan):
        return {"clump_templates": [], "clumps": [], "placement_radius": PLACEMENT_RADIUS}
    kinds = sorted({(c.shape, c.material, c.fixed) for c in case.bodies.clumps})
    seeds = primes_above(10000 + case.seed % 100000, 2 * len(kinds) + len(case.bodies.clumps))
    shape_of = {(c.shape, c.material): body for c, body in zip(case.bodies.clumps, plan.shapes)}
    templates = {}
    for index, (shape_name, material, glued) in enumerate(kinds):
        brick = shape_of[(shape_name, material)]
        spheres = " ".join(f"{_numbers(c)} {float(r)!r}" for c, r in zip(brick.centres, brick.radii))
        tensor = brick.inertia_tensor
        templates[(shape_name, material, glued)] = {
            "template": f"template_{index + 1}",
            "distribution": f"distribution_{index + 1}",
            "seed": seeds[2 * index],
            "seed2": seeds[2 * index + 1],
            "type": types[material],
            "density": case.material(material).density,
            "n": brick.n_spheres,
            "spheres": spheres,
            "multisphere_type": index + 1,
            "mass": brick.mass,
            "inertia": _numbers(tensor[i, j] for i, j in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))),
            # A glued clump: fix multisphere neither moves nor turns it (its forces and torques are not integrated).
            "flags": " fflag off off off tflag off off off" if glued else "",
        }
    clumps = [
        {
            "position": _numbers(c.position),
            "orientation": _numbers(c.orientation),
            "velocity": _numbers(c.velocity),
            "angular_velocity": _numbers(c.angular_velocity),
            "distribution": templates[(c.shape, c.material, c.fixed)]["distribution"],
            "seed": seeds[2 * len(kinds) + i],
        }
        for i, c in enumerate(case.bodies.clumps)
    ]
    return {"clump_templates": list(templates.values()), "clumps": clumps, "placement_radius": PLACEMENT_RADIUS}


def link_initial_state(source: Path, target: Path) -> None:
    """Copy the state file a case starts from into its run directory (the run then holds everything
    its deck reads, even if the packing it came from is deleted). preflight.check_initial_state has
    made sure it is a state LIGGGHTS wrote for this package. A copy, never a link: the source stays
    untouched.
    """
    target.unlink(missing_ok=True)
    shutil.copyfile(source, target)


def run_segments(plan: RunPlan, start: int = 0) -> list[dict[str, object]]:
    """Consecutive `run`s up to each wall removal step (`end`), each followed by the walls removed
    then, from step `start` on (a continued run: the removals due at or before its checkpoint are
    done already, walls_at)."""
    removals = plan.removals
    remaining = [wall.name for wall in plan.case.walls]
    segments, done = [], 0
    for step in sorted(set(removals.values())):
        removed = [name for name, at in removals.items() if at == step]
        remaining = [name for name in remaining if name not in removed]
        segments.append({"steps": step - max(done, start), "end": step, "remove": removed, "remaining": remaining})
        done = step
    total = plan.schedule.total_steps
    segments.append({"steps": total - max(done, start), "end": total, "remove": [], "remaining": remaining})
    return [segment for segment in segments if segment["end"] > start or segment["end"] == total]


def walls_at(plan: RunPlan, step: int) -> list[str]:
    """The walls a run from `step` starts with: those not removed at or before it (a continued run
    starts with the removals due at its checkpoint done)."""
    return [wall.name for wall in plan.case.walls if step == 0 or plan.removals.get(wall.name, step + 1) > step]


def rest_context(plan: RunPlan, last_segment_steps: int) -> dict[str, object] | None:
    """The deck's stop-at-rest runs over the last segment: up to the first check, whole chunks between
    checks, then the remainder to the end (None: one `run`). A continued run's last segment starts at
    its checkpoint, and its first check is the next one due (checks stay where they were)."""
    if plan.rest is None:
        return None
    rest = plan.rest.as_dict()
    start = plan.schedule.total_steps - last_segment_steps  # the last segment starts at the last wall removal (or the checkpoint)
    due = rest["first"] if start <= rest["first"] else rest["first"] + math.ceil((start - rest["first"]) / rest["every"]) * rest["every"]
    first = min(due - start, last_segment_steps)  # steps from there to the first check
    chunks, remainder = divmod(last_segment_steps - first, rest["every"])
    return {**rest, "first": first, "chunks": chunks, "remainder": remainder, "speed_squared": float(rest["speed"]) ** 2}


def write_deck(plan: RunPlan, rundir: Path, processor_grid: str = "* * *", max_bins: float = MAX_BINS,
               skin_radii: float = SKIN_RADII, checkpoint_every: int | None = None) -> Path:
    """The data file, wall meshes and deck of the plan's segment in rundir; returns the deck path.

    checkpoint_every: steps between checkpoint files (None: none). A plan that resumes continues from
    its checkpoint (a deck of its own, in.<segment>.liggghts, writing its own frame files)."""
    case, resume = plan.case, plan.resume
    types = {name: index + 1 for index, name in enumerate(m.name for m in case.materials)}
    start = resume.step if resume else 0
    walls = write_meshes(plan, types, rundir, walls_at(plan, start))
    write_data(plan, types, rundir / DATA_NAME)
    if case.initial_state:
        link_initial_state(plan.case_dir / case.initial_state, rundir / INITIAL_STATE_NAME)
    gravity = np.asarray(case.gravity, dtype=float)
    magnitude = float(np.linalg.norm(gravity))
    direction = gravity / magnitude if magnitude > 0 else np.array([0.0, 0.0, -1.0])
    segments = run_segments(plan, start)
    segment = plan.segment
    radius_max = float(max(_sphere_radii(plan)))
    skin = skin_radii * _skin_length(plan)
    context = {
        "name": case.name,
        "processors": [int(p) if p != "*" else None for p in processor_grid.split()],
        "materials": [{"name": name, "type": t} for name, t in types.items()],
        "n_types": len(types),
        "matrix": common.pair_matrices(case, plan.pairs),
        "law": case.law.value,
        "data_file": DATA_NAME,
        "dump_file": segment_name(DUMP_NAME, segment),
        "contacts": {"pairs": segment_name(CONTACT_PAIRS_NAME, segment), "walls": segment_name(CONTACT_WALLS_NAME, segment)}
                    if case.record_contacts else None,
        "checkpoint_every": checkpoint_every,
        "checkpoint_ext": CHECKPOINT_EXT,
        "resume": {"file": resume.file, "step": resume.step} if resume else None,
        "skin": skin,
        "contact_distance_factor": CONTACT_DISTANCE_FACTOR,
        "binsize": bin_size(plan.domain, cutoff=2.0 * radius_max + skin, max_bins=max_bins),
        "dt": plan.schedule.dt,
        "gravity_magnitude": magnitude,
        "gravity_direction": [float(v) for v in direction],
        "walls": walls,
        "planar": case.planar,
        **body_context(plan, types, starts_from_state=bool(resume or case.initial_state)),
        "output_every": plan.schedule.output_every,
        "thermo_every": max(1, min(plan.schedule.output_every, plan.schedule.total_steps // 100)),
        "total_steps": plan.schedule.total_steps,
        "segments": segments,
        "rest": rest_context(plan, segments[-1]["steps"]),
        "initial_state": INITIAL_STATE_NAME if case.initial_state else "",
        "box": [(float(lo), float(hi)) for lo, hi in zip(plan.domain.lower, plan.domain.upper)],
        "save_state": case.save_state,
        "state_file": STATE_NAME,
    }
    deck = rundir / segment_name(DECK_NAME, segment)
    deck.write_text(render("liggghts", "case.in.j2", context))
    return deck


def body_context(plan: RunPlan, types: dict[str, int], starts_from_state: bool) -> dict[str, object]:
    """Template data for the bodies: atom style, dump columns, glued and non-rotating ids, clump
    templates or superquadric settings (none when the bodies come from a state file)."""
    case = plan.case
    superquadric = superquadrics.one_atom_bodies(plan)
    if superquadric:
        glued = [i + 1 for i, c in enumerate(case.bodies.clumps) if c.fixed]
        fixed = []
    else:
        glued = [i + 1 for i, s in enumerate(case.bodies.spheres) if s.fixed]
        fixed = [i + 1 for i, s in enumerate(case.bodies.spheres) if s.fixed_rotation and not s.fixed]
    return {
        "dump_columns": " ".join(dump_columns(plan)),
        "atom_style": "superquadric" if superquadric else "granular",
        "surface": " surface superquadric" if superquadric else "",  # pair_style gran's superquadric surface
        "superquadric": superquadric,
        # rounded boxes: pair_style roundedbox and fix wall/roundedbox (custom_contact/) at this rounding
        "rounding": superquadrics.rounding(plan) if superquadric else None,
        "superquadric_sets": superquadrics.set_commands(plan) if superquadric and not starts_from_state else [],
        "fixed_rotation_ids": id_ranges(fixed) if fixed else "",
        "glued_ids": id_ranges(glued) if glued else "",
        **clump_context(plan, types),
    }


def dump_columns(plan: RunPlan) -> tuple[str, ...]:
    """The frame dump's columns: per sphere, per clump sphere (with its body id) or per superquadric (with its orientation)."""
    if superquadrics.one_atom_bodies(plan):
        return superquadrics.SUPERQUADRIC_COLUMNS
    return CLUMP_COLUMNS if plan.case.bodies.clumps else SPHERE_COLUMNS


def write_meshes(plan: RunPlan, types: dict[str, int], rundir: Path, present: list[str]) -> list[dict[str, object]]:
    """An ASCII STL per wall present (rundir/meshes); the template data of each."""
    mesh_dir = rundir / "meshes"
    mesh_dir.mkdir(exist_ok=True)
    walls = []
    for wall, triangles in zip(plan.case.walls, plan.wall_triangles):
        if wall.name in present:
            stl = mesh_dir / f"{wall.name}.stl"
            geometry.write_ascii_stl(stl, triangles)
            walls.append({"name": wall.name, "stl": f"meshes/{stl.name}", "type": types[wall.material]})
    return walls


def write_data(plan: RunPlan, types: dict[str, int], path: Path) -> None:
    """LIGGGHTS data file (atom_style granular): Atoms `id type diameter density x y z`, then Velocities;
    or, for superquadric bodies, their rows (superquadrics.atom_rows)."""
    case = plan.case
    lower, upper = plan.domain.lower, plan.domain.upper
    superquadric = superquadrics.one_atom_bodies(plan)
    lines = [
        f"LIGGGHTS data file written by dem-orchestrator for case {case.name}",
        "",
        f"{len(case.bodies.clumps) if superquadric else len(case.bodies.spheres)} atoms",
        f"{len(types)} atom types",
        "",
        f"{lower[0]!r} {upper[0]!r} xlo xhi",
        f"{lower[1]!r} {upper[1]!r} ylo yhi",
        f"{lower[2]!r} {upper[2]!r} zlo zhi",
    ]
    if superquadric:
        lines += ["", "Atoms", "", *superquadrics.atom_rows(plan, types), "", "Velocities", "", *superquadrics.velocity_rows(case)]
        path.write_text("\n".join(lines) + "\n")
        return
    if not case.bodies.spheres:  # clumps only: they are inserted by the deck
        path.write_text("\n".join(lines) + "\n")
        return
    lines += ["", "Atoms", ""]
    for i, sphere in enumerate(case.bodies.spheres, start=1):
        density = case.material(sphere.material).density
        x, y, z = sphere.position
        lines.append(f"{i} {types[sphere.material]} {2.0 * sphere.radius!r} {density!r} {x!r} {y!r} {z!r}")
    lines += ["", "Velocities", ""]
    for i, sphere in enumerate(case.bodies.spheres, start=1):
        values = " ".join(repr(float(v)) for v in (*sphere.velocity, *sphere.angular_velocity))
        lines.append(f"{i} {values}")
    path.write_text("\n".join(lines) + "\n")
