"""An avalanche study: pack bricks in the release box, open the trap, measure the deposit and front.

A study file (YAML) holds the geometry, the brick, the packing and the contacts; it expands into one
ordinary case: bricks rained (or stacked) into the box with the trap closed, settled for
`packing.settle_time`, then the trap wall is removed (`remove_at`) and the mass flows for
`release.duration`. Metrics use the frames from the opening on.
"""

from __future__ import annotations

import json
import os
import tomllib
from pathlib import Path
from typing import Any, Callable, Literal

import numpy as np
import yaml
from pydantic import Field, ValidationError

from . import deposit, front
from .avalanche import AvalancheGeometry, apparent_density, brick_count, ordered_pile, rain_height, rain_positions
from .bricks import BrickClump
from .case import Case, CaseError, Engine, Name, Real, Strict, _format_error, parse_case
from .results import Trajectory, read_results
from .runner import RESULTS, run_case

REFERENCE = Path(os.environ.get("DEMORCH_REFERENCE", Path(__file__).resolve().parents[2] / "shared" / "reference" / "reference.toml"))


class GeometrySpec(Strict):
    slope_deg: Real(gt=0.0, lt=90.0) = 45.0
    launch_height: Real(gt=0.0, le=100.0) = 1.0
    board_length: Real(gt=0.0, le=100.0) = 3.0
    board_width: Real(gt=0.0, le=100.0) = 4.0
    box_depth: Real(gt=0.0, le=10.0) = 0.6
    box_width: Real(gt=0.0, le=10.0) = 0.4
    box_height: Real(gt=0.0, le=10.0) = 0.2

    def build(self) -> AvalancheGeometry:
        return AvalancheGeometry(**self.model_dump())


class BrickSpec(Strict):
    length: Real(gt=0.0, le=1.0) = 0.031
    width: Real(gt=0.0, le=1.0) = 0.015
    thickness: Real(gt=0.0, le=1.0) = 0.008
    density: Real(gt=0.0, le=1e5) = 1700.0
    layout: tuple[int, int, int] = (4, 2, 1)

    def build(self) -> BrickClump:
        return BrickClump(self.length, self.width, self.thickness, self.density, self.layout)


class PairSpec(Strict):
    en2: Real(gt=0.0, le=1.0)
    mu: Real(ge=0.0, le=10.0)
    kn: Real(gt=0.0, le=1e12)
    kt_over_kn: Real(ge=0.0, le=10.0)


class ContactSpec(Strict):
    """Table 1 of Richefeu et al. (2012) by default; `box` is the release box (brick/box = brick/board)."""

    law: Literal["linear", "bilinear"] = "bilinear"
    brick_brick: PairSpec = PairSpec(en2=0.13, mu=0.86, kn=1e5, kt_over_kn=0.27)
    brick_board: PairSpec = PairSpec(en2=0.53, mu=0.46, kn=1e5, kt_over_kn=0.42)


class PackingSpec(Strict):
    kind: Literal["random_pour", "ordered_pile"] = "random_pour"
    volume: Real(gt=0.0, le=10.0) = 0.04  # m³ of pile at the apparent density below
    apparent_density: Real(gt=0.0, le=1e4) | None = None  # default: 1000 (pour) or 1600 (pile)
    settle_time: Real(gt=0.0, le=100.0) = 1.0
    # The paper changed contact parameters while packing to reach the target density, then restored them.
    brick_brick_mu: Real(ge=0.0, le=10.0) | None = None


class ReleaseSpec(Strict):
    duration: Real(gt=0.0, le=1000.0) = 4.0
    output_interval: Real(gt=0.0, le=10.0) = 0.02


class AvalancheStudy(Strict):
    name: Name
    engine: Engine = Engine.liggghts
    seed: int = Field(default=2009, ge=1, le=2**31 - 1)
    geometry: GeometrySpec = GeometrySpec()
    brick: BrickSpec = BrickSpec()
    contacts: ContactSpec = ContactSpec()
    packing: PackingSpec = PackingSpec()
    release: ReleaseSpec = ReleaseSpec()

    @property
    def target_density(self) -> float:
        if self.packing.apparent_density is not None:
            return self.packing.apparent_density
        return 1000.0 if self.packing.kind == "random_pour" else 1600.0

    @property
    def brick_count(self) -> int:
        return brick_count(self.packing.volume, self.target_density, self.brick.build())


def load_study(path: Path) -> AvalancheStudy:
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as error:
        raise CaseError(f"{path}: cannot read the study ({error})") from None
    try:
        return AvalancheStudy.model_validate(data)
    except ValidationError as error:
        raise CaseError(f"{path}: {_format_error(error)}") from None


def _contacts(study: AvalancheStudy, brick_brick_mu: float | None = None) -> list[dict[str, Any]]:
    law = study.contacts.law
    brick_brick = study.contacts.brick_brick.model_dump()
    if brick_brick_mu is not None:
        brick_brick["mu"] = brick_brick_mu
    board = study.contacts.brick_board.model_dump()
    return [
        {"materials": ["brick", "brick"], "law": law, **brick_brick},
        {"materials": ["brick", "board"], "law": law, **board},
        {"materials": ["brick", "box"], "law": law, **board},
    ]


def study_case(study: AvalancheStudy) -> Case:
    """The whole study as one case: rain (or stack) into the closed box, settle, open the trap, flow."""
    geometry, brick, count = study.geometry.build(), study.brick.build(), study.brick_count
    if study.packing.kind == "random_pour":
        # 3 mm between cells: LIGGGHTS places each clump within 1 mm of where it is asked to.
        positions, orientations = rain_positions(geometry, brick, count, study.seed, gap=0.003)
        height = max(geometry.box_height, rain_height(geometry, brick, count, gap=0.003))
    else:
        gap = 0.0025 if study.engine is Engine.liggghts else 0.0005  # LIGGGHTS places within 1 mm
        positions, orientations = ordered_pile(geometry, brick, count, gap=gap)
        height = max(geometry.box_height, (count // max(1, int(geometry.box_depth // (brick.length + gap)) * int(geometry.box_width // (brick.width + gap))) + 1) * (brick.thickness + gap) + gap)
    walls = geometry.walls(trap_closed=True, wall_height=height)
    for wall in walls:
        if wall["name"] == "trap":
            wall["remove_at"] = study.packing.settle_time
    spec = study.brick
    return parse_case(
        {
            "name": study.name,
            "engine": study.engine.value,
            "seed": study.seed,
            "time": {"duration": study.packing.settle_time + study.release.duration, "output_interval": study.release.output_interval},
            "materials": [
                {"name": "brick", "density": spec.density},
                {"name": "board", "density": 1400.0},
                {"name": "box", "density": 1400.0},
            ],
            "contacts": _contacts(study, study.packing.brick_brick_mu),
            "shapes": [{"name": "brick", "length": spec.length, "width": spec.width, "thickness": spec.thickness, "layout": list(spec.layout)}],
            "bodies": {
                "clumps": [
                    {"shape": "brick", "material": "brick", "position": p.tolist(), "orientation": q.tolist()}
                    for p, q in zip(positions, orientations)
                ]
            },
            "walls": walls,
        },
        source=f"study {study.name}",
    )


def release_frame(trajectory: Trajectory, study: AvalancheStudy) -> int:
    """Index of the frame at which the trap opens."""
    return int(np.argmin(np.abs(trajectory.time - study.packing.settle_time)))


def run_study(
    study: AvalancheStudy,
    outdir: Path,
    progress: Callable[[str], Callable[[float, float], None] | None] | None = None,
) -> dict[str, Any]:
    """Run the study (or reuse a finished run in outdir/run) and measure it. Returns the report."""
    outdir.mkdir(parents=True, exist_ok=True)
    geometry, brick = study.geometry.build(), study.brick.build()
    rundir = outdir / "run"
    if not (rundir / RESULTS).exists():
        run_case(study_case(study), outdir, rundir, progress=progress("avalanche") if progress else None)
    trajectory = read_results(rundir / RESULTS)
    opening = release_frame(trajectory, study)
    packed = trajectory.position[opening]
    inside = np.isfinite(packed).all(axis=1)
    density = apparent_density(geometry, packed[inside], trajectory.orientation[opening][inside], brick)
    report = measure(trajectory, brick, first_frame=opening)
    report["packing"] = {"bricks": int(inside.sum()), "apparent_density": density, "target_apparent_density": study.target_density}
    report["study"] = study.model_dump(mode="json")
    (outdir / "report.json").write_text(json.dumps(report, indent=2) + "\n")
    return report


def measure(trajectory: Trajectory, brick: BrickClump, first_frame: int = 0) -> dict[str, Any]:
    """Deposit metrics on the last frame and the front curve from `first_frame` (the trap opening) on."""
    metrics = deposit.deposit_metrics(trajectory.position[first_frame], trajectory.position[-1], trajectory.mass, trajectory.radius)
    # At least 1 % of the mass and at least three bricks must stand at the front.
    share = max(0.01, 3.0 / trajectory.n_bodies)
    time = trajectory.time[first_frame:] - trajectory.time[first_frame]
    position, velocity = front.front_curve(time, trajectory.position[first_frame:, :, 0], trajectory.mass, window=2 * brick.length, min_fraction=share)
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
        },
        "kinetic_to_released_energy": released_ratio(trajectory, first_frame),
    }


def released_ratio(trajectory: Trajectory, first_frame: int) -> float:
    """Kinetic energy at the end over the potential energy released since `first_frame`: ~0 when stopped."""
    from .metrics import kinetic_energy

    released = 9.81 * float(np.nansum(trajectory.mass * (trajectory.position[first_frame, :, 2] - trajectory.position[-1, :, 2])))
    return float(kinetic_energy(trajectory)[-1] / released) if released > 0 else float("nan")


def load_reference() -> dict[str, Any]:
    with open(REFERENCE, "rb") as stream:
        return tomllib.load(stream)
