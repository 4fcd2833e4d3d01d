"""The grains of a collapse study: their radii, the rough bed's glued monolayer, the rain that fills
the column and the erodible layer (spec.py: the study file; cases.py: the cases made from these)."""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from orchestrator.case import CaseError
from orchestrator.studies.collapse.spec import CollapseStudy

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
