"""An avalanche study: pack bricks in the release box, open the trap, measure the deposit and front.

A study file (YAML) holds the geometry, the brick, the packing and the contacts; it expands into two
ordinary cases. The packing: bricks rained (or stacked) into the box with the trap closed and settled
for `packing.settle_time`; it is content-addressed (the hash of its case) and stored once under a
packings directory, so every study with the same packing inputs reuses it. The release: the packed
bricks with the trap gone flow for `release.duration`; its time starts at the opening.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from orchestrator.post import deposit, front
from orchestrator.studies.avalanche.geometry import AvalancheGeometry, apparent_density, brick_count, ordered_pile, pile_rows, rain_height, rain_positions
from orchestrator.bodies import BrickShape, ShapeKind
from orchestrator.shapes import BodyShape
from orchestrator.case import Case, CaseError, Name, Real, RestStop, Strict, parse_case
from orchestrator.engines import DEFAULT_ENGINE, Engine, RunOptions, capabilities
from orchestrator.results import Trajectory
from orchestrator.rundir import run_id, saved_case
from orchestrator.studies.base import StageProgress, StudyKind

SHARED_REFERENCE = Path(__file__).resolve().parents[4] / "shared" / "reference" / "reference.toml"
PACKAGED_REFERENCE = Path(__file__).resolve().parents[2] / "data" / "reference.toml"  # a copy, for installs without shared/


def reference_path() -> Path:
    """The reference numbers: $DEMORCH_REFERENCE, else the project's shared/reference, else the packaged copy."""
    if "DEMORCH_REFERENCE" in os.environ:
        return Path(os.environ["DEMORCH_REFERENCE"])
    return SHARED_REFERENCE if SHARED_REFERENCE.is_file() else PACKAGED_REFERENCE


class GeometrySpec(Strict):
    slope_deg: Real(unit="°", gt=0.0, lt=90.0) = 45.0
    launch_height: Real(unit="m", gt=0.0, le=100.0) = 1.0
    board_length: Real(unit="m", gt=0.0, le=100.0) = 3.0
    board_width: Real(unit="m", gt=0.0, le=100.0) = 4.0
    box_depth: Real(unit="m", gt=0.0, le=10.0) = 0.6
    box_width: Real(unit="m", gt=0.0, le=10.0) = 0.4
    box_height: Real(unit="m", gt=0.0, le=10.0) = 0.2

    def build(self) -> AvalancheGeometry:
        return AvalancheGeometry(**self.model_dump())


class BrickSpec(Strict):
    length: Real(unit="m", gt=0.0, le=1.0) = 0.031
    width: Real(unit="m", gt=0.0, le=1.0) = 0.015
    thickness: Real(unit="m", gt=0.0, le=1.0) = 0.008
    density: Real(unit="kg/m³", gt=0.0, le=1e5) = 1700.0
    layout: tuple[int, int, int] = (4, 2, 1)
    bevel_deg: Real(unit="°", ge=0.0, le=10.0) = 0.0  # the paper's modified bricks: 2.0 (three faces turned; see shapes/clump.py)
    # The study's brick has its edges and corners rounded at 1 mm: eight corner spheres of that radius
    # join the layout, and the brick gets the rounded solid's mass and inertia (shapes/clump.py). With them
    # the single-brick drops of the study are reproduced (tests/test_brick_drop.py). 0: a sharp box
    # (required with a bevel).
    rounding: Real(unit="m", ge=0.0, le=0.01) = 0.001
    # How the brick is realised (docs/bricks.md, "Kinds of brick"): `clump` (the layout above plus
    # corner spheres) or `superquadric` (LIGGGHTS: one body with flat faces, this blockiness).
    # Unset: the engine's preferred kind (AvalancheStudy.brick_spec), a clump when bevelled.
    kind: ShapeKind | None = None
    blockiness: tuple[Real(unit="1", ge=2.0, le=40.0), Real(unit="1", ge=2.0, le=40.0)] = (6.0, 6.0)

    @model_validator(mode="after")
    def _rounding_needs_a_box(self) -> "BrickSpec":
        if self.rounding and self.bevel_deg:
            raise ValueError(f"rounding: a bevelled brick has no corner spheres; allowed: 0 with bevel_deg > 0 (got {self.rounding!r})")
        return self

    def shape_entry(self, name: str = "brick") -> dict[str, object]:
        """The case's `shapes` entry of this brick (a clump when `kind` is unset)."""
        return {"name": name, "kind": self.kind or "clump", "length": self.length, "width": self.width, "thickness": self.thickness,
                "layout": list(self.layout), "bevel_deg": self.bevel_deg, "rounding": self.rounding, "blockiness": list(self.blockiness)}

    def build(self) -> BodyShape:
        return BrickShape(**self.shape_entry()).body(self.density)


class PairSpec(Strict):
    en2: Real(unit="1", gt=0.0, le=1.0)
    mu: Real(unit="1", ge=0.0, le=10.0)
    kn: Real(unit="N/m", gt=0.0, le=1e12)
    kt_over_kn: Real(unit="1", ge=0.0, le=10.0)


class ContactSpec(Strict):
    """Table 1 of Richefeu et al. (2012) by default; `box` is the release box (brick/box = brick/board)."""

    law: Literal["linear", "bilinear"] = "bilinear"
    brick_brick: PairSpec = PairSpec(en2=0.13, mu=0.86, kn=1e5, kt_over_kn=0.27)
    brick_board: PairSpec = PairSpec(en2=0.53, mu=0.46, kn=1e5, kt_over_kn=0.42)


class PackingSpec(Strict):
    kind: Literal["random_pour", "ordered_pile"] = "random_pour"
    volume: Real(unit="m³", gt=0.0, le=10.0) = 0.04  # m³ of pile at the apparent density below
    apparent_density: Real(unit="kg/m³", gt=0.0, le=1e4) | None = None  # default: 1000 (pour) or 1600 (pile)
    settle_time: Real(unit="s", gt=0.0, le=100.0) = 1.0
    # Set: settle_time is an upper bound and the packing ends once the bricks are at rest.
    stop_at_rest: RestStop | None = None
    # The paper changed contact parameters while packing to reach the target density, then restored
    # them. Default: the study's own contacts. Give them explicitly to share one packing across
    # studies (a campaign) that vary the contacts of the flow only.
    contacts: ContactSpec | None = None
    brick_brick_mu: Real(unit="1", ge=0.0, le=10.0) | None = None  # shortcut: only μ brick/brick differs while packing
    # Ordered pile only: turn each brick half a turn about a random axis, or not (the paper's flips).
    flips: bool = False

    @model_validator(mode="after")
    def _flips_need_a_pile(self) -> "PackingSpec":
        if self.flips and self.kind != "ordered_pile":
            raise ValueError("flips: only for kind ordered_pile (a random pour orients every brick at random already)")
        return self


class ReleaseSpec(Strict):
    duration: Real(unit="s", gt=0.0, le=1000.0) = 4.0
    output_interval: Real(unit="s", gt=0.0, le=10.0) = 0.02
    # Set: duration is an upper bound and the flow ends once the deposit is at rest (give `after`
    # > 0: the bricks are at rest in the box at the opening).
    stop_at_rest: RestStop | None = None
    # Record every contact of the flow at each frame (results.h5 /contacts; the report then draws the
    # deposit's force chains). Opt-in: it multiplies the output.
    record_contacts: bool = False


class AvalancheStudy(Strict):
    name: Name
    engine: Engine = Engine(DEFAULT_ENGINE)
    seed: int = Field(default=2009, ge=1, le=2**31 - 1)
    geometry: GeometrySpec = GeometrySpec()
    brick: BrickSpec = BrickSpec()
    contacts: ContactSpec = ContactSpec()
    packing: PackingSpec = PackingSpec()
    release: ReleaseSpec = ReleaseSpec()

    @model_validator(mode="after")
    def _packing_law(self) -> "AvalancheStudy":
        if self.packing.contacts is not None and self.packing.contacts.law != self.contacts.law:
            raise ValueError(
                f"packing.contacts.law: must be {self.contacts.law!r} like contacts.law "
                "(the flow continues the packing's contact history)"
            )
        return self

    @property
    def target_density(self) -> float:
        if self.packing.apparent_density is not None:
            return self.packing.apparent_density
        return 1000.0 if self.packing.kind == "random_pour" else 1600.0

    @property
    def brick_spec(self) -> BrickSpec:
        """The brick with its kind settled: as given, else the engine's preferred kind
        (capabilities.preferred_brick: the superquadric on LIGGGHTS, chosen by measurement,
        docs/bricks.md), a clump where that cannot be had (a bevelled brick)."""
        if self.brick.kind is not None:
            return self.brick
        preferred = capabilities(self.engine).preferred_brick
        return self.brick.model_copy(update={"kind": "clump" if self.brick.bevel_deg else preferred})

    @property
    def brick_count(self) -> int:
        return brick_count(self.packing.volume, self.target_density, self.brick_spec.build())


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


# Between neighbouring bricks of the ordered pile, each way (m). Every engine places a clump at its
# requested centre (within 1e-6 m, tests/test_initial_state.py), so the pile can be tight: 19 × 26
# bricks lie flat in the 0.6 × 0.4 m box, and the pile reads about 1607 kg/m³ × 31 / 31.2 × 15 / 15.2 =
# 1576 kg/m³ (apparent_density; 1607: the brick's mass over its 31 × 15 × 8 mm box times the share of
# the floor under the rows). Measured at full scale (ordered_pile_full.yaml): 1568 as laid, 1601 once
# the layers had settled onto each other; the experiment's: 1600.
PILE_GAP = 0.0002


def _initial_layout(study: AvalancheStudy) -> tuple[np.ndarray, np.ndarray, float]:
    """Where the bricks start (rain cells or the ordered pile) and the height of the box walls."""
    geometry, brick, count = study.geometry.build(), study.brick_spec.build(), study.brick_count
    if study.packing.kind == "random_pour":
        # 3 mm between the cells of the rain grid: part of the packing's definition (the recorded
        # packings of docs/validation.md use it), not a placement tolerance.
        positions, orientations = rain_positions(geometry, brick, count, study.seed, gap=0.003)
        return positions, orientations, max(geometry.box_height, rain_height(geometry, brick, count, gap=0.003))
    positions, orientations = ordered_pile(geometry, brick, count, gap=PILE_GAP, flip_seed=study.seed if study.packing.flips else None)
    rows, columns = pile_rows(geometry, brick, PILE_GAP)
    height = max(geometry.box_height, (count // (rows * columns) + 1) * (brick.extent[2] + PILE_GAP) + PILE_GAP)
    return positions, orientations, height


def _case(study: AvalancheStudy, name: str, duration: float, output_interval: float, rest: RestStop | None,
          contacts: list[dict[str, Any]], clumps: list[dict[str, Any]], walls: list[dict[str, object]], **extra: Any) -> Case:
    spec = study.brick_spec
    return parse_case(
        {
            "name": name,
            "engine": study.engine.value,
            "seed": study.seed,
            "time": {"duration": duration, "output_interval": min(output_interval, duration),
                     "stop_at_rest": rest.model_dump() if rest is not None else None},
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
    )


def packing_case(study: AvalancheStudy) -> Case:
    """Bricks rained (or stacked) into the closed box and settled for `packing.settle_time`.

    Everything that shapes the packing is in this case, and nothing else: its hash is the packing's
    key, so studies that differ only after the opening (release contacts, duration) share it.
    LIGGGHTS saves its whole state at the end (clumps cannot be re-inserted exactly there).
    """
    positions, orientations, height = _initial_layout(study)
    clumps = [{"shape": "brick", "material": "brick", "position": p.tolist(), "orientation": q.tolist()} for p, q in zip(positions, orientations)]
    walls = study.geometry.build().walls(trap_closed=True, wall_height=height)
    return _case(study, "packing", study.packing.settle_time, study.release.output_interval, study.packing.stop_at_rest,
                 _contacts(study.packing.contacts or study.contacts, study.packing.brick_brick_mu), clumps, walls, save_state=capabilities(study.engine).restart)


def release_case(study: AvalancheStudy, packed: Trajectory, state_file: Path | None) -> Case:
    """The flow: the settled bricks (last packing frame) with the trap gone and the study's contacts.

    Bodies are listed as they were packed; LIGGGHTS starts from the packing's state file (contact
    history included), YADE rebuilds each clump at exactly that position, orientation and velocity
    (its contacts start afresh at the opening).
    """
    _, _, height = _initial_layout(study)
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
    walls = study.geometry.build().walls(trap_closed=False, wall_height=height)
    extra = {"initial_state": str(state_file.resolve())} if state_file is not None else {}
    # A brick may leave the boards over an edge (the experiment's boards end; its floor is not modelled):
    # it is dropped from the results and counted in the deposit (bodies_lost), not an error.
    return _case(study, study.name, study.release.duration, study.release.output_interval, study.release.stop_at_rest,
                 _contacts(study.contacts), clumps, walls, record_contacts=study.release.record_contacts,
                 lost_bodies="drop", **extra)


def packing_key(study: AvalancheStudy) -> str:
    """Content address of the packing of `study` (its run id)."""
    return run_id(packing_case(study))


def packing_state_file(study: AvalancheStudy, packing_dir: Path) -> Path | None:
    """The state file a release starts from (an engine with `restart`); None: the release rebuilds each
    clump exactly where the packing left it (its contacts start afresh at the opening)."""
    name = capabilities(study.engine).state_file
    return packing_dir / name if name is not None else None


class AvalancheKind(StudyKind):
    """Bricks packed in the release box (the preparation), released down the slope, deposit and front measured."""

    name = "avalanche"
    model = AvalancheStudy
    detect_keys = frozenset({"packing", "release", "geometry", "brick"})
    preparation = "packing"
    shared_dir = "packings"
    lost_bodies = "some bricks left the box while settling; check the study geometry"
    # Under MPI, split the box across the flow (y): the set-up is symmetric about y = 0, so each process
    # gets half the bricks all along (measured: 1.74 × faster on 2 processes, against 1.13 × with the
    # default split along the boards, which left one process with the whole pile).
    processor_grid = "1 * 1"

    def preparation_case(self, study: AvalancheStudy) -> Case:
        return packing_case(study)

    def state_file(self, study: AvalancheStudy, directory: Path) -> Path | None:
        return packing_state_file(study, directory)

    def release_case(self, study: AvalancheStudy, prepared: Case, packed: Trajectory, state: Path | None) -> Case:
        return release_case(study, packed, state)

    def measure(self, study: AvalancheStudy, trajectory: Trajectory, release_dir: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        brick = study.brick_spec.build()
        report = measure(trajectory, brick, gravity=-saved_case(release_dir).gravity[2])
        density = apparent_density(study.geometry.build(), trajectory.position[0], trajectory.orientation[0], brick)
        report["packing"] = {"bricks": trajectory.n_bodies, "apparent_density": density, "target_apparent_density": study.target_density}
        return report, {}

    def metrics(self, report: dict[str, Any]) -> dict[str, float]:
        """deposit.*, front.*, packing density and the kinetic energy left, flat."""
        metrics = {f"deposit.{k}": float(v) for k, v in report["deposit"].items() if isinstance(v, (int, float))}
        metrics.update({f"front.{k}": float(v) for k, v in report["front"].items() if isinstance(v, (int, float))})
        metrics["packing.apparent_density"] = float(report["packing"]["apparent_density"])
        metrics["kinetic_to_released_energy"] = float(report["kinetic_to_released_energy"])
        return metrics


KIND = AvalancheKind()


def load_study(path: Path) -> AvalancheStudy:
    return KIND.load(path)


def run_study(
    study: AvalancheStudy,
    outdir: Path,
    progress: StageProgress | None = None,
    packings: Path | None = None,
    timeout: float | None = None,
    options: RunOptions | None = None,
) -> dict[str, Any]:
    """Pack (or reuse the packing from `packings`, default outdir/../packings), release, measure.

    A finished release in outdir/run is reused (rerun = report only). Returns the report, also
    written to outdir/report.json (studies.base.run_study).
    """
    return KIND.run(study, outdir, progress, packings, timeout, options)


def measure(trajectory: Trajectory, brick: BrickClump, first_frame: int = 0, gravity: float = 9.81) -> dict[str, Any]:
    """Deposit metrics on the last frame and the front curve from `first_frame` (the trap opening) on.

    gravity: m/s², the downward (−z) component of the case's gravity, for the released energy."""
    metrics = deposit.deposit_metrics(trajectory.position[first_frame], trajectory.position[-1], trajectory.mass, trajectory.radius)
    # The front is the leading brick among those that end in the deposit: the rule of R (deposit.py),
    # less the brick's bounding radius, so a group that runs ahead and leaves never holds it.
    time = trajectory.time[first_frame:] - trajectory.time[first_frame]
    members = deposit.deposit_members(trajectory.position[-1], trajectory.radius)
    position, velocity = front.front_curve(time, trajectory.position[first_frame:, :, 0], trajectory.mass, window=2 * brick.length,
                                           min_fraction=0.0, members=members)
    on_flat = position >= 0.0
    return {
        "deposit": metrics.as_dict(),
        "front": {
            "time": time.tolist(),
            "position": position.tolist(),
            "velocity": velocity.tolist(),
            "max_velocity": float(np.nanmax(velocity)),
            "max_velocity_on_flat": float(np.nanmax(velocity[on_flat])) if on_flat.any() else float("nan"),
            "final_position": float(position[-1]),
            "flat_phases": front.flat_phases(position, velocity),
        },
        "kinetic_to_released_energy": released_ratio(trajectory, first_frame, gravity),
    }


def released_ratio(trajectory: Trajectory, first_frame: int, gravity: float = 9.81) -> float:
    """Kinetic energy at the end over the potential energy released since `first_frame`: ~0 when stopped.

    gravity: m/s², the downward (−z) component of the case's gravity."""
    from orchestrator.post.summary import kinetic_energy

    released = gravity * float(np.nansum(trajectory.mass * (trajectory.position[first_frame, :, 2] - trajectory.position[-1, :, 2])))
    return float(kinetic_energy(trajectory)[-1] / released) if released > 0 else float("nan")


def load_reference() -> dict[str, Any]:
    path = reference_path()
    try:
        with open(path, "rb") as stream:
            return tomllib.load(stream)
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise CaseError(f"reference numbers: cannot read {path} ({error}); unset DEMORCH_REFERENCE to use the packaged copy") from None
