"""The two cases of a collapse study (spec.py): the preparation (grains rained behind the gate and
onto the rough bed) and the release (levelled to H0 and h_i, the gate gone, gravity on the slope)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from orchestrator.case import Case, parse_case
from orchestrator.engines import capabilities
from orchestrator.results import Trajectory
from orchestrator.studies.collapse.grains import grain_radii, rain_counts, rain_lattice, rough_bed
from orchestrator.studies.collapse.spec import GRAIN, WALL, CollapseStudy


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
