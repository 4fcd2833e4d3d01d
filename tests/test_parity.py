"""Engine parity: the same micro-case on every engine that supports it, against its analytic value.

Restitution e² = (v_out / v_in)² of a body dropped at 0.5 m/s, without gravity, on a wall of the
same law: a sphere on a rectangle wall at its centre, 0.2 mm inside its edge and on its diagonal
(where two triangles meet), on an STL mesh's shared edge and shared vertex; a brick clump landing
flat on 1, 4 and 8 of its spheres at once. Tolerance ±3 % of e² (the bilinear law has no damping,
its only error is the discrete overlap at 100 steps per contact; measured within 0.3 %).
cocd is perfectly inelastic and is not in this matrix.

Known gaps, kept as strict expected failures until they are fixed (measured 2026-11-29):
- YADE emulates the bilinear law with a dashpot sized for one contact, so a body landing on N spheres
  at once is over-damped (damping ratio ∝ √N): e² 0.304 on 4 spheres and 0.198 on 8, for 0.53
  (LIGGGHTS, the compiled law: 0.530 and 0.530).
- YADE meets a sphere once per facet of an STL mesh it touches: e² 0.414 on an edge shared by two
  facets, 0.299 on a vertex shared by four, for 0.53.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from orchestrator.case import Case, parse_case
from orchestrator.results import read_results
from orchestrator.runner import RESULTS, run_case

from conftest import requires_liggghts, requires_yade

EN2 = 0.53
SPEED = 0.5
RADIUS = 0.005
ENGINES = [pytest.param("liggghts", marks=[pytest.mark.engine, requires_liggghts]),
           pytest.param("yade", marks=[pytest.mark.engine, requires_yade])]


def drop_case(engine: str, bodies: dict, walls: list[dict], shapes: list[dict] | None = None) -> Case:
    law = {"law": "bilinear", "en2": EN2, "mu": 0.0, "kn": 1.0e5, "kt_over_kn": 0.4}
    return parse_case({
        "name": "parity", "engine": engine, "gravity": [0.0, 0.0, 0.0],
        "time": {"duration": 0.012, "output_interval": 0.001, "safety_factor": 0.01},
        "materials": [{"name": "ball", "density": 2500.0}, {"name": "board", "density": 2500.0}],
        "contacts": [{"materials": ["ball", "ball"], **law}, {"materials": ["ball", "board"], **law}],
        "shapes": shapes or [], "bodies": bodies, "walls": walls,
    })


def restitution(case: Case, directory: Path) -> float:
    run_case(case, directory, directory / "run")
    velocity = read_results(directory / "run" / RESULTS).velocity[:, 0, 2]
    assert velocity[-1] > 0.0, "the body must have left the wall"
    return float((velocity[-1] / velocity[0]) ** 2)


FLOOR = {"type": "rectangle", "name": "floor", "material": "board", "origin": [-0.1, -0.1, 0.0], "edge1": [0.2, 0.0, 0.0], "edge2": [0.0, 0.2, 0.0]}
SPOTS = {"centre": (0.03, -0.02), "inside_edge": (0.0998, 0.01), "diagonal": (0.02, 0.02)}


@pytest.mark.parametrize("spot", sorted(SPOTS))
@pytest.mark.parametrize("engine", ENGINES)
def test_a_sphere_on_a_rectangle(engine: str, spot: str, tmp_path: Path) -> None:
    x, y = SPOTS[spot]
    ball = {"material": "ball", "radius": RADIUS, "position": [x, y, RADIUS + 1e-4], "velocity": [0.0, 0.0, -SPEED]}
    assert restitution(drop_case(engine, {"spheres": [ball]}, [FLOOR]), tmp_path) == pytest.approx(EN2, rel=0.03)


def write_stl(path: Path, triangles: list[list[list[float]]]) -> None:
    lines = ["solid parity"]
    for a, b, c in triangles:
        lines += ["facet normal 0 0 1", " outer loop", *[f"  vertex {p[0]} {p[1]} {p[2]}" for p in (a, b, c)], " endloop", "endfacet"]
    path.write_text("\n".join(lines + ["endsolid parity"]) + "\n")


# A square of four triangles around its centre: edges shared by two, the centre by all four.
FAN = [[[0.0, 0.0, 0.0], [-0.1, -0.1, 0.0], [0.1, -0.1, 0.0]], [[0.0, 0.0, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0]],
       [[0.0, 0.0, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]], [[0.0, 0.0, 0.0], [-0.1, 0.1, 0.0], [-0.1, -0.1, 0.0]]]
MESH_SPOTS = {"shared_edge": (0.03, 0.03), "shared_vertex": (0.0, 0.0), "inside_triangle": (0.05, -0.01)}


@pytest.mark.parametrize("spot", sorted(MESH_SPOTS))
@pytest.mark.parametrize("engine", ENGINES)
def test_a_sphere_on_an_stl_mesh(engine: str, spot: str, tmp_path: Path, request: pytest.FixtureRequest) -> None:
    if engine == "yade" and spot != "inside_triangle":
        # YADE meets a sphere once per facet it touches (measured e² 0.414 on an edge shared by two,
        # 0.299 on a vertex shared by four, for 0.53); its rectangle walls avoid this as one box.
        request.applymarker(pytest.mark.xfail(strict=True, reason="YADE counts one contact per facet on a mesh's shared edges and vertices"))
    write_stl(tmp_path / "fan.stl", FAN)
    x, y = MESH_SPOTS[spot]
    ball = {"material": "ball", "radius": RADIUS, "position": [x, y, RADIUS + 1e-4], "velocity": [0.0, 0.0, -SPEED]}
    mesh = {"type": "mesh", "name": "floor", "material": "board", "file": "fan.stl"}
    assert restitution(drop_case(engine, {"spheres": [ball]}, [mesh]), tmp_path) == pytest.approx(EN2, rel=0.03)


LAYOUTS = {4: [2, 2, 1], 8: [4, 2, 1]}  # one contact: the sphere cases (LIGGGHTS has no one-sphere clump)


@pytest.mark.parametrize("contacts", sorted(LAYOUTS))
@pytest.mark.parametrize("engine", [
    pytest.param("liggghts", marks=[pytest.mark.engine, requires_liggghts]),
    pytest.param("yade", marks=[pytest.mark.engine, requires_yade]),
])
def test_a_clump_landing_flat_on_several_spheres(engine: str, contacts: int, tmp_path: Path, request: pytest.FixtureRequest) -> None:
    if engine == "yade" and contacts > 1:
        request.applymarker(pytest.mark.xfail(strict=True, reason="YADE's dashpot stand-in over-damps several simultaneous contacts (brick issue)"))
    layout = LAYOUTS[contacts]
    shape = {"name": "brick", "length": 0.031, "width": 0.015, "thickness": 0.008, "layout": layout}
    clump = {"shape": "brick", "material": "ball", "position": [0.0, 0.0, 0.0041], "velocity": [0.0, 0.0, -SPEED]}
    rebound = restitution(drop_case(engine, {"clumps": [clump]}, [FLOOR], [shape]), tmp_path)
    assert rebound == pytest.approx(EN2, rel=0.03), f"{contacts} contacts: e² = {rebound:.4f}"
