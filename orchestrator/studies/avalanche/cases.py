"""The two cases an avalanche study expands into: the packing and the release.

The packing: bricks rained (or stacked) into the closed box standing on its base (gravity along the
slope's normal, as the experiment and the 2012 study filled it before setting it on the slope; an
ordered pile under a lid at the walls' top), settled for `packing.settle_time`, with μ brick/brick of
a density-search trial. Each packing is content-addressed (the hash of its case) and stored once
under a packings directory, so every study with the same packing inputs reuses it. The release: the packed bricks, vertical gravity, the trap
gone, the study's contacts, flowing for `release.duration`; its time starts at the opening.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from orchestrator.case import Case, RestStop, parse_case
from orchestrator.engines import build_stamp, capabilities
from orchestrator.results import Trajectory
from orchestrator.rundir import run_id
from orchestrator.studies.avalanche.geometry import ordered_pile, pile_rows, rain_height, rain_positions
from orchestrator.studies.avalanche.spec import PILE_GAP, RAIN_GAP, AvalancheStudy, ContactSpec

def _contacts(spec: ContactSpec, brick_brick_mu: float | None = None) -> list[dict[str, Any]]:
    """Case contact pairs from a study's contact spec (brick/box takes the brick/board values)."""
    brick_brick = spec.brick_brick.model_dump()
    if brick_brick_mu is not None:
        brick_brick["mu"] = brick_brick_mu
    board = spec.brick_board.model_dump()
    return [
        {"materials": ["brick", "brick"], "law": spec.law, **brick_brick},
        {"materials": ["brick", "board"], "law": spec.law, **board},
        {"materials": ["brick", "box"], "law": spec.law, **board},
    ]


def _initial_layout(study: AvalancheStudy) -> tuple[np.ndarray, np.ndarray, float]:
    """Where the bricks start (rain cells or the ordered pile) and the height the packing's box walls
    need to hold them (m; the box's own height, or more while the rain stands above it)."""
    geometry, brick, count = study.geometry.build(), study.brick_spec.build(), study.brick_count
    if study.packing.kind == "random_pour":
        positions, orientations = rain_positions(geometry, brick, count, study.seed, gap=RAIN_GAP)
        return positions, orientations, max(geometry.box_height, rain_height(geometry, brick, count, gap=RAIN_GAP))
    positions, orientations = ordered_pile(geometry, brick, count, gap=PILE_GAP, flip_seed=study.seed if study.packing.flips else None)
    rows, columns = pile_rows(geometry, brick, PILE_GAP)
    height = max(geometry.box_height, (count // (rows * columns) + 1) * (brick.extent[2] + PILE_GAP) + PILE_GAP)
    return positions, orientations, height


# A stage's case fields by the names the study file gives them (errors name what the user wrote).
_STAGE_FIELDS = {
    True: {"time.duration": "packing.settle_time", "time.safety_factor": "packing.time_safety_factor", "time.stop_at_rest": "packing.stop_at_rest",
           "time.output_interval": "release.output_interval"},
    False: {"time.duration": "release.duration", "time.safety_factor": "release.time_safety_factor", "time.stop_at_rest": "release.stop_at_rest",
            "time.output_interval": "release.output_interval", "record_contacts": "release.record_contacts"},
}


def _case(study: AvalancheStudy, name: str, duration: float, output_interval: float, rest: RestStop | None,
          contacts: list[dict[str, Any]], clumps: list[dict[str, Any]], walls: list[dict[str, object]],
          safety_factor: float | None = None, packing: bool = False, **extra: Any) -> Case:
    spec = study.brick_spec
    return parse_case(
        {
            "name": name,
            "engine": study.engine.value,
            "seed": study.seed,
            "time": {"duration": duration, "output_interval": min(output_interval, duration),
                     "stop_at_rest": rest.model_dump() if rest is not None else None, "safety_factor": safety_factor},
            "materials": [
                {"name": "brick", "density": spec.density},
                {"name": "board", "density": 1400.0},
                {"name": "box", "density": 1400.0},
            ],
            "contacts": contacts,
            "shapes": [spec.shape_entry()],
            "bodies": {"clumps": clumps},
            "walls": walls,
            **extra,
        },
        source=f"study {study.name}",
        fields={"shapes.0": "brick", **_STAGE_FIELDS[packing]},
    )


def first_packing_mu(study: AvalancheStudy) -> float:
    """μ brick/brick of the packing's first trial (AvalancheStudy.first_packing_mu)."""
    return study.first_packing_mu


def packing_case(study: AvalancheStudy, brick_brick_mu: float | None = None) -> Case:
    """Bricks rained (or stacked) into the closed box standing on its base and settled for
    `packing.settle_time`, with μ brick/brick `brick_brick_mu` (default: the first trial's).

    The box stands on its base as in the experiment before it was set on the slope: the packing runs
    in place, gravity along the slope's normal (geometry.packing_gravity), so the settled pile is a
    slab on the box's base, not a heap against the trap. Everything that shapes the packing is in
    this case, and nothing else: its hash is the packing's key, so studies that differ only after
    the opening (release contacts, duration) share it. LIGGGHTS saves its whole state at the end
    (clumps cannot be re-inserted exactly there).
    """
    positions, orientations, height = _initial_layout(study)
    clumps = [{"shape": "brick", "material": "brick", "position": p.tolist(), "orientation": q.tolist()} for p, q in zip(positions, orientations)]
    geometry = study.geometry.build()
    # The stacked pile is packed under a lid on the walls' top: bricks squeezed out of the partial top
    # layer's open edge stay in the box (without it, 6 of 10 244 rose above it and were still falling
    # when the settle ended). The rain starts above the box and needs none.
    walls = geometry.walls(trap_closed=True, wall_height=height, lid=study.packing.kind == "ordered_pile")
    mu = first_packing_mu(study) if brick_brick_mu is None else brick_brick_mu
    return _case(study, "packing", study.packing.settle_time, study.release.output_interval, study.packing.stop_at_rest,
                 _contacts(study.packing.contacts or study.contacts, mu), clumps, walls, study.packing.time_safety_factor,
                 packing=True, gravity=list(geometry.packing_gravity()), save_state=capabilities(study.engine).restart)


def release_case(study: AvalancheStudy, packed: Trajectory, state_file: Path | None) -> Case:
    """The flow: the settled bricks (last packing frame), vertical gravity, the trap gone, the box's
    own walls (its height) and the study's contacts.

    Bodies are listed as they were packed; LIGGGHTS starts from the packing's state file (contact
    history included), YADE rebuilds each clump at exactly that position, orientation and velocity
    (its contacts start afresh at the opening).
    """
    clumps = [
        {
            "shape": "brick",
            "material": "brick",
            "position": packed.position[-1, k].tolist(),
            "orientation": packed.orientation[-1, k].tolist(),
            "velocity": packed.velocity[-1, k].tolist(),
            "angular_velocity": packed.angular_velocity[-1, k].tolist(),
        }
        for k in range(packed.n_bodies)
    ]
    geometry = study.geometry.build()
    walls = geometry.walls(trap_closed=False)
    extra = {"initial_state": str(state_file.resolve())} if state_file is not None else {}
    # A brick may leave the boards over an edge (the experiment's boards end; its floor is not modelled):
    # it is dropped from the results and counted in the deposit (bodies_lost), not an error.
    return _case(study, study.name, study.release.duration, study.release.output_interval, study.release.stop_at_rest,
                 _contacts(study.contacts), clumps, walls, study.release.time_safety_factor, record_contacts=study.release.record_contacts,
                 lost_bodies="drop", gravity=list(geometry.release_gravity()), **extra)


def packing_key(study: AvalancheStudy) -> str:
    """Content address of the packing of `study` (its run id)."""
    return run_id(packing_case(study), build_stamp(study.engine.value))


def packing_state_file(study: AvalancheStudy, packing_dir: Path) -> Path | None:
    """The state file a release starts from (an engine with `restart`); None: the release rebuilds each
    clump exactly where the packing left it (its contacts start afresh at the opening)."""
    name = capabilities(study.engine).state_file
    return packing_dir / name if name is not None else None
