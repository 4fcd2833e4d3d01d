"""A granular column collapse on an inclined channel, with an optional erodible bed (Martin et al. 2022).

A collapse study file (YAML) describes the column, the channel, the grains and the bed; it expands
into two ordinary cases:

- the **preparation**: grains rained under gravity normal to the bed (so that a frictionless rain
  stays put whatever the slope) into the column behind a gate and, downstream of the gate, onto the
  rough bed (one layer of glued grains) for the erodible layer. Its friction is `preparation.mu`
  (0: compact, 0.3: loose, as in the study). It is content-addressed and reused across a campaign;
- the **release**: the prepared grains, levelled to the column height H0 and the bed thickness h_i
  (grains whose centre lies above are removed, as a scraper would), at rest, with the gate gone and
  gravity tilted to the slope α. The gate is not modelled as a moving wall: as in the study's
  simulations the column is released at once.

Frame: x runs down the channel (the gate at x = 0, the column over -R0 ≤ x ≤ 0), z is normal to the
bed (the base plane at z = 0, the glued grains on it), y across (the channel spans |y| ≤ W/2 in 3D;
in 2D every grain has y = 0 and moves in the x-z plane). Heights H0 and h_i are measured from the
top of the rough layer, z_b = one mean grain diameter.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field, model_validator

from orchestrator.case import Name, Real, Strict, parse_model, read_yaml
from orchestrator.engines import DEFAULT_ENGINE, Engine
from orchestrator.engine_sections import StudyEngineSections
from orchestrator.studies.collapse.fields import FieldsSpec
from orchestrator.studies.seeds import Seeds, member_seeds

GRAIN, WALL = "grain", "wall"  # one grain material: the rough bed's grains are glued grains (`fixed`)


class ColumnSpec(Strict):
    length: Real(unit="m", gt=0.0, le=10.0) = 0.10  # R0, m
    height: Real(unit="m", gt=0.0, le=10.0) = 0.07  # H0, m
    width: Real(unit="m", gt=0.0, le=10.0) = 0.008  # W, m: the channel width (3D only); the study's reduced 3D set-up


class ChannelSpec(Strict):
    slope_deg: Real(unit="°", ge=0.0, le=45.0) = 22.0
    length: Real(unit="m", gt=0.0, le=100.0) = 0.6  # m downstream of the gate; an end wall closes it


class GrainSpec(Strict):
    diameter: Real(unit="m", gt=0.0, le=1.0) = 0.002  # mean, m
    polydispersity: Real(unit="1", ge=0.0, le=0.5) = 0.1  # diameters uniform in d (1 ± p)
    density: Real(unit="kg/m³", gt=0.0, le=1e5) = 2500.0


class BedSpec(Strict):
    erodible_thickness: Real(unit="m", ge=0.0, le=1.0) = 0.0  # h_i, m, above the rough layer
    # The glued layer (3D): "rows" of touching grains (the calibrated default: every figure in the
    # docs/studies/collapse.md), or "random", a dense random monolayer like glued beads, without the straight gutters
    # between rows that grains roll down (see `rough_bed`).
    glued: Literal["rows", "random"] = "rows"


class CollapseContacts(Strict):
    """Linear spring-dashpot contacts (stock in both engines)."""

    # Grain/grain, also grain/glued grain. 0.3: the study's 3D value, and what the horizontal
    # calibration finds for the default 3D column (ΔL/L0 = 0.86 against 1.2 a = 0.84).
    mu: Real(unit="1", ge=0.0, le=10.0) = 0.3
    mu_wall: Real(unit="1", ge=0.0, le=10.0) | None = None  # grain/wall (base plane, side and end walls); None: = mu
    en2: Real(unit="1", gt=0.0, le=1.0) = 0.25
    kn: Real(unit="N/m", gt=0.0, le=1e12) = 1000.0  # N/m: overlaps ≈ 0.1 % of d at rest in the 7 cm column, ≈ 4 % in 1 m/s impacts
    kt_over_kn: Real(unit="1", ge=0.0, le=10.0) = 0.4


class PreparationSpec(Strict):
    mu: Real(unit="1", ge=0.0, le=10.0) = 0.0  # 0: compact column, 0.3: loose (as in the study)
    settle_time: Real(unit="s", gt=0.0, le=100.0) = 0.4


class CollapseRelease(Strict):
    duration: Real(unit="s", gt=0.0, le=1000.0) = 2.0
    output_interval: Real(unit="s", gt=0.0, le=10.0) = 0.01


class CollapseStudy(StudyEngineSections, Strict):
    """One collapse: the column, channel, grains, bed, contacts, preparation and release."""

    name: Name = "collapse"
    engine: Engine = Engine(DEFAULT_ENGINE)
    seed: Annotated[int, Field(ge=1, le=2**31 - 1)] = 2022
    seeds: Seeds = None  # an ensemble: a count of seeds from `seed` on, or a list (studies/seeds.py)
    # 3: a channel between side walls (the quasi-2D set-up of the scaling law and of the study's
    # reduced 3D runs). 2: grains in one plane, ≈ 5 × cheaper; its runout hardly depends on μ
    # (free rolling) and overshoots the law (see docs/studies/collapse.md).
    dimension: Literal[2, 3] = 3
    column: ColumnSpec = ColumnSpec()
    channel: ChannelSpec = ChannelSpec()
    grains: GrainSpec = GrainSpec()
    bed: BedSpec = BedSpec()
    contacts: CollapseContacts = CollapseContacts()
    preparation: PreparationSpec = PreparationSpec()
    release: CollapseRelease = CollapseRelease()
    fields: FieldsSpec = FieldsSpec()  # where the depth profiles and the erosion waves are read
    # Δt = safety_factor × the shortest contact duration: 20 steps per contact. Halving it moved the
    # default runout by less than the grain size (see docs/studies/collapse.md).
    time_safety_factor: Real(unit="1", ge=1e-3, le=0.1) = 0.05  # as a case's time.safety_factor: at most 0.1
    # The sections one engine reads (its solver, the step of an implicit engine) come from StudyEngineSections.

    @model_validator(mode="after")
    def _fits(self) -> "CollapseStudy":
        d = self.grains.diameter
        if self.dimension == 3 and self.column.width < 2.0 * d:
            raise ValueError(f"column.width: must hold at least two grains across (≥ {2 * d} m) in 3D")
        if self.column.height < 2.0 * d or self.column.length < 2.0 * d:
            raise ValueError(f"column: length and height must be at least two grain diameters ({2 * d} m)")
        if self.bed.glued == "random" and self.dimension == 2:
            raise ValueError("bed.glued: 'random' needs dimension 3 (a plane holds one row of grains)")
        if self.fields.stations and max(self.fields.stations) * self.column.length > self.channel.length:
            raise ValueError(f"fields.stations: at most channel.length / column.length ({self.channel.length / self.column.length:g}) R0 past the gate")
        if 0.0 < self.bed.erodible_thickness < 0.5 * d:
            raise ValueError(f"bed.erodible_thickness: 0, or at least half a grain diameter ({0.5 * d} m)")
        member_seeds(self.seed, self.seeds)
        return self

    @property
    def bed_top(self) -> float:
        """z of the top of the rough layer, where H0 and h_i are measured from."""
        return self.grains.diameter

    @property
    def channel_width(self) -> float:
        """Across the channel: W in 3D, one grain diameter (the plane's thickness) in 2D."""
        return self.column.width if self.dimension == 3 else self.grains.diameter


def load_collapse(path: Path) -> CollapseStudy:
    return parse_collapse(read_yaml(path, "collapse study"), source=str(path))


def parse_collapse(data: object, source: str = "study") -> CollapseStudy:
    return parse_model(CollapseStudy, data if data is not None else {}, source)
