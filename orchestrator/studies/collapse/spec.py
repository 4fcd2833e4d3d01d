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

import math
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, model_validator
from scipy.spatial import cKDTree

from orchestrator.case import Case, CaseError, Name, Real, Strict, parse_case, parse_model, read_yaml
from orchestrator.engines import DEFAULT_ENGINE, Engine, capabilities
from orchestrator.engine_sections import StudyEngineSections
from orchestrator.results import Trajectory
from orchestrator.studies.collapse.fields import FieldsSpec

GRAIN, WALL = "grain", "wall"  # one grain material: the rough bed's grains are glued grains (`fixed`)
# Solid fraction of a frictionless rain, used only to size the rain (the column is levelled after):
# spheres in a plane cover ≈ 0.82 of it, a 3D random packing ≈ 0.62.
RAIN_FRACTION = {2: 0.82, 3: 0.62}
OVERFILL = 1.2  # rain 20 % more than needed, so levelling always has grains to remove
# The 3D rough bed: discs cover 75 % of the base. A random monolayer of 10 % polydisperse discs in
# the default strip (4 grains wide) relaxes to overlaps of 1 % of d in about a second; at 78 % it
# takes 6 s, and at 72 % a grain finds a hole down to the base plane on 3e-4 of the bed (4e-5 here).
BED_COVER = 0.75
BED_GROWTH_STEPS = 200  # sweeps from 30 % to full size
BED_MAX_SWEEPS = 3000  # then relax until BED_OVERLAP, or stop here (fixed grains may overlap)
BED_OVERLAP = 0.01


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
    time_safety_factor: Real(unit="1", gt=0.0, le=0.5) = 0.05
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


# -- grains ---------------------------------------------------------------------------------------


def grain_radii(study: CollapseStudy, count: int, rng: np.random.Generator) -> np.ndarray:
    """Radii uniform in d (1 ± p) / 2."""
    d, p = study.grains.diameter, study.grains.polydispersity
    return 0.5 * d * rng.uniform(1.0 - p, 1.0 + p, size=count)


def rough_bed(study: CollapseStudy, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(centres, radii) of the glued grains on the base plane, under the whole channel.

    "rows": touching rows along x, staggered by d/4 (one row in 2D). "random" (3D): a random dense
    monolayer (`random_monolayer`). Rows leave straight gutters between them: at 22° grains roll
    down them one by one (docs/studies/collapse.md).
    """
    d = study.grains.diameter
    start, end = -study.column.length, study.channel.length
    if study.dimension == 3 and study.bed.glued == "random":
        return random_monolayer(study, (start, end), study.column.width / 2, rng)
    rows = [0.0] if study.dimension == 2 else list(np.arange(-study.column.width / 2 + d / 2, study.column.width / 2 - d / 4, d))
    centres, radii = [], []
    for row, y in enumerate(rows):
        x = start + (0.25 * d if row % 2 else 0.0)  # stagger the rows
        while True:
            r = float(grain_radii(study, 1, rng)[0])
            if x + 2.0 * r > end:
                break
            centres.append((x + r, y, r))
            radii.append(r)
            x += 2.0 * r
    return np.array(centres), np.array(radii)


def random_monolayer(study: CollapseStudy, x_range: tuple[float, float], half_width: float,
                     rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(centres, radii) of grains covering BED_COVER of the strip x_range × |y| ≤ half_width, on z = 0.

    The discs start at random places at 30 % of their size and grow to full size while overlaps are
    pushed apart (a growth relaxation: uniform, unlike relaxing at full size from random places,
    which leaves holes a grain can drop through). Glued grains do not interact, so overlaps of up to
    BED_OVERLAP × d left at the end are harmless.
    """
    d = study.grains.diameter
    (x0, x1), p = x_range, study.grains.polydispersity
    mean_area = math.pi * (d / 2) ** 2 * (1.0 + p**2 / 3.0)
    count = max(1, int(BED_COVER * (x1 - x0) * 2 * half_width / mean_area))
    radii = grain_radii(study, count, rng)  # the study's validation keeps W ≥ 2 d
    # One disc per slice of the strip, at a random place in it: evenly spread along x from the start,
    # since the relaxation cannot move a crowd of discs far along a narrow strip.
    slices = x0 + (np.arange(count) + rng.uniform(0.0, 1.0, count)) * (x1 - x0) / count
    xy = np.column_stack([np.clip(slices, x0 + radii, x1 - radii), rng.uniform(-half_width + radii, half_width - radii)])
    for step in range(BED_MAX_SWEEPS):
        scale = min(1.0, 0.3 + 0.7 * step / BED_GROWTH_STEPS)
        overlap = _push_apart(xy, radii * scale, (x0, x1), half_width)
        if scale == 1.0 and overlap < BED_OVERLAP * d:
            break
    return np.column_stack([xy, radii]), radii


def _push_apart(xy: np.ndarray, radii: np.ndarray, x_range: tuple[float, float], half_width: float) -> float:
    """One relaxation sweep in place: each overlapping pair moves apart by its overlap; discs stay in
    the strip. Returns the largest overlap before the sweep."""
    pairs = cKDTree(xy).query_pairs(2.0 * float(radii.max()), output_type="ndarray")
    largest = 0.0
    if len(pairs):
        i, j = pairs[:, 0], pairs[:, 1]
        delta = xy[j] - xy[i]
        distance = np.maximum(np.linalg.norm(delta, axis=1), 1e-12 * float(radii.max()))
        overlap = radii[i] + radii[j] - distance
        hit = overlap > 0.0
        if hit.any():
            largest = float(overlap[hit].max())
            push = (0.5 * overlap[hit] / distance[hit])[:, None] * delta[hit]
            np.add.at(xy, i[hit], -push)
            np.add.at(xy, j[hit], push)
    xy[:, 0] = np.clip(xy[:, 0], x_range[0] + radii, x_range[1] - radii)
    xy[:, 1] = np.clip(xy[:, 1], -half_width + radii, half_width - radii)
    return largest


def rain_lattice(study: CollapseStudy, x_range: tuple[float, float], count: int, rng: np.random.Generator) -> np.ndarray:
    """`count` grain centres on a loose jittered lattice over x_range, rising from above the rough layer."""
    d_max = study.grains.diameter * (1.0 + study.grains.polydispersity)
    spacing = 1.15 * d_max
    xs = np.arange(x_range[0] + spacing / 2, x_range[1] - spacing / 2 + 1e-12, spacing)
    if study.dimension == 2:
        ys = np.array([0.0])
    else:
        half = study.column.width / 2
        ys = np.arange(-half + spacing / 2, half - spacing / 2 + 1e-12, spacing)
    if len(xs) == 0 or len(ys) == 0:
        raise CaseError("grains.diameter: too large for the column or channel")
    per_layer = len(xs) * len(ys)
    layers = math.ceil(count / per_layer)
    z0 = study.bed_top + spacing / 2 + 0.1 * d_max
    grid = np.array([(x, y, z0 + k * spacing) for k in range(layers) for y in ys for x in xs])[:count]
    jitter = 0.05 * d_max * rng.uniform(-1.0, 1.0, size=grid.shape)
    if study.dimension == 2:
        jitter[:, 1] = 0.0
    return grid + jitter


def rain_counts(study: CollapseStudy) -> tuple[int, int]:
    """Grains to rain into the column and onto the bed (OVERFILL × what the levelled volumes hold)."""
    d = study.grains.diameter
    mean_measure = math.pi * d**2 / 4.0 if study.dimension == 2 else math.pi * d**3 / 6.0
    width = 1.0 if study.dimension == 2 else study.column.width
    fraction = RAIN_FRACTION[study.dimension]
    column = study.column.length * study.column.height * width * fraction / mean_measure
    bed = study.channel.length * study.bed.erodible_thickness * width * fraction / mean_measure
    return math.ceil(OVERFILL * column), math.ceil(OVERFILL * bed) if bed > 0 else 0


# -- cases ----------------------------------------------------------------------------------------


def walls(study: CollapseStudy, gate: bool, height: float) -> list[dict[str, Any]]:
    """Base plane, back wall, end wall, the gate (preparation only) and, in 3D, the side walls."""
    r0, length = study.column.length, study.channel.length
    span = r0 + length
    # 2D: the walls only need some width across the grains' plane, but LIGGGHTS rejects meshes with
    # needle-like triangles (a 0.9 m × 4 mm base failed): keep them at least 1/40 of the span wide.
    half = study.column.width / 2 if study.dimension == 3 else max(study.grains.diameter, span / 40)
    result: list[dict[str, Any]] = [
        {"type": "rectangle", "name": "base", "material": WALL, "origin": [-r0, -half, 0.0], "edge1": [span, 0.0, 0.0], "edge2": [0.0, 2 * half, 0.0]},
        {"type": "rectangle", "name": "back", "material": WALL, "origin": [-r0, -half, 0.0], "edge1": [0.0, 2 * half, 0.0], "edge2": [0.0, 0.0, height]},
        {"type": "rectangle", "name": "end", "material": WALL, "origin": [length, -half, 0.0], "edge1": [0.0, 2 * half, 0.0], "edge2": [0.0, 0.0, height]},
    ]
    if gate:
        result.append({"type": "rectangle", "name": "gate", "material": WALL, "origin": [0.0, -half, 0.0], "edge1": [0.0, 2 * half, 0.0], "edge2": [0.0, 0.0, height]})
    if study.dimension == 3:
        result += [
            {"type": "rectangle", "name": f"side_{side}", "material": WALL, "origin": [-r0, y, 0.0], "edge1": [span, 0.0, 0.0], "edge2": [0.0, 0.0, height]}
            for side, y in (("left", -half), ("right", half))
        ]
    return result


def _contacts(study: CollapseStudy, mu: float, mu_wall: float) -> list[dict[str, Any]]:
    spec = study.contacts
    common = {"law": "linear", "en2": spec.en2, "kn": spec.kn, "kt_over_kn": spec.kt_over_kn}
    return [{"materials": [GRAIN, GRAIN], "mu": mu, **common}, {"materials": [GRAIN, WALL], "mu": mu_wall, **common}]


def _case(study: CollapseStudy, name: str, duration: float, gravity: list[float], spheres: list[dict[str, Any]],
          wall_list: list[dict[str, Any]], contacts: list[dict[str, Any]], **extra: Any) -> Case:
    return parse_case(
        {
            "name": name,
            "engine": study.engine.value,
            "seed": study.seed,
            "time": {"duration": duration, "output_interval": min(study.release.output_interval, duration),
                     **({"step": study.implicit_step()} if capabilities(study.engine).implicit else {"safety_factor": study.time_safety_factor})},
            **study.engine_sections(),
            "gravity": gravity,
            "materials": [{"name": GRAIN, "density": study.grains.density}, {"name": WALL, "density": 2500.0}],
            "contacts": contacts,
            "bodies": {"spheres": spheres},
            "walls": wall_list,
            "planar": study.dimension == 2,
            **extra,
        },
        source=f"collapse study {study.name}",
    )


def _rain_height(positions: np.ndarray, study: CollapseStudy) -> float:
    return float(max(positions[:, 2].max() + study.grains.diameter * 2, study.bed_top + 1.5 * study.column.height))


def preparation_case(study: CollapseStudy) -> Case:
    """The rain: column and bed grains fall (gravity normal to the bed) and settle behind the gate.

    Bodies: the glued grains first, then the column's grains, then the bed's. Everything that shapes
    the prepared packing is in this case and nothing else, so its hash is the preparation's key.
    """
    rng = np.random.default_rng(study.seed)
    glued, glued_radii = rough_bed(study, rng)
    n_column, n_bed = rain_counts(study)
    column = rain_lattice(study, (-study.column.length, 0.0), n_column, rng)
    bed = rain_lattice(study, (0.0, study.channel.length), n_bed, rng) if n_bed else np.empty((0, 3))
    radii = grain_radii(study, n_column + n_bed, rng)
    spheres = [{"material": GRAIN, "radius": float(r), "position": [float(v) for v in c], "fixed": True} for c, r in zip(glued, glued_radii)]
    spheres += [{"material": GRAIN, "radius": float(r), "position": [float(v) for v in c]} for c, r in zip(np.concatenate([column, bed]), radii)]
    g = 9.81
    height = _rain_height(np.concatenate([column, bed]), study)
    mu = study.preparation.mu
    return _case(study, "preparation", study.preparation.settle_time, [0.0, 0.0, -g], spheres, walls(study, True, height), _contacts(study, mu, mu))


def groups_of(study: CollapseStudy, n_glued: int, positions: np.ndarray) -> dict[str, np.ndarray]:
    """Indices of the glued grains, the column's and the erodible bed's, from prepared positions."""
    index = np.arange(len(positions))
    mobile = index >= n_glued
    return {
        "glued": index[~mobile],
        "column": index[mobile & (positions[:, 0] < 0.0)],
        "bed": index[mobile & (positions[:, 0] >= 0.0)],
    }


def level(study: CollapseStudy, prepared: Trajectory, n_glued: int) -> np.ndarray:
    """Indices of the prepared bodies kept at release: glued grains, column grains with their centre
    at most H0 above the rough layer, bed grains at most h_i above it (a scraper's levelling)."""
    position = prepared.position[-1]
    groups = groups_of(study, n_glued, position)
    z = position[:, 2] - study.bed_top
    column = groups["column"][z[groups["column"]] <= study.column.height]
    bed = groups["bed"][z[groups["bed"]] <= study.bed.erodible_thickness] if study.bed.erodible_thickness > 0 else groups["bed"][:0]
    return np.concatenate([groups["glued"], column, bed])


def gravity_on_slope(slope_deg: float, g: float = 9.81) -> list[float]:
    """Gravity in the channel frame: downslope along +x, into the bed along -z."""
    alpha = math.radians(slope_deg)
    return [g * math.sin(alpha), 0.0, -g * math.cos(alpha)]


def release_case(study: CollapseStudy, prepared: Case, packed: Trajectory) -> Case:
    """The collapse: the levelled grains at rest, the gate gone, gravity tilted to the slope."""
    n_glued = sum(1 for s in prepared.bodies.spheres if s.fixed)
    kept = level(study, packed, n_glued)
    spheres = []
    for k in kept:
        source = prepared.bodies.spheres[k]
        position = source.position if source.fixed else [float(v) for v in packed.position[-1, k]]
        if study.dimension == 2:
            position = [position[0], 0.0, position[2]]
        spheres.append({"material": source.material, "radius": source.radius, "position": position, "fixed": source.fixed})
    height = max(w.edge2[2] for w in prepared.walls if w.name == "back")  # type: ignore[union-attr]
    mu_wall = study.contacts.mu if study.contacts.mu_wall is None else study.contacts.mu_wall
    return _case(study, study.name, study.release.duration, gravity_on_slope(study.channel.slope_deg), spheres,
                 walls(study, False, height), _contacts(study, study.contacts.mu, mu_wall))
