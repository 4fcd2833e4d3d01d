"""The avalanche study file: its fields, ranges and defaults, and the checks across them.

A study file (YAML) holds the geometry (Manzella & Labiouse 2009's boards and release box), the brick,
the contacts (Table 1 of Richefeu et al. 2012 by default), the packing and the release; `cases.py`
expands it into the packing and release cases.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal

from pydantic import Field, model_validator

from orchestrator.bodies import MIN_SIZE, Brick, BrickShape, ShapeKind
from orchestrator.case import Name, Real, RestStop, Strict
from orchestrator.capabilities import refused_kinds
from orchestrator.engines import DEFAULT_ENGINE, ENGINE_NAMES, Engine, capabilities
from orchestrator.shapes import BodyShape
from orchestrator.studies.seeds import Seeds, member_seeds
from orchestrator.studies.avalanche.geometry import AvalancheGeometry, brick_count

# Between the cells of the rain grid (m): part of the packing's definition (the recorded packings of
# docs/validation.md use it), not a placement tolerance.
RAIN_GAP = 0.003

# Between neighbouring bricks of the ordered pile, each way (m). Every engine places a clump at its
# requested centre (within 1e-6 m, tests/test_initial_state.py), so the pile can be tight: 19 × 26
# bricks lie flat in the 0.6 × 0.4 m box, and the pile reads about 1607 kg/m³ × 31 / 31.2 × 15 / 15.2 =
# 1576 kg/m³ (apparent_density; 1607: the brick's mass over its 31 × 15 × 8 mm box times the share of
# the floor under the rows); the experiment's: 1600. At full scale the pile settles onto that
# (docs/studies/avalanche.md, packing density).
PILE_GAP = 0.0002

DEMO_STUDY = Path(__file__).resolve().parents[3] / "cases" / "avalanche" / "small.yaml"  # `demorch demo`: 96 bricks, about a minute



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


class BrickSpec(Brick):
    """A study's brick: the one brick schema (bodies.Brick) at the 2012 study's brick by default, with
    its density; `kind` unset is the engine's preferred kind (AvalancheStudy.brick_spec), a clump when
    bevelled (docs/bricks.md, "Kinds of brick")."""

    kind: ShapeKind | None = None
    length: Real(unit="m", ge=MIN_SIZE, le=1.0) = 0.031
    width: Real(unit="m", ge=MIN_SIZE, le=1.0) = 0.015
    thickness: Real(unit="m", ge=MIN_SIZE, le=1.0) = 0.008
    bevel_deg: Real(unit="°", ge=0.0, le=10.0) = 0.0  # the paper's modified bricks: 2.0 (three faces turned; see shapes/clump.py)
    # The study's brick has its edges and corners rounded at 1 mm: eight corner spheres of that radius
    # join the layout, and the brick gets the rounded solid's mass and inertia (shapes/rigid.py). With them
    # the single-brick drops of the study are reproduced (tests/test_brick_drop.py). 0: a sharp box
    # (required with a bevel).
    rounding: Real(unit="m", ge=0.0, le=0.01) = 0.001
    density: Real(unit="kg/m³", gt=0.0, le=1e5) = 1700.0

    def shape_entry(self, name: str = "brick") -> dict[str, object]:
        """The case's `shapes` entry of this brick (a clump when `kind` is unset)."""
        return self.entry(name)

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


class DensitySearchSpec(Strict):
    """How the packing reaches its apparent density: μ brick/brick while packing varies within
    `mu_bounds`, a whole packing per trial, until the pile is within `tolerance` of the target
    (`density.py`). `max_trials: 1` packs once with the given contacts."""

    tolerance: Real(unit="1", gt=0.0, le=0.5) = 0.02
    max_trials: int = Field(default=4, ge=1, le=12)
    mu_bounds: tuple[Real(unit="1", ge=0.0, le=10.0), Real(unit="1", ge=0.0, le=10.0)] = (0.0, 2.0)

    @model_validator(mode="after")
    def _ordered_bounds(self) -> "DensitySearchSpec":
        if not self.mu_bounds[0] < self.mu_bounds[1]:
            raise ValueError(f"mu_bounds: the lower bound must be below the upper; allowed: 0 ≤ low < high ≤ 10 (got {list(self.mu_bounds)})")
        return self


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
    brick_brick_mu: Real(unit="1", ge=0.0, le=10.0) | None = None  # shortcut: only μ brick/brick differs while packing (the search's first trial)
    # The packing's Δt as a fraction of the shortest contact duration (a case's time.safety_factor).
    # Default: the engine's, as in the release. The packing only makes the initial state (its
    # density and fabric are what the release sees), so it may run at a coarser step than the flow;
    # docs/bricks.md gives the measured case (rounded boxes packed at the superquadric's step).
    time_safety_factor: Real(unit="1", ge=1e-3, le=0.1) | None = None  # as time.safety_factor: at most 0.1
    density_search: DensitySearchSpec = DensitySearchSpec()
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
    # The flow's Δt as a fraction of the shortest contact duration (a case's time.safety_factor).
    # Default: the engine's (0.02 on LIGGGHTS: 50 steps per contact). The step study of
    # docs/benchmarks.md measures deposits and a brick's rebound at 1×, 1.5× and 2× it.
    time_safety_factor: Real(unit="1", ge=1e-3, le=0.1) | None = None  # as time.safety_factor: at most 0.1


class AvalancheStudy(Strict):
    name: Name
    engine: Engine = Engine(DEFAULT_ENGINE)
    seed: int = Field(default=2009, ge=1, le=2**31 - 1)
    # An ensemble: a count of seeds from `seed` on, or a list; each seed is packed and released on
    # its own, and the report gives each seed, the mean and the range (studies/seeds.py).
    seeds: Seeds = None
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

    @model_validator(mode="after")
    def _engine_takes_brick(self) -> "AvalancheStudy":
        """The brick's kind on the study's engine, with the study's own fields named, before any engine starts."""
        kind, engine = self.brick_spec.kind, self.engine.value
        can = capabilities(engine)
        if not can.clumps:
            raise ValueError(f"engine: {engine} takes spheres only, not bricks; engines that can: "
                             f"{', '.join(name for name in ENGINE_NAMES if capabilities(name).clumps)}")
        if kind not in can.shape_kinds:
            able = [name for name in ENGINE_NAMES if kind in capabilities(name).shape_kinds]
            raise ValueError(f"brick.kind: {engine} takes {', '.join(can.shape_kinds)} bricks, not {kind}; engines that can: {', '.join(able)}")
        refused = refused_kinds(engine, self.contacts.law, self.release.record_contacts).get(str(kind))
        if refused == "record_contacts":
            raise ValueError(f"release.record_contacts: {engine} does not record the contacts of {kind} bricks; allowed: false "
                             f"(or a brick.kind that records them: {', '.join(k for k in can.shape_kinds if k not in can.unrecorded_kinds)})")
        if refused == "contacts.law":
            raise ValueError(f"contacts.law: {kind} bricks touch by the bilinear law of Richefeu et al. (2012) only on {engine}; "
                             f"allowed: bilinear (got {self.contacts.law})")
        return self

    @model_validator(mode="after")
    def _denser_than_bricks(self) -> "AvalancheStudy":
        """A pile of bricks cannot be denser than the bricks: apparent density = solid fraction × brick density."""
        if self.target_density >= self.brick.density:
            raise ValueError(f"packing.apparent_density: {self.target_density:g} kg/m³ is not below the bricks' own density "
                             f"({self.brick.density:g} kg/m³, brick.density); allowed: below {self.brick.density:g} (the experiment's "
                             "random pour: 1000, its ordered pile: 1576)")
        return self

    @model_validator(mode="after")
    def _first_trial_in_bounds(self) -> "AvalancheStudy":
        """A density search's first trial (μ brick/brick while packing) lies within its bounds."""
        search, packing = self.packing.density_search, self.packing
        if search.max_trials == 1:
            return self
        mu = self.first_packing_mu
        low, high = search.mu_bounds
        if not low <= mu <= high:
            field = ("packing.brick_brick_mu" if packing.brick_brick_mu is not None
                     else "packing.contacts.brick_brick.mu" if packing.contacts is not None else "contacts.brick_brick.mu")
            raise ValueError(f"{field}: {mu:g} starts the density search outside packing.density_search.mu_bounds [{low:g}, {high:g}]; "
                             f"allowed: within them (or widen the bounds, or set packing.density_search.max_trials: 1 to pack once)")
        return self

    @model_validator(mode="after")
    def _seeds_fit(self) -> "AvalancheStudy":
        member_seeds(self.seed, self.seeds)
        return self

    @model_validator(mode="after")
    def _box_fits(self) -> "AvalancheStudy":
        """The box must sit on the slope board, hold the packing's volume and at least two bricks each
        way on its floor (a rain cell is a brick's bounding diameter and RAIN_GAP; a pile's cell a
        brick and PILE_GAP), and be as high as a brick is thick."""
        g, brick = self.geometry, self.brick_spec.build()
        if g.launch_height / math.sin(math.radians(g.slope_deg)) + g.box_depth > g.board_length:
            raise ValueError(f"geometry.box_depth: the box ({g.box_depth!r} m up the slope from the trap, "
                             f"{g.launch_height / math.sin(math.radians(g.slope_deg)):.3g} m from the toe) runs past the slope board's top "
                             f"end ({g.board_length!r} m); allowed: launch_height / sin(slope_deg) + box_depth ≤ board_length")
        if g.box_width > g.board_width:
            raise ValueError(f"geometry.box_width: {g.box_width!r} m is wider than the boards ({g.board_width!r} m); allowed: at most board_width")
        capacity = g.box_depth * g.box_width * g.box_height
        if self.packing.volume > capacity:
            raise ValueError(f"packing.volume: {self.packing.volume!r} m³ does not fit the box ({capacity:.4g} m³: box_depth × box_width × "
                             f"box_height); allowed: at most {capacity:.4g} m³ (the experiment's 40 l fill 40 of its 48 l)")
        if self.brick_count < 1:
            raise ValueError(f"packing.volume: {self.packing.volume!r} m³ at {self.target_density:g} kg/m³ is less than one brick "
                             f"({brick.mass * 1e3:.3g} g); allowed: at least {brick.mass / self.target_density:.3g} m³")
        if self.packing.kind == "random_pour":
            cell = 2.0 * brick.bounding_radius + RAIN_GAP
            need = {"box_depth": 2 * cell, "box_width": 2 * cell, "box_height": float(brick.extent[2])}
        else:
            need = {"box_depth": 2 * (brick.extent[0] + PILE_GAP), "box_width": 2 * (brick.extent[1] + PILE_GAP),
                    "box_height": float(brick.extent[2]) + 2 * PILE_GAP}
        for name, least in need.items():
            if getattr(g, name) < least:
                raise ValueError(f"geometry.{name}: {getattr(g, name)!r} m holds less than {'two bricks' if name != 'box_height' else 'one brick'} "
                                 f"of {'a random pour' if self.packing.kind == 'random_pour' else 'an ordered pile'} ({least:.4g} m); allowed: at least {least:.4g} m")
        return self

    @property
    def first_packing_mu(self) -> float:
        """μ brick/brick of the packing's first trial: `packing.brick_brick_mu`, else the packing's contacts'."""
        if self.packing.brick_brick_mu is not None:
            return self.packing.brick_brick_mu
        return (self.packing.contacts or self.contacts).brick_brick.mu

    @property
    def target_density(self) -> float:
        if self.packing.apparent_density is not None:
            return self.packing.apparent_density
        return 1000.0 if self.packing.kind == "random_pour" else 1600.0

    @property
    def brick_spec(self) -> BrickSpec:
        """The brick with its kind settled: as given, else the engine's preferred kind
        (capabilities.preferred_brick: the rounded box on LIGGGHTS, chosen by measurement,
        docs/bricks.md), else the first of its fallbacks the study's settings allow (the
        superquadric for a linear law or recorded contacts), a clump where none can be had (a
        bevelled brick)."""
        if self.brick.kind is not None:
            return self.brick
        can = capabilities(self.engine)
        refused = refused_kinds(self.engine, self.contacts.law, self.release.record_contacts)
        usable = [kind for kind in (can.preferred_brick, *can.brick_fallbacks) if kind not in refused and not self.brick.bevel_deg]
        return self.brick.model_copy(update={"kind": usable[0] if usable else "clump"})

    @property
    def brick_count(self) -> int:
        return brick_count(self.packing.volume, self.target_density, self.brick_spec.build())
